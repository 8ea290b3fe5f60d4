"""Builds the package with the impostor.v1 stubs generated from proto/.

From the build tree (build/python, made by python/CMakeLists.txt) the stubs
are already in impostor/v1 and are packaged as they are. From the source
tree (`pip install --no-build-isolation ./python`) they are generated here
into the build directory, with the system `protoc` and `grpc_python_plugin`
(Debian: protobuf-compiler, protobuf-compiler-grpc) from ../proto, or from
$IMPOSTOR_PROTO_DIR. Nothing generated is written into the source tree.
"""
import os
import shutil
import subprocess
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
PROTOS = ["types", "bake_service", "asset_service", "worker_service"]


class BuildPyWithStubs(build_py):
    def run(self) -> None:
        super().run()
        if all((HERE / "impostor" / "v1" / f"{p}_pb2.py").exists() for p in PROTOS):
            return  # the build tree: copied by super().run()
        proto_dir = Path(os.environ.get("IMPOSTOR_PROTO_DIR", HERE.parent / "proto"))
        protoc = shutil.which("protoc")
        plugin = shutil.which("grpc_python_plugin")
        if not (proto_dir / "impostor" / "v1" / "types.proto").exists():
            raise SystemExit(f"impostor: no protos at {proto_dir}; set IMPOSTOR_PROTO_DIR to the repo's proto/")
        if protoc is None or plugin is None:
            raise SystemExit("impostor: protoc and grpc_python_plugin are needed "
                             "(apt-get install protobuf-compiler protobuf-compiler-grpc)")
        subprocess.run(
            [protoc, f"--proto_path={proto_dir}", f"--python_out={self.build_lib}", f"--pyi_out={self.build_lib}",
             f"--grpc_out={self.build_lib}", f"--plugin=protoc-gen-grpc={plugin}",
             *[str(proto_dir / "impostor" / "v1" / f"{p}.proto") for p in PROTOS]],
            check=True)


setup(cmdclass={"build_py": BuildPyWithStubs})
