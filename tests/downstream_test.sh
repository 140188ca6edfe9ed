#!/usr/bin/env bash
# Installs the build into a scratch prefix, then builds against it as a user would:
#  - tests/downstream (C++) with find_package(svms COMPONENTS ...);
#  - tests/downstream/pose.c (C) with pkg-config's svms.pc, run on the C API fixture's frame;
# and checks that the installed libsvms_c needs nothing of the simulator, the artwork, the image
# codecs or the benchmarks' peers, and exports only the C API; that the svms command links
# neither the benchmarks nor their peers (AprilTag, ArUco), which only the svms-bench program of
# the build does; that the installed svms, without svms-bench, says so in one line; and that the
# installed Python package (when built) loads the installed libraries and gives the fused pose.
set -euo pipefail
build=${1:?build dir}; src=${2:?source dir}; fixture=${3:?capi fixture dir}
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
prefix=$scratch/prefix
cmake --install "$build" --prefix "$prefix" > "$scratch/install.log"
fail() { echo "downstream: $*" >&2; exit 1; }

# C++: find_package with components.
cmake -S "$src/tests/downstream" -B "$scratch/build" -DCMAKE_PREFIX_PATH="$prefix" > "$scratch/configure.log" \
  || { cat "$scratch/configure.log"; exit 1; }
cmake --build "$scratch/build" > "$scratch/build.log" 2>&1 || { cat "$scratch/build.log"; exit 1; }
"$scratch/build/downstream"
# An unknown component is refused by name.
mkdir -p "$scratch/bad"
printf 'cmake_minimum_required(VERSION 3.25)\nproject(bad CXX)\nfind_package(svms REQUIRED COMPONENTS nosuchmodule)\n' \
  > "$scratch/bad/CMakeLists.txt"
if cmake -S "$scratch/bad" -B "$scratch/bad/build" -DCMAKE_PREFIX_PATH="$prefix" > "$scratch/bad.log" 2>&1; then
  fail "find_package(svms COMPONENTS nosuchmodule) succeeded"
fi
grep -q "nosuchmodule" "$scratch/bad.log" || fail "the unknown component is not named: $(cat "$scratch/bad.log")"

# C: pkg-config from the install prefix, then the fused pose on the demo frame.
pc=$(find "$prefix" -name svms.pc | head -1)
[ -n "$pc" ] || fail "no svms.pc installed"
export PKG_CONFIG_PATH=$(dirname "$pc")
flags=$(pkg-config --cflags --libs svms)
cc -std=c99 -Wall -Werror -o "$scratch/pose" "$src/tests/downstream/pose.c" $flags -lm
libdir=$(pkg-config --variable=libdir svms)
LD_LIBRARY_PATH=$libdir "$scratch/pose" "$fixture"

# The installed libraries find each other without LD_LIBRARY_PATH (their RUNPATH), and the
# installed command runs.
if ldd "$(ls "$libdir"/libsvms_c.so.* | head -1)" | grep -q "not found"; then
  fail "libsvms_c does not find its libraries from the install: $(ldd "$(ls "$libdir"/libsvms_c.so.* | head -1)" | grep 'not found')"
fi
"$prefix/bin/svms" --version > /dev/null || fail "the installed svms does not run"

# libsvms_c: what it needs, and what it exports.
lib=$(ls "$libdir"/libsvms_c.so.* | head -1)
needed=$(readelf -d "$lib" | sed -n 's/.*NEEDED.*\[\(.*\)\]/\1/p')
echo "libsvms_c needs: $(echo $needed)"
all=$(LD_LIBRARY_PATH=$libdir ldd "$lib")
for forbidden in libsvms_sim libsvms_print libsvms_datasets libsvms_imageio libcairo libapriltag \
    libopencv_aruco libopencv_imgcodecs libgdal libgdcm libhdf5; do
  if grep -q "$forbidden" <<< "$all"; then fail "libsvms_c depends on $forbidden"; fi
done
exported=$(nm -D --defined-only "$lib" | awk '{print $3}' | grep -v '^$')
others=$(grep -v '^svms_' <<< "$exported" || true)
[ -z "$others" ] || fail "libsvms_c exports more than svms_*: $(echo $others | head -c 300)"
echo "libsvms_c exports $(wc -l <<< "$exported") symbols, all svms_*"

