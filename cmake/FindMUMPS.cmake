# FindMUMPS.cmake — the sequential build of MUMPS (multifrontal sparse direct
# solver), double precision, for symmetric indefinite LDLᵀ factorizations with
# pivoting and their inertia (solve_sparse_modes).
#
# Defines the imported target MUMPS::MUMPS and MUMPS_FOUND, MUMPS_INCLUDE_DIR,
# MUMPS_LIBRARY. Debian 12: libmumps-seq-dev, which installs dmumps_c.h in
# /usr/include and the sequential stand-in for MPI (mpi.h, libmpiseq_seq) in
# /usr/include/mumps_seq; the libraries carry the suffix _seq.

find_path(MUMPS_INCLUDE_DIR NAMES dmumps_c.h)
find_path(MUMPS_MPISEQ_INCLUDE_DIR NAMES mpi.h PATH_SUFFIXES mumps_seq NO_DEFAULT_PATH
          PATHS /usr/include /usr/local/include)
find_library(MUMPS_LIBRARY NAMES dmumps_seq)
find_library(MUMPS_COMMON_LIBRARY NAMES mumps_common_seq)
find_library(MUMPS_MPISEQ_LIBRARY NAMES mpiseq_seq)
find_library(MUMPS_PORD_LIBRARY NAMES pord_seq)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(MUMPS
  REQUIRED_VARS MUMPS_LIBRARY MUMPS_COMMON_LIBRARY MUMPS_MPISEQ_LIBRARY MUMPS_PORD_LIBRARY MUMPS_INCLUDE_DIR
                MUMPS_MPISEQ_INCLUDE_DIR
  REASON_FAILURE_MESSAGE "sequential MUMPS is required (Debian: libmumps-seq-dev)")

if(MUMPS_FOUND AND NOT TARGET MUMPS::MUMPS)
  add_library(MUMPS::MUMPS UNKNOWN IMPORTED)
  set_target_properties(MUMPS::MUMPS PROPERTIES
    IMPORTED_LOCATION "${MUMPS_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${MUMPS_INCLUDE_DIR};${MUMPS_MPISEQ_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${MUMPS_COMMON_LIBRARY};${MUMPS_PORD_LIBRARY};${MUMPS_MPISEQ_LIBRARY}")
endif()
mark_as_advanced(MUMPS_INCLUDE_DIR MUMPS_MPISEQ_INCLUDE_DIR MUMPS_LIBRARY MUMPS_COMMON_LIBRARY MUMPS_MPISEQ_LIBRARY
                 MUMPS_PORD_LIBRARY)
