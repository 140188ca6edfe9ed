# svms_add_module(<name> SOURCES ... [PUBLIC ...] [PRIVATE ...] [INTERNAL_HEADERS ...])
#
# One module of SVMS: the folder svms/<name>/ under the current source directory, the library
# svms_<name> (alias svms::<name>, exported as svms::<name>) and the include prefix
# "svms/<name>/". Its headers are installed under include/svms/<name>/, except INTERNAL_HEADERS
# (shared between modules inside the build, never part of the installed interface). Without
# SOURCES the module is header-only (an INTERFACE library).
#
# Modules are shared libraries so that a program links only what it uses and a module's
# private dependencies (cairo for print, mrcal for camera) do not reach its users' link lines.
# docs/architecture.md lists what each module may depend on; tests/module_dependencies_test.sh
# checks the built libraries against that list.
function(svms_add_module name)
  cmake_parse_arguments(M "" "" "SOURCES;PUBLIC;PRIVATE;INTERNAL_HEADERS" ${ARGN})
  set(target svms_${name})
  if(M_SOURCES)
    add_library(${target} SHARED ${M_SOURCES})
    # Installed beside each other: a module finds the modules it needs in its own directory,
    # whatever the libdir is (lib, lib64, lib/x86_64-linux-gnu).
    set_target_properties(${target} PROPERTIES OUTPUT_NAME svms_${name}
      VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR}
      INSTALL_RPATH "$ORIGIN")
    target_include_directories(${target} PUBLIC
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${target} PUBLIC ${M_PUBLIC} PRIVATE ${M_PRIVATE})
    target_compile_features(${target} PUBLIC cxx_std_17)
    # SVMS_FUZZ: libFuzzer's coverage on the modules the fuzz targets reach
    # (SVMS_FUZZ_COVERAGE_MODULES, top CMakeLists.txt).
    if(name IN_LIST SVMS_FUZZ_COVERAGE_MODULES)
      target_compile_options(${target} PRIVATE ${SVMS_FUZZ_COVERAGE_FLAGS})
    endif()
  else()
    add_library(${target} INTERFACE)
    target_include_directories(${target} INTERFACE
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${target} INTERFACE ${M_PUBLIC})
    target_compile_features(${target} INTERFACE cxx_std_17)
  endif()
  add_library(svms::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  install(TARGETS ${target} EXPORT svmsTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  set(excludes PATTERN "*_test*" EXCLUDE)
  foreach(h ${M_INTERNAL_HEADERS})
    list(APPEND excludes PATTERN ${h} EXCLUDE)
  endforeach()
  install(DIRECTORY svms/${name} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/svms
    FILES_MATCHING PATTERN "*.h" ${excludes})
  set_property(GLOBAL APPEND PROPERTY SVMS_MODULES ${name})
endfunction()

# svms_add_module_tests(<name> SOURCES ... LIBS ...): the module's gtest program,
# svms_<name>_tests, discovered into ctest with the label "unit".
function(svms_add_module_tests name)
  cmake_parse_arguments(T "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT SVMS_BUILD_TESTS)
    return()
  endif()
  add_executable(svms_${name}_tests ${T_SOURCES})
  target_link_libraries(svms_${name}_tests PRIVATE svms::${name} ${T_LIBS} ${OpenCV_LIBS} svms_test_support
    GTest::gtest_main)
  gtest_discover_tests(svms_${name}_tests DISCOVERY_TIMEOUT 60 PROPERTIES LABELS unit)
  add_dependencies(unit_tests svms_${name}_tests)
endfunction()
