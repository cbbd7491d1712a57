# ModalInstall.cmake — what `cmake --install` installs, and the Debian package
# (`cpack -G DEB`). Included by the top-level CMakeLists.txt after lib/ and
# apps/modal/.
#
#   bin/modal                               the command-line program (modal::cli)
#   lib/libmodal.so.0.2.0 (SONAME .so.0)    modal::modal
#   lib/libmodal.a                          modal::modal_static
#   include/modal/*.hpp                     the public headers
#   lib/cmake/modal/                        modalConfig.cmake, modalConfigVersion.cmake, the
#                                           exported targets, FindCHOLMOD.cmake, FindMUMPS.cmake
#   lib/pkgconfig/modal.pc
#   share/modal/models/                     the bundled scenes (and their data/)
#   share/man/man1/modal.1                  from `modal --help` (help2man; optional)
# (lib is lib/<multiarch> when the prefix is /usr: GNUInstallDirs.)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(MODAL_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/modal)
set(MODAL_MODELS_DIR ${CMAKE_INSTALL_DATADIR}/modal/models)

# --- libraries, program, headers, models ---------------------------------------------
install(TARGETS modal EXPORT modalTargets LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS modal_static EXPORT modalStaticTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
if(TARGET modal_app)
  set_target_properties(modal_app PROPERTIES EXPORT_NAME cli)
  install(TARGETS modal_app EXPORT modalTargets RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
if(TARGET modal_mpi_app)  # beside modal, which executes it for analyze --backend petsc
  install(TARGETS modal_mpi_app RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/lib/include/modal DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.hpp"
  PATTERN "distributed.hpp" EXCLUDE)  # modal-mpi's stage, not part of libmodal
install(DIRECTORY ${PROJECT_SOURCE_DIR}/models/ DESTINATION ${MODAL_MODELS_DIR})

# --- CMake package -----------------------------------------------------------------------
install(EXPORT modalTargets NAMESPACE modal:: DESTINATION ${MODAL_CMAKE_DIR})
install(EXPORT modalStaticTargets NAMESPACE modal:: DESTINATION ${MODAL_CMAKE_DIR})

# The find_package()/find_dependency() calls of modalConfig.cmake, from the
# dependency table of cmake/ModalLibrary.cmake.
modal_dependencies(public PUBLIC)
modal_dependencies(private PRIVATE)
set(MODAL_PUBLIC_FIND_CALLS "")
foreach(dep IN LISTS public)
  get_property(find GLOBAL PROPERTY "MODAL_DEPENDENCY_FIND ${dep}")
  list(JOIN find " " find)
  string(APPEND MODAL_PUBLIC_FIND_CALLS "find_dependency(${find})  # ${dep}\n")
endforeach()
set(MODAL_PRIVATE_FIND_CALLS "")
set(private_find_modules "")
foreach(dep IN LISTS private)
  get_property(find GLOBAL PROPERTY "MODAL_DEPENDENCY_FIND ${dep}")
  list(GET find 0 package)
  if(EXISTS ${PROJECT_SOURCE_DIR}/cmake/Find${package}.cmake)
    list(APPEND private_find_modules ${PROJECT_SOURCE_DIR}/cmake/Find${package}.cmake)
  endif()
  list(JOIN find " " find)
  string(APPEND MODAL_PRIVATE_FIND_CALLS "  if(NOT TARGET ${dep})\n    find_package(${find} \${_modal_quiet})\n  endif()\n")
endforeach()
string(STRIP "${MODAL_PRIVATE_FIND_CALLS}" MODAL_PRIVATE_FIND_CALLS)
list(JOIN private " " MODAL_PRIVATE_TARGETS)

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/modalConfig.cmake.in
  ${PROJECT_BINARY_DIR}/modalConfig.cmake
  INSTALL_DESTINATION ${MODAL_CMAKE_DIR}
  PATH_VARS MODAL_MODELS_DIR)
# Before 1.0 a minor version may change the API and the ABI (semantic
# versioning, item 4), so find_package(modal 0.2) accepts 0.2.x only:
# SameMinorVersion. From 1.0 on, SameMajorVersion will be the rule.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/modalConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/modalConfig.cmake ${PROJECT_BINARY_DIR}/modalConfigVersion.cmake
              ${private_find_modules}
  DESTINATION ${MODAL_CMAKE_DIR})

