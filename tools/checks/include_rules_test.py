#!/usr/bin/env python3
"""include_rules.py checked both ways: a small tree with an import back up
and a common/ file reaching into server/ must fail with those lines named,
the same tree without them must pass, and then the repository itself must
hold the rules."""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK = os.path.join(HERE, 'include_rules.py')


def write(root, path, text):
    full = os.path.join(root, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, 'w') as f:
        f.write(text)


def run(root):
    p = subprocess.run([sys.executable, CHECK, root], capture_output=True, text=True)
    return p.returncode, p.stdout


def main():
    failures = []
    with tempfile.TemporaryDirectory(prefix='include_rules_test_') as root:
        write(root, 'server/scheduler/bake_scheduler.h', '#include "server/store/job_store.h"\n')
        write(root, 'server/store/job_store.h', '#include <string>\n')
        write(root, 'common/util/sha256.h', '')
        write(root, 'client/transport/retry.h', '#include "common/util/sha256.h"\n')
        rc, out = run(root)
        if rc != 0:
            failures.append(f'a tree that follows the rules failed:\n{out}')
        # An import back up: the store reaching into the scheduler.
        write(root, 'server/store/job_store.h', '#include "server/scheduler/bake_scheduler.h"\n')
        # common/ reaching into server/, client/ into worker/.
        write(root, 'common/util/sha256.h', '#include "server/store/job_store.h"\n')
        write(root, 'worker/worker_loop.h', '')
        write(root, 'client/transport/retry.h', '#include "worker/worker_loop.h"\n')
        # client/transport/ using client/transfer/ (a level above it).
        write(root, 'client/transfer/blob_download.h', '#include "client/transport/retry.h"\n')
        write(root, 'client/transport/transport.h', '#include "client/transfer/blob_download.h"\n')
        rc, out = run(root)
        expected = [
            'server/store/job_store.h:1: server/store/ (level 1) includes server/scheduler/bake_scheduler.h',
            'common/util/sha256.h:1: common/ may not include server/store/job_store.h',
            'client/transport/retry.h:1: client/ may not include worker/worker_loop.h',
            'client/transport/transport.h:1: client/transport/ (level 1) includes client/transfer/blob_download.h',
        ]
        if rc != 1:
            failures.append(f'a tree breaking the rules passed (rc {rc}):\n{out}')
        for e in expected:
            if e not in out:
                failures.append(f'missing from the report: {e}\n{out}')
        if '4 include(s) break' not in out:
            failures.append(f'expected exactly 4 offending includes:\n{out}')
    rc, out = run(os.path.join(HERE, '..', '..'))
    if rc != 0:
        failures.append(f'the repository breaks its include rules:\n{out}')
    for f in failures:
        print('FAIL:', f)
    if not failures:
        print('include rules: the checker catches what it should, and the tree holds them')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
