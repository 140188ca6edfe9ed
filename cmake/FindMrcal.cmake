# FindMrcal: mrcal's C library (https://mrcal.secretsauce.net/), e.g. Debian's libmrcal-dev.
# mrcal ships neither a pkg-config file nor a CMake package, so we look for the header and the
# library ourselves.
#
# Result: the imported target mrcal::mrcal, and the variables Mrcal_FOUND, Mrcal_INCLUDE_DIR,
# Mrcal_LIBRARY and Mrcal_VERSION (taken from the library's file name, libmrcal.so.2.2 -> 2.2;
# empty if the name does not carry it). Hints: Mrcal_ROOT or CMAKE_PREFIX_PATH.
#
# Note: mrcal/mrcal.h has no extern "C" guard; C++ code must include it inside extern "C" { }.

find_path(Mrcal_INCLUDE_DIR NAMES mrcal/mrcal.h DOC "Directory that holds mrcal/mrcal.h")
find_library(Mrcal_LIBRARY NAMES mrcal DOC "The mrcal C library")

set(Mrcal_VERSION "")
if(Mrcal_LIBRARY)
  file(REAL_PATH "${Mrcal_LIBRARY}" _mrcal_real_library)
  if(_mrcal_real_library MATCHES "\\.so\\.([0-9]+(\\.[0-9]+)*)$")
    set(Mrcal_VERSION "${CMAKE_MATCH_1}")
  endif()
  unset(_mrcal_real_library)
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Mrcal
  REQUIRED_VARS Mrcal_LIBRARY Mrcal_INCLUDE_DIR
  VERSION_VAR Mrcal_VERSION)

if(Mrcal_FOUND AND NOT TARGET mrcal::mrcal)
  add_library(mrcal::mrcal UNKNOWN IMPORTED)
  set_target_properties(mrcal::mrcal PROPERTIES
    IMPORTED_LOCATION "${Mrcal_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${Mrcal_INCLUDE_DIR}")
endif()

mark_as_advanced(Mrcal_INCLUDE_DIR Mrcal_LIBRARY)
