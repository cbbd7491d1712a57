# ModalLazy.cmake — the program's libraries loaded on first use
# (docs/design.md, "Start-up").
#
# modal_lazy_link(<program>) links <program> to modal_program_library (libmodal's
# objects without the dependencies marked LAZY in cmake/ModalLibrary.cmake) and
# to stubs of the functions and data it takes from those dependencies, written
# at build time by cmake/modal_lazy_generate.cmake from the archive's own
# references, with the resolver apps/modal/lazy_load.cpp. A library is then
# opened (dlopen) when one of its functions is first called. x86-64 Linux only
# (the stubs are assembly); elsewhere MODAL_LAZY_LOADING is off and the program
# links everything as libmodal does.

include_guard(GLOBAL)

function(modal_lazy_link program)
  get_property(names GLOBAL PROPERTY MODAL_LAZY_LIBRARY_NAMES)
  set(libraries "")
  foreach(name IN LISTS names)
    find_library(MODAL_LAZY_LIBRARY_${name} NAMES ${name} REQUIRED)
    list(APPEND libraries ${MODAL_LAZY_LIBRARY_${name}})
  endforeach()
  # The C and C++ run-time libraries, which the program links as usual: their
  # symbols are never stubbed, although libmujoco, for one, exports copies of
  # some of libstdc++'s.
  set(eager "")
  foreach(runtime libstdc++.so.6 libc.so.6 libm.so.6 libgcc_s.so.1)
    execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=${runtime} OUTPUT_VARIABLE path
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(EXISTS "${path}")
      list(APPEND eager ${path})
    endif()
  endforeach()
  set(stubs ${CMAKE_CURRENT_BINARY_DIR}/${program}_lazy.S)
  set(exports ${CMAKE_CURRENT_BINARY_DIR}/${program}_lazy_exports.txt)
  # Read by the program only after a call into GSL (lib/simulate/simulate.cpp).
  set(data_after_call gsl_odeiv2_step_rk8pd)
  add_custom_command(
    OUTPUT ${stubs} ${exports}
    COMMAND ${CMAKE_COMMAND} -DARCHIVE=$<TARGET_FILE:modal_program_library> "-DLIBRARIES=${libraries}"
            "-DEAGER=${eager}" "-DDATA_AFTER_CALL=${data_after_call}" -DNM=${CMAKE_NM} -DOBJDUMP=${CMAKE_OBJDUMP}
            -DOUTPUT=${stubs} -DEXPORTS=${exports} -P ${PROJECT_SOURCE_DIR}/cmake/modal_lazy_generate.cmake
    DEPENDS modal_program_library ${PROJECT_SOURCE_DIR}/cmake/modal_lazy_generate.cmake
    COMMENT "Stubs of the libraries ${program} loads on first use"
    VERBATIM)
  add_library(${program}_lazy_stubs OBJECT ${stubs})
  set_source_files_properties(${stubs} PROPERTIES LANGUAGE ASM)
  target_sources(${program} PRIVATE $<TARGET_OBJECTS:${program}_lazy_stubs>
                 ${PROJECT_SOURCE_DIR}/apps/modal/lazy_load.cpp)
  target_link_libraries(${program} PRIVATE modal_program_library ${CMAKE_DL_LIBS})
  # The data symbols are defined by the program and exported, so that each
  # library binds to the program's copy when it is loaded.
  target_link_options(${program} PRIVATE "LINKER:--dynamic-list=${exports}")
  set_property(TARGET ${program} APPEND PROPERTY LINK_DEPENDS ${exports})
endfunction()