# --- pkg-config ----------------------------------------------------------------------------
set(pc_requires "")
set(pc_requires_private "")
set(pc_libs_private "")
foreach(dep IN LISTS public private)
  get_property(kind GLOBAL PROPERTY "MODAL_DEPENDENCY_KIND ${dep}")
  get_property(module GLOBAL PROPERTY "MODAL_DEPENDENCY_PKG_CONFIG ${dep}")
  get_property(libs GLOBAL PROPERTY "MODAL_DEPENDENCY_LIBS ${dep}")
  if(kind STREQUAL "PUBLIC")
    list(APPEND pc_requires ${module})
  elseif(module)
    list(APPEND pc_requires_private ${module})
  else()
    list(APPEND pc_libs_private ${libs})
  endif()
endforeach()
list(JOIN pc_requires " " MODAL_PC_REQUIRES)
list(JOIN pc_requires_private " " MODAL_PC_REQUIRES_PRIVATE)
list(JOIN pc_libs_private " " MODAL_PC_LIBS_PRIVATE)
# The prefix, relative to the directory of modal.pc (${pcfiledir}).
file(RELATIVE_PATH MODAL_PC_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
string(REGEX REPLACE "/$" "" MODAL_PC_PREFIX "${MODAL_PC_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/modal.pc.in ${PROJECT_BINARY_DIR}/modal.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/modal.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# --- man page ------------------------------------------------------------------------------
option(MODAL_MAN_PAGE "Generate the man page modal.1 from --help (needs help2man)" ON)
if(MODAL_MAN_PAGE AND TARGET modal_app)
  find_program(HELP2MAN help2man)
  if(HELP2MAN)
    add_custom_command(OUTPUT ${PROJECT_BINARY_DIR}/modal.1
      COMMAND ${CMAKE_COMMAND} -DMODAL=$<TARGET_FILE:modal_app> -DHELP2MAN=${HELP2MAN}
              -DOUTPUT=${PROJECT_BINARY_DIR}/modal.1 -P ${CMAKE_CURRENT_LIST_DIR}/ModalManPage.cmake
      DEPENDS modal_app ${CMAKE_CURRENT_LIST_DIR}/ModalManPage.cmake
      COMMENT "Generating the man page modal.1 (help2man)" VERBATIM)
    add_custom_target(modal_man ALL DEPENDS ${PROJECT_BINARY_DIR}/modal.1)
    install(FILES ${PROJECT_BINARY_DIR}/modal.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
  else()
    message(STATUS "help2man not found: no man page (Debian: help2man)")
  endif()
endif()

# --- Debian package: cpack -G DEB ----------------------------------------------------------
# One package with the program, both libraries, the headers and the CMake and
# pkg-config files. Depends: the runtime libraries, found by dpkg-shlibdeps
# (Debian: dpkg-dev) from what the program and libmodal.so link.
# Recommends: Eigen's headers, which the public headers include. Suggests:
# the development packages that linking libmodal.a needs.
set(CPACK_PACKAGE_NAME modal)
set(CPACK_PACKAGE_VENDOR "modal developers")
set(CPACK_PACKAGE_CONTACT "modal maintainers <maintainers@users.noreply.h-seed-cbfada41.example>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "linearization and modal analysis of Lagrangian mechanical systems")
set(CPACK_PACKAGE_DESCRIPTION
  "modal reads a mechanical system described by Lagrangian mechanics (a TOML scene: rigid bodies, \
joints, springs, dampers, constraints, kinematic maps, large lattices), finds its equilibria, \
linearizes the equations of motion with exact derivatives and reports natural frequencies, \
mode shapes and stability with an error estimate on every eigenvalue. This package holds the \
command-line program modal, the C++20 library libmodal (shared and static) with its headers, \
CMake package and pkg-config file, the bundled models and the man page.")
set(CPACK_PACKAGE_FILE_NAME "${CPACK_PACKAGE_NAME}-${PROJECT_VERSION}")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "libeigen3-dev (>= 3.4)")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS
  "libnlopt-cxx-dev, libgsl-dev, libsuitesparse-dev, libmumps-seq-dev, liblapack-dev, libtomlplusplus-dev, libfmt-dev")
set(CPACK_GENERATOR DEB)
set(CPACK_SOURCE_GENERATOR "")
include(CPack)
