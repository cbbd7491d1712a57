# ModalLibrary.cmake — libmodal, made of the pipeline stages (included by
# lib/CMakeLists.txt).
#
# lib/CMakeLists.txt declares each stage with modal_stage(): a static library
# linked only to the stages before it, so that the one-way data flow is
# enforced at build time; the tests link the stages they test. modal_stage()
# calls modal_register_stage(), and at the end of lib/CMakeLists.txt (a
# deferred call, so that every stage declared in that file is included,
# wherever the declaration stands) modal_libraries() makes libmodal of the
# objects of all stages, compiled once:
#
#   target        file                                      alias / exported as
#   modal         libmodal.so.0.2.0, SONAME libmodal.so.0   modal::modal
#   modal_static  libmodal.a                                modal::modal_static
#
# The public headers (lib/include/modal) include only Eigen among third-party
# headers, so Eigen is the one public dependency; the others are private:
# the shared library carries them as DT_NEEDED, the static one passes them on
# as link-only dependencies. Each third-party target a stage links is
# described in the table below (how the installed modalConfig.cmake finds it
# and what modal.pc says); a stage linking a target missing from it stops the
# configuration, so the installed package cannot silently lack a dependency.

include_guard(GLOBAL)
include(GNUInstallDirs)

# --- the third-party dependencies of libmodal ---------------------------------
# modal_dependency(<target> PUBLIC|HEADER_ONLY|PRIVATE FIND <find_package args>
#                  [PKG_CONFIG <module>] [LIBS <-l flags>])
#   PUBLIC       in the public headers: a dependency of both libraries
#   HEADER_ONLY  used by the sources only, at compile time: nothing to link
#   PRIVATE      compiled: linked into libmodal.so, link-only for libmodal.a
#   FIND         the arguments of find_package()/find_dependency() in modalConfig.cmake
#   PKG_CONFIG   its pkg-config module (modal.pc Requires / Requires.private)
#   LIBS         or, without a module, its -l flags (modal.pc Libs.private)
#   LAZY         the names of its shared libraries (lib<name>.so) that the
#                program `modal` loads on first use instead of linking them
#                (cmake/ModalLazy.cmake); libmodal links them as usual
function(modal_dependency target kind)
  cmake_parse_arguments(ARG "" "PKG_CONFIG" "FIND;LIBS;LAZY" ${ARGN})
  set_property(GLOBAL PROPERTY "MODAL_DEPENDENCY_LAZY ${target}" "${ARG_LAZY}")
  set_property(GLOBAL PROPERTY "MODAL_DEPENDENCY_KIND ${target}" ${kind})
  set_property(GLOBAL PROPERTY "MODAL_DEPENDENCY_FIND ${target}" "${ARG_FIND}")
  set_property(GLOBAL PROPERTY "MODAL_DEPENDENCY_PKG_CONFIG ${target}" "${ARG_PKG_CONFIG}")
  set_property(GLOBAL PROPERTY "MODAL_DEPENDENCY_LIBS ${target}" "${ARG_LIBS}")
endfunction()

modal_dependency(Eigen3::Eigen PUBLIC FIND Eigen3 3.4 NO_MODULE PKG_CONFIG eigen3)
modal_dependency(Spectra::Spectra HEADER_ONLY)
modal_dependency(nlohmann_json::nlohmann_json HEADER_ONLY)
# Debian ships two NLoptConfig.cmake (C and C++ builds): the one found here.
modal_dependency(NLopt::nlopt_cxx PRIVATE
  FIND NLopt CONFIG HINTS "${NLopt_DIR}" /usr/lib/\${CMAKE_LIBRARY_ARCHITECTURE}/cmake/nlopt_cxx
  PKG_CONFIG nlopt_cxx LAZY nlopt_cxx)
modal_dependency(GSL::gsl PRIVATE FIND GSL PKG_CONFIG gsl LAZY gsl)
modal_dependency(Threads::Threads PRIVATE FIND Threads LIBS -pthread)
modal_dependency(LAPACK::LAPACK PRIVATE FIND LAPACK PKG_CONFIG lapack LAZY lapack blas)
modal_dependency(tomlplusplus::tomlplusplus PRIVATE FIND tomlplusplus PKG_CONFIG tomlplusplus)
modal_dependency(fmt::fmt PRIVATE FIND fmt PKG_CONFIG fmt)
# SuiteSparse 5 and MUMPS have no pkg-config module on Debian 12; their find
# modules (cmake/FindCHOLMOD.cmake, cmake/FindMUMPS.cmake) are installed with
# the package.
modal_dependency(CHOLMOD::CHOLMOD PRIVATE FIND CHOLMOD LIBS -lcholmod -lsuitesparseconfig LAZY cholmod)
# libmujoco (MJCF and URDF import): Debian's own CMake config is unusable (cmake/FindMuJoCo.cmake).
modal_dependency(MuJoCo::MuJoCo PRIVATE FIND MuJoCo LIBS -lmujoco LAZY mujoco)
modal_dependency(MUMPS::MUMPS PRIVATE FIND MUMPS LIBS -ldmumps_seq -lmumps_common_seq -lpord_seq -lmpiseq_seq
  LAZY dmumps_seq)

