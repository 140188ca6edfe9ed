# svms_precompile_headers(): precompiled third-party headers for every C++ target of the build
# (SVMS_PCH, on by default). Called once, after every target exists.
#
# Why: much of the build's time is the compiler's front end on the standard library, Eigen,
# OpenCV, nlohmann::json and gtest, parsed again in each of about 230 files (about 2 s a file
# with GCC 12), and CI builds the tree twice (GCC for `make test`, clang with the sanitizers)
# on 2 cores. One precompiled header per kind of compile line and set of headers, reused by
# every target of that kind (CMake's REUSE_FROM), parses them once per build.
#
# Which headers: those a target may include by the layering rules (docs/architecture.md), found
# from what it links: the standard library for all; Eigen where Eigen3::Eigen is reachable
# through its own links and its dependencies' public ones; OpenCV's core and imgproc where
# OpenCV is; nlohmann::json where it is; gtest for gtest programs. So codec (the standard library
# only) sees no Eigen, and geometry, base and marker see no OpenCV, precompiled or not.
#
# Which compile line: a compiler takes a precompiled header only from a compile line like the
# one that made it. Clang refuses one made with another PIC/PIE mode or other sanitizers, so the
# kinds are libraries (-fPIC), programs (-fPIE), gtest programs, and, under SVMS_FUZZ, libraries
# with libFuzzer's coverage flags. Other macros (a target's own -D) may differ: the headers
# precompiled here do not read them. Each (kind, headers) pair is one anchor target,
# svms_pch_<kind>_<headers>, made when a target needs it.
#
# A target opts out with DISABLE_PRECOMPILE_HEADERS (the fuzz targets, whose own
# -fsanitize=fuzzer no precompiled header matches; the Python module, python/CMakeLists.txt says
# why) or by precompiling its own, a source file with SKIP_PRECOMPILE_HEADERS. With SVMS_PCH=OFF
# every file is compiled on its own includes: the build that shows a missing #include (a
# precompiled header hides it).
option(SVMS_PCH "Precompile the third-party headers most files include" ON)

set(SVMS_PCH_STD_HEADERS
  <algorithm> <array> <atomic> <chrono> <cmath> <cstdint> <cstdio> <cstdlib> <cstring>
  <filesystem> <fstream> <functional> <iostream> <limits> <map> <memory> <mutex> <optional>
  <random> <set> <sstream> <string> <thread> <vector>)

# GCC 12 (Debian 12's) warns of std::string's inlined copies as out of bounds or overflowing
# (-Warray-bounds, -Wstringop-overflow, -Wstringop-overread, in char_traits.h under
# basic_string's operator+) in a file compiled with a precompiled header, and not in the same
# file without one: taken from a precompiled header, libstdc++'s code loses the system-header
# silence for those warnings. So they are off in the files that use one (GCC before 13). What
# they would catch is checked elsewhere: ASan and UBSan at run time on the unit tests, and the
# clang build's own -Warray-bounds; a build with -DSVMS_PCH=OFF has them all.
function(svms_pch_gcc_warnings target)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-array-bounds -Wno-stringop-overflow
      -Wno-stringop-overread)
  endif()
endfunction()