# The svms command (built and installed): no benchmark code and no peers, directly (readelf -d)
# or through its libraries (ldd); the benchmarks are the svms-bench program's, which must link
# them (else the checks above would prove nothing).
for svms in "$build/bin/svms" "$prefix/bin/svms"; do
  needed=$(readelf -d "$svms" | sed -n 's/.*NEEDED.*\[\(.*\)\]/\1/p')
  all=$(ldd "$svms")
  for forbidden in libapriltag libopencv_aruco libsvms_bench libsvms_peers; do
    if grep -q "$forbidden" <<< "$needed$all"; then fail "$svms links $forbidden"; fi
  done
  symbols=$(nm -C "$svms")
  if grep -q "svms::PeerDetector\|svms::RunCompareBenchmark" <<< "$symbols"; then
    fail "$svms holds the benchmarks' code (svms::PeerDetector, svms::RunCompareBenchmark)"
  fi
done
bench=$build/bin/svms-bench
grep -q libapriltag <<< "$(ldd "$bench")" || fail "$bench does not link AprilTag: the checks of svms prove nothing"
grep -q "svms::PeerDetector" <<< "$(nm -C "$bench")" || fail "$bench holds no svms::PeerDetector"
[ ! -e "$prefix/bin/svms-bench" ] || fail "svms-bench is installed; the benchmarks are not shipped"
echo "svms links no benchmark and no peer; svms-bench does"
# `svms bench` in the install: one line naming svms-bench, exit 2, nothing written.
set +e
"$prefix/bin/svms" bench detect --quick --out "$scratch/bench" > "$scratch/bench.out" 2> "$scratch/bench.err"
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "svms bench without svms-bench: exit $rc, expected 2"
[ "$(wc -l < "$scratch/bench.err")" -eq 1 ] && grep -q "svms-bench not found" "$scratch/bench.err" \
  || fail "svms bench without svms-bench: expected one line naming svms-bench, got: $(cat "$scratch/bench.err")"
[ ! -e "$scratch/bench" ] || fail "svms bench without svms-bench wrote $scratch/bench"

# The Python package, when the build has it (SVMS_BUILD_PYTHON): installed under the prefix's
# lib/python3.X/dist-packages, it loads the installed libraries through its RUNPATH (not the
# build's) and computes the fused pose of the fixture's frame.
pkg=$(find "$prefix" -path '*dist-packages/svms/__init__.py' | head -1)
if [ -f "$build/python/svms/__init__.py" ]; then
  [ -n "$pkg" ] || fail "the build has the Python package, the install does not"
  pydir=$(dirname "$(dirname "$pkg")")
  ext=$(ls "$pydir"/svms/_svms*.so)
  if ldd "$ext" | grep -q "not found"; then fail "the installed svms._svms misses: $(ldd "$ext" | grep 'not found')"; fi
  ldd "$ext" | grep libsvms_ | grep -qv "$prefix" && fail "the installed svms._svms loads libraries from outside the prefix: $(ldd "$ext" | grep libsvms_)"
  python=$(sed -n 's/^Python_EXECUTABLE:[A-Z]*=//p' "$build/CMakeCache.txt")
  (cd "$scratch" && PYTHONPATH="$pydir" "${python:-/usr/bin/python3}" - "$fixture" "$pydir" <<'PY') || fail "the installed Python package does not work"
import os, sys
import numpy as np
import svms
fixture, pydir = sys.argv[1], sys.argv[2]
assert svms.__file__.startswith(pydir), svms.__file__
camera = svms.Camera(os.path.join(fixture, "true.cameramodel"))
frame = np.fromfile(os.path.join(fixture, "frame_11.raw"), np.uint8).reshape(camera.height, camera.width)
pose = svms.PoseEstimator(camera, os.path.join(fixture, "true_layout.json")).estimate(frame, 0).pose
assert pose.valid, pose.message
print(f"the installed Python package: {pose.markers_used} markers, range {np.linalg.norm(pose.cam_from_object.tvec):.3f} m")
PY
fi
