#!/usr/bin/env python3
"""The dependency direction of the C++ tree, checked (issue 42).

Between top-level folders: common/ is used by worker/, server/ and client/
and uses none of them; those three never include each other. Inside
server/, common/ and client/ each folder ("room") has a level, and a file
may include only rooms at its own level or below, so no import runs back up
(e.g. server/store/ never includes server/scheduler/). Each room's README.md
says what lives there.

Usage: include_rules.py [REPO_ROOT]   exit 0 when every include follows the
rules, 1 with one line per offending include otherwise.
"""
import os
import re
import sys

# Folders that may not include each other (besides common/, which all use).
MODULES = ['common', 'worker', 'server', 'client']
MAY_USE = {
    'common': {'common'},
    'worker': {'worker', 'common'},
    'server': {'server', 'common'},
    'client': {'client', 'common'},
}

# Rooms and their levels, longest prefix first wins. A file directly in the
# module's folder gets the level given for the module name itself.
LEVELS = {
    # server: the blob store at the bottom, the daemon's wiring on top.
    'server/blobs': 0,
    'server/store': 1,       # store/sqlite, store/postgres
    'server/auth': 2,
    'server/scheduler': 3,
    'server/rpc': 4,
    'server/metrics': 5,
    'server/http': 6,
    'server/commands': 7,
    'server': 8,             # main.cc, worker_supervisor
    # common: helpers at the bottom, requests and manifests above them.
    'common': 0,             # error_reason.h, worker_exit_codes.h: leaf headers
    'common/util': 0,
    'common/quality': 0,
    'common/atlas': 1,
    'common/net': 1,
    'common/flags': 1,
    'common/runtime': 2,
    'common/request': 2,
    'common/manifest': 2,
    # client: the public headers and logging at the bottom, the CLI on top.
    'client/include': 0,
    'client/base': 0,
    'client/lod': 0,
    'client/runtime': 0,
    'client/transport': 1,
    'client/transfer': 2,
    'client': 3,             # client.cc, the SDK's entry points
    'client/delivery': 3,
    'client/cache': 4,
    'client/cli': 5,
}

# Modules whose rooms are levelled (worker/'s folders are not, yet).
LEVELED = {'server', 'common', 'client'}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
SOURCE = re.compile(r'\.(cc|h|cpp|c)$')


def room_of(path):
    best = None
    for prefix in LEVELS:
        if path == prefix or path.startswith(prefix + '/'):
            if best is None or len(prefix) > len(best):
                best = prefix
    return best


def resolve(root, included):
    """The repository path an include names, or None (system, generated)."""
    if os.path.isfile(os.path.join(root, included)):
        return included
    public = os.path.join('client/include', included)
    if included.startswith('impostor/') and os.path.isfile(os.path.join(root, public)):
        return public
    return None


def check(root):
    problems = []
    for module in MODULES:
        for folder, _, files in os.walk(os.path.join(root, module)):
            for name in files:
                if not SOURCE.search(name):
                    continue
                path = os.path.relpath(os.path.join(folder, name), root)
                with open(os.path.join(root, path), encoding='utf-8', errors='replace') as f:
                    text = f.read()
                for m in INCLUDE.finditer(text):
                    target = resolve(root, m.group(1))
                    if target is None:
                        continue
                    line = text.count('\n', 0, m.start()) + 1
                    to_module = target.split('/', 1)[0]
                    if to_module in MODULES and to_module not in MAY_USE[module]:
                        problems.append(f'{path}:{line}: {module}/ may not include {target}')
                        continue
                    if to_module != module or module not in LEVELED:
                        continue
                    a, b = room_of(path), room_of(target)
                    if a is None or b is None:
                        problems.append(f'{path}:{line}: no level for {path if a is None else target} '
                                        f'(add its folder to LEVELS in {os.path.basename(__file__)})')
                    elif LEVELS[b] > LEVELS[a]:
                        problems.append(f'{path}:{line}: {a}/ (level {LEVELS[a]}) includes {target} '
                                        f'from {b}/ (level {LEVELS[b]}): an import back up')
    return problems


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), '..', '..')
    problems = check(os.path.abspath(root))
    for p in problems:
        print(p)
    if problems:
        print(f'{len(problems)} include(s) break the dependency direction')
        return 1
    print('include rules hold')
    return 0


if __name__ == '__main__':
    sys.exit(main())