# --- stages -----------------------------------------------------------------------
function(modal_register_stage name)
  set_property(GLOBAL APPEND PROPERTY MODAL_STAGES ${name})
  modal_register_stage_dependencies(${name} ${ARGN})
endfunction()

function(modal_register_stage_dependencies name)
  foreach(dep IN LISTS ARGN)
    if(dep MATCHES "^modal_")
      continue()
    endif()
    get_property(kind GLOBAL PROPERTY "MODAL_DEPENDENCY_KIND ${dep}")
    if(NOT kind)
      message(FATAL_ERROR "stage ${name} links ${dep}, which cmake/ModalLibrary.cmake does not describe: add a "
                          "modal_dependency() line for it (the installed modalConfig.cmake and modal.pc need it)")
    endif()
    set_property(GLOBAL APPEND PROPERTY MODAL_DEPENDENCIES ${dep})
  endforeach()
endfunction()

# Objects of libmodal outside the stages (an OBJECT library, such as the
# sequential variant of the MUMPS wrapper, lib/modal/mumps.hpp) and the
# third-party targets they need.
function(modal_register_objects target)
  set_property(GLOBAL APPEND PROPERTY MODAL_EXTRA_OBJECTS ${target})
  modal_register_stage_dependencies(${target} ${ARGN})
endfunction()

# The third-party dependencies of the stages declared so far, of one kind.
function(modal_dependencies out kind)
  get_property(deps GLOBAL PROPERTY MODAL_DEPENDENCIES)
  list(REMOVE_DUPLICATES deps)
  set(result "")
  foreach(dep IN LISTS deps)
    get_property(k GLOBAL PROPERTY "MODAL_DEPENDENCY_KIND ${dep}")
    if(k STREQUAL kind)
      list(APPEND result ${dep})
    endif()
  endforeach()
  set(${out} ${result} PARENT_SCOPE)
endfunction()

function(modal_libraries)
  get_property(stages GLOBAL PROPERTY MODAL_STAGES)
  set(objects "")
  foreach(stage IN LISTS stages)
    get_target_property(type modal_${stage} TYPE)
    if(type STREQUAL "STATIC_LIBRARY")  # a stage without sources yet is an INTERFACE library
      list(APPEND objects $<TARGET_OBJECTS:modal_${stage}>)
    endif()
  endforeach()
  get_property(extra GLOBAL PROPERTY MODAL_EXTRA_OBJECTS)
  foreach(target IN LISTS extra)
    list(APPEND objects $<TARGET_OBJECTS:${target}>)
  endforeach()
  modal_dependencies(public PUBLIC)
  modal_dependencies(private PRIVATE)

  add_library(modal SHARED ${objects})
  add_library(modal_static STATIC ${objects})
  foreach(lib modal modal_static)
    target_include_directories(${lib} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                             $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${lib} PUBLIC ${public} PRIVATE ${private})
    target_compile_features(${lib} PUBLIC cxx_std_20)
    set_target_properties(${lib} PROPERTIES
      OUTPUT_NAME modal LINKER_LANGUAGE CXX
      ARCHIVE_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib LIBRARY_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib)
  endforeach()
  # SONAME libmodal.so.<major>: bump the major version (0 → 1, …) when the ABI breaks.
  set_target_properties(modal PROPERTIES VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
  set_target_properties(modal_static PROPERTIES EXPORT_NAME modal_static)
  add_library(modal::modal ALIAS modal)
  add_library(modal::modal_static ALIAS modal_static)

  # The program's libmodal (cmake/ModalLazy.cmake): the same objects, linked
  # to the dependencies that are not loaded on first use; the program adds
  # the stubs of the others. Not installed.
  if(MODAL_LAZY_LOADING)
    set(eager "")
    set(lazy "")
    foreach(dep IN LISTS private)
      get_property(names GLOBAL PROPERTY "MODAL_DEPENDENCY_LAZY ${dep}")
      if(names)
        list(APPEND lazy ${names})
      else()
        list(APPEND eager ${dep})
      endif()
    endforeach()
    add_library(modal_program_library STATIC ${objects})
    target_include_directories(modal_program_library PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(modal_program_library PUBLIC ${public} PRIVATE ${eager})
    target_compile_features(modal_program_library PUBLIC cxx_std_20)
    set_target_properties(modal_program_library PROPERTIES LINKER_LANGUAGE CXX
                          ARCHIVE_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib/program)
    set_property(GLOBAL PROPERTY MODAL_LAZY_LIBRARY_NAMES ${lazy})
  endif()
endfunction()
