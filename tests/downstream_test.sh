#!/usr/bin/env bash
# Installs the build into a scratch prefix, then builds against it as a user would:
#  - tests/downstream (C++) with find_package(svms COMPONENTS ...);
#  - tests/downstream/pose.c (C) with pkg-config's svms.pc, run on the C API fixture's frame;
# and checks that the installed libsvms_c needs nothing of the simulator, the artwork, the image
# codecs or the benchmarks' peers, and exports only the C API.
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
