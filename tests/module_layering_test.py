#!/usr/bin/env python3
"""Checks the modules' layering (docs/architecture.md) against the sources.

usage: module_layering_test.py SOURCE_DIR BUILD_DIR

BUILD_DIR/svms_modules.txt holds each module's direct dependencies as the build declares them
(top CMakeLists.txt). Every non-test source file of a module may include headers only of its
own module and of the modules it depends on (transitively); the modules a flight program links
(the C API and everything it reaches, and calib and bundle) must not reach the simulator, the
artwork, the datasets, the commands' pipelines, the benchmarks or their peers, or the image
codecs (imageio); and every header lives in a module folder.
Exits 1 with one line per violation.
"""
import os
import re
import sys

src, build = sys.argv[1], sys.argv[2]
deps = {}
for line in open(os.path.join(build, 'svms_modules.txt')):
    if ':' in line:
        name, rest = line.split(':', 1)
        deps[name.strip()] = rest.split()


def closure(m, seen=None):
    seen = set() if seen is None else seen
    for d in deps.get(m, []):
        if d not in seen:
            seen.add(d)
            closure(d, seen)
    return seen


LIBSVMS = {'geometry', 'base', 'codec', 'marker', 'camera', 'imageio', 'detect', 'sim', 'print'}
folder = {m: os.path.join('libsvms', 'svms', m) if m in LIBSVMS else os.path.join(m, 'svms', m)
          for m in deps if m != 'c'}
folder['c'] = 'capi'
problems = []
expected = LIBSVMS | {'calib', 'bundle', 'fusion', 'datasets', 'pipelines', 'peers', 'bench',
                      'c'}
if set(deps) != expected:
    problems.append(f'svms_modules.txt lists {sorted(deps)}, expected {sorted(expected)}')

include = re.compile(r'#include\s+["<]svms/([a-z]+)/[^">]+[">]')
for m, d in folder.items():
    allowed = closure(m) | {m}
    path = os.path.join(src, d)
    for name in sorted(os.listdir(path)):
        if not re.search(r'\.(h|cc|c)$', name) or '_test' in name:
            continue
        for n, line in enumerate(open(os.path.join(path, name)), 1):
            mm = include.search(line)
            if mm and mm.group(1) not in allowed:
                problems.append(f'{d}/{name}:{n}: module {m} includes svms/{mm.group(1)}/, '
                                f'which it does not depend on (it may use: {sorted(allowed)})')

# The Python package (python/src/) is no module: its includes must stay within the modules its
# extension links (python/CMakeLists.txt, target_link_libraries(svms_python ...)) and theirs.
python_cmake = os.path.join(src, 'python', 'CMakeLists.txt')
if os.path.exists(python_cmake):
    text = open(python_cmake).read()
    link = re.search(r'target_link_libraries\(svms_python\b(.*?)\)', text, re.S)
    linked = set(re.findall(r'svms::([a-z]+)', link.group(1))) if link else set()
    allowed = set(linked)
    for m in linked:
        allowed |= closure(m)
    pysrc = os.path.join(src, 'python', 'src')
    for name in sorted(os.listdir(pysrc)):
        if not re.search(r'\.(h|cc)$', name):
            continue
        for n, line in enumerate(open(os.path.join(pysrc, name)), 1):
            mm = include.search(line)
            if mm and mm.group(1) not in allowed:
                problems.append(f'python/src/{name}:{n}: includes svms/{mm.group(1)}/, which the '
                                f'extension does not link (it may use: {sorted(allowed)})')

FLIGHT = ['c', 'fusion', 'calib', 'bundle', 'detect', 'camera', 'marker', 'codec', 'base',
          'geometry']
for m in FLIGHT:
    bad = closure(m) & {'sim', 'print', 'datasets', 'pipelines', 'peers', 'bench', 'imageio'}
    if bad:
        problems.append(f'module {m} (linked by flight programs) depends on {sorted(bad)}')

# Headers outside a module folder (the include prefix would not say the module).
for top in ['libsvms/svms', 'calib/svms', 'bundle/svms', 'fusion/svms', 'datasets/svms',
            'pipelines/svms', 'peers/svms', 'bench/svms']:
    for name in os.listdir(os.path.join(src, top)):
        if os.path.isfile(os.path.join(src, top, name)):
            problems.append(f'{top}/{name}: not in a module folder ({top}/<module>/)')

for p in problems:
    print(p)
print(f'{len(deps)} modules, {len(problems)} layering problems')
sys.exit(1 if problems else 0)
