# FindCHOLMOD.cmake — SuiteSparse's sparse Cholesky (CHOLMOD), for Eigen's
# <Eigen/CholmodSupport>.
#
# Defines the imported target CHOLMOD::CHOLMOD (include directory holding
# cholmod.h, libcholmod and libsuitesparseconfig) and CHOLMOD_FOUND,
# CHOLMOD_INCLUDE_DIR, CHOLMOD_LIBRARY, CHOLMOD_VERSION.
#
# SuiteSparse ≥ 7 installs CMake package files (target SuiteSparse::CHOLMOD);
# they are used when present. SuiteSparse 5.x (Debian 12: libsuitesparse-dev)
# ships none, so the header and the libraries are searched for directly.

find_package(CHOLMOD CONFIG QUIET)
if(CHOLMOD_FOUND AND NOT TARGET CHOLMOD::CHOLMOD)
  if(TARGET SuiteSparse::CHOLMOD)
    add_library(CHOLMOD::CHOLMOD INTERFACE IMPORTED)
    target_link_libraries(CHOLMOD::CHOLMOD INTERFACE SuiteSparse::CHOLMOD)
  elseif(TARGET SuiteSparse::CHOLMOD_static)
    add_library(CHOLMOD::CHOLMOD INTERFACE IMPORTED)
    target_link_libraries(CHOLMOD::CHOLMOD INTERFACE SuiteSparse::CHOLMOD_static)
  else()
    set(CHOLMOD_FOUND FALSE)  # a package file without the expected target: search by hand
  endif()
endif()

if(NOT TARGET CHOLMOD::CHOLMOD)
  find_path(CHOLMOD_INCLUDE_DIR NAMES cholmod.h PATH_SUFFIXES suitesparse SuiteSparse)
  find_library(CHOLMOD_LIBRARY NAMES cholmod)
  find_library(CHOLMOD_SUITESPARSECONFIG_LIBRARY NAMES suitesparseconfig)

  if(CHOLMOD_INCLUDE_DIR AND EXISTS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h")
    set(_cholmod_version_header "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h")
  elseif(CHOLMOD_INCLUDE_DIR)
    set(_cholmod_version_header "${CHOLMOD_INCLUDE_DIR}/cholmod.h")
  endif()
  if(_cholmod_version_header)
    foreach(_part MAIN SUB SUBSUB)
      file(STRINGS "${_cholmod_version_header}" _line REGEX "^#define[ \t]+CHOLMOD_${_part}_VERSION[ \t]+[0-9]+")
      string(REGEX REPLACE ".*CHOLMOD_${_part}_VERSION[ \t]+([0-9]+).*" "\\1" _cholmod_${_part} "${_line}")
    endforeach()
    if(_cholmod_MAIN MATCHES "^[0-9]+$" AND _cholmod_SUB MATCHES "^[0-9]+$" AND _cholmod_SUBSUB MATCHES "^[0-9]+$")
      set(CHOLMOD_VERSION "${_cholmod_MAIN}.${_cholmod_SUB}.${_cholmod_SUBSUB}")
    endif()
  endif()

  include(FindPackageHandleStandardArgs)
  find_package_handle_standard_args(CHOLMOD
    REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_SUITESPARSECONFIG_LIBRARY CHOLMOD_INCLUDE_DIR
    VERSION_VAR CHOLMOD_VERSION
    REASON_FAILURE_MESSAGE "CHOLMOD (SuiteSparse) is required (Debian: libsuitesparse-dev)")

  if(CHOLMOD_FOUND)
    add_library(CHOLMOD::CHOLMOD UNKNOWN IMPORTED)
    set_target_properties(CHOLMOD::CHOLMOD PROPERTIES
      IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
      INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${CHOLMOD_SUITESPARSECONFIG_LIBRARY}")
  endif()
  mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY CHOLMOD_SUITESPARSECONFIG_LIBRARY)
else()
  set(CHOLMOD_FOUND TRUE)
endif()
