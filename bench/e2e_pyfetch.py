"""One `impostor.Client.fetch` of a farm result for bench/e2e_fetch.py (what a
Python script or the Blender add-on runs): prints {"seconds": ...}, the fetch
alone, the interpreter's start and imports not counted (the bench times the
whole process beside it).

    e2e_pyfetch.py KEY OUT_DIR SERVER TOKEN_FILE FARM_HTTP   (FARM_HTTP: a URL or "none")
"""
import json
import sys
import time

import impostor


def main():
    key, out, server, token_file, farm_http = sys.argv[1:6]
    with impostor.Client(server, token_file=token_file, farm_http=farm_http) as client:
        t0 = time.perf_counter()
        result = client.fetch(key, out)
        seconds = time.perf_counter() - t0
    print(json.dumps({"seconds": seconds, "files": len(result.files)}))


if __name__ == "__main__":
    main()