# Every target defined in `dir` and below.
function(_svms_targets_below dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(s ${subdirs})
    _svms_targets_below(${s} below)
    list(APPEND targets ${below})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

# The link items whose headers `target` may include: its own LINK_LIBRARIES, then its
# dependencies' INTERFACE_LINK_LIBRARIES (what they pass on), transitively. $<BUILD_INTERFACE:x>
# counts as x; $<LINK_ONLY:x> (a static library's private link, which passes on no include
# directory) and every other generator expression are left out.
function(_svms_reachable target out)
  set(seen "")
  get_target_property(queue ${target} LINK_LIBRARIES)
  if(NOT queue)
    set(queue "")
  endif()
  while(queue)
    list(POP_FRONT queue item)
    string(REGEX REPLACE "^\\$<BUILD_INTERFACE:(.*)>$" "\\1" item "${item}")
    if(item IN_LIST seen OR item MATCHES "^\\$<")
      continue()
    endif()
    list(APPEND seen ${item})
    if(TARGET ${item})
      get_target_property(aliased ${item} ALIASED_TARGET)
      if(aliased)
        list(APPEND queue ${aliased})
        continue()
      endif()
      get_target_property(more ${item} INTERFACE_LINK_LIBRARIES)
      if(more)
        list(APPEND queue ${more})
      endif()
    endif()
  endwhile()
  set(${out} ${seen} PARENT_SCOPE)
endfunction()

# The anchor of (kind, headers): made on first use; its name in `out`.
function(_svms_pch_anchor kind with_eigen with_opencv with_json out)
  set(name svms_pch_${kind})
  set(headers ${SVMS_PCH_STD_HEADERS})
  set(links "")
  if(with_eigen)
    string(APPEND name _eigen)
    list(APPEND headers <Eigen/Dense>)
    list(APPEND links Eigen3::Eigen)
  endif()
  if(with_opencv)
    string(APPEND name _opencv)
    list(APPEND headers <opencv2/core.hpp> <opencv2/imgproc.hpp>)
    list(APPEND links opencv_core opencv_imgproc)
  endif()
  if(with_json)
    string(APPEND name _json)
    list(APPEND headers <nlohmann/json.hpp>)
    list(APPEND links nlohmann_json::nlohmann_json)
  endif()
  if(kind STREQUAL "test")
    list(APPEND headers <gtest/gtest.h>)
    list(APPEND links GTest::gtest)
  endif()
  set(${out} ${name} PARENT_SCOPE)
  if(TARGET ${name})
    return()
  endif()
  # An object library: only compiled, never linked.
  set(src ${CMAKE_BINARY_DIR}/svms_pch/${name}.cc)
  if(NOT EXISTS ${src})
    file(WRITE ${src} "// The anchor of a precompiled header (cmake/SvmsPrecompiledHeaders.cmake).\n")
  endif()
  add_library(${name} OBJECT EXCLUDE_FROM_ALL ${src})
  target_link_libraries(${name} PRIVATE ${links})
  if(kind STREQUAL "exe" OR kind STREQUAL "test")
    # Programs are compiled with -fPIE (CMAKE_POSITION_INDEPENDENT_CODE), objects with -fPIC.
    set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE OFF)
    target_compile_options(${name} PRIVATE -fPIE)
  elseif(kind STREQUAL "cov")
    target_compile_options(${name} PRIVATE ${SVMS_FUZZ_COVERAGE_FLAGS})
  endif()
  # C++ only: the anchor has no C source, so no C target could reuse it.
  target_precompile_headers(${name} PRIVATE ${headers})
endfunction()

function(svms_precompile_headers)
  if(NOT SVMS_PCH)
    return()
  endif()
  _svms_targets_below(${PROJECT_SOURCE_DIR} targets)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    get_target_property(disabled ${t} DISABLE_PRECOMPILE_HEADERS)
    get_target_property(own ${t} PRECOMPILE_HEADERS)
    if(disabled OR own OR NOT type MATCHES "EXECUTABLE|LIBRARY" OR type STREQUAL "INTERFACE_LIBRARY")
      continue()
    endif()
    # A C program (the C API's test) has no C++ header to reuse.
    get_target_property(sources ${t} SOURCES)
    if(NOT sources MATCHES "\\.cc(;|$)")
      continue()
    endif()
    _svms_reachable(${t} reach)
    set(kind lib)
    if(type STREQUAL "EXECUTABLE")
      set(kind exe)
      if(SVMS_BUILD_TESTS AND reach MATCHES "(^|;)GTest::")
        set(kind test)
      endif()
    else()
      get_target_property(options ${t} COMPILE_OPTIONS)
      if(SVMS_FUZZ AND options MATCHES "fuzzer-no-link")
        set(kind cov)
      endif()
    endif()
    set(eigen OFF)
    set(opencv OFF)
    set(json OFF)
    if(reach MATCHES "(^|;)Eigen3::Eigen(;|$)")
      set(eigen ON)
    endif()
    if(reach MATCHES "(^|;)opencv_core(;|$)")
      set(opencv ON)
    endif()
    if(reach MATCHES "(^|;)nlohmann_json::nlohmann_json(;|$)")
      set(json ON)
    endif()
    _svms_pch_anchor(${kind} ${eigen} ${opencv} ${json} anchor)
    target_precompile_headers(${t} REUSE_FROM ${anchor})
    svms_pch_gcc_warnings(${t})
  endforeach()
endfunction()
