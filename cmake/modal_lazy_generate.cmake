# modal_lazy_generate.cmake — writes the program's lazy-loading stubs (run by
# cmake -P at build time; cmake/ModalLazy.cmake, docs/design.md "Start-up").
#
#   -DARCHIVE=<static library>   the objects whose external references are stubbed
#   -DLIBRARIES=<a;b;...>        shared libraries loaded on first use, in the
#                                order a symbol is looked up in them
#   -DDATA_AFTER_CALL=<x;y;...>  initialized data symbols of those libraries
#                                that the code reads only after a call into
#                                the same library (their value is copied when
#                                the library is loaded); any other initialized
#                                data symbol stops the build
#   -DEAGER=<a;b;...>            the libraries the program links as usual (the C
#                                and C++ run-time libraries): a symbol they
#                                define is never stubbed, even where a lazily
#                                loaded library exports a copy of it
#   -DNM=<nm> -DOBJDUMP=<objdump>
#   -DOUTPUT=<file.S>            x86-64 assembly: one stub per function, one
#                                definition per data symbol, and the tables the
#                                resolver (apps/modal/lazy_load.cpp) reads
#   -DEXPORTS=<file>             a --dynamic-list of the data symbols, which the
#                                program must export so that the libraries,
#                                once loaded, bind to the program's definitions
#
# Every function symbol S the archive needs from one of LIBRARIES becomes
#     S: jmp *slot_S(%rip)
# with slot_S first pointing at an entry that pushes S's index and calls the
# resolver, which loads S's library (dlopen), looks S up (dlsym), stores the
# address in slot_S and jumps there with the caller's registers restored.

cmake_minimum_required(VERSION 3.25)

function(run_tool out)
  execute_process(COMMAND ${ARGN} OUTPUT_VARIABLE text RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "modal_lazy_generate: '${ARGN}' failed (${rc}): ${err}")
  endif()
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# Symbols the archive needs from outside itself.
run_tool(undefined_text ${NM} -u --format=posix ${ARCHIVE})
run_tool(defined_text ${NM} --defined-only --format=posix ${ARCHIVE})
string(REGEX MATCHALL "(^|\n)[^ \n:]+ [UwvV]" undefined_lines "${undefined_text}")
string(REGEX MATCHALL "(^|\n)[^ \n:]+ [A-Za-z]" defined_lines "${defined_text}")
set(defined ";")
foreach(line IN LISTS defined_lines)
  string(REGEX REPLACE "^\n?([^ ]+) .*$" "\\1" name "${line}")
  string(APPEND defined "${name};")
endforeach()
set(needed "")
foreach(line IN LISTS undefined_lines)
  string(REGEX REPLACE "^\n?([^ ]+) .*$" "\\1" name "${line}")
  string(FIND "${defined}" ";${name};" at)
  if(at EQUAL -1)
    list(APPEND needed ${name})
  endif()
endforeach()
list(REMOVE_DUPLICATES needed)
foreach(library IN LISTS EAGER)
  run_tool(symbols ${NM} -D --defined-only --format=posix ${library})
  string(REGEX REPLACE "(@[^ \n]*)? [A-Za-z][^\n]*" "" symbols "${symbols}")
  string(REPLACE "\n" ";" symbols ";${symbols};")
  set(kept "")
  foreach(name IN LISTS needed)
    string(FIND "${symbols}" ";${name};" at)
    if(at EQUAL -1)
      list(APPEND kept ${name})
    endif()
  endforeach()
  set(needed ${kept})
endforeach()

# What each library defines: "name type size" per dynamic symbol.
set(functions "")
set(data "")
set(library_index 0)
set(sonames "")
foreach(library IN LISTS LIBRARIES)
  run_tool(dynamic ${OBJDUMP} -p ${library})
  if(NOT dynamic MATCHES "SONAME +([^ \n]+)")
    message(FATAL_ERROR "modal_lazy_generate: ${library} has no SONAME")
  endif()
  list(APPEND sonames ${CMAKE_MATCH_1})
  run_tool(symbols ${NM} -D -S --defined-only --format=posix ${library})
  string(REPLACE "\n" ";" symbol_lines "${symbols}")
  set(still_needed "")
  set(table ";")
  foreach(line IN LISTS symbol_lines)
    if(line MATCHES "^([^ @]+)(@[^ ]*)? ([A-Za-z]) ([0-9a-f]+)( ([0-9a-f]+))?$")
      string(APPEND table "${CMAKE_MATCH_1}:${CMAKE_MATCH_3}:${CMAKE_MATCH_6};")
    endif()
  endforeach()
  foreach(name IN LISTS needed)
    if(NOT table MATCHES ";${name}:([A-Za-z]):([0-9a-f]*);")
      list(APPEND still_needed ${name})
      continue()
    endif()
    set(type ${CMAKE_MATCH_1})
    set(size ${CMAKE_MATCH_2})
    if(type MATCHES "^[TtWi]$")
      list(APPEND functions "${name}:${library_index}")
    elseif(type MATCHES "^[BbDdRrV]$")
      if(NOT size)
        message(FATAL_ERROR "modal_lazy_generate: data symbol ${name} of ${library} has no size")
      endif()
      math(EXPR bytes "0x${size}")
      set(copy 1)
      if(type MATCHES "^[Bb]$")
        set(copy 0)  # zero-initialized in the library too
      elseif(NOT name IN_LIST DATA_AFTER_CALL)
        message(FATAL_ERROR "modal_lazy_generate: ${name} is initialized data of ${library}: the program would read "
                            "it before the library is loaded. Read it only after a call into that library and list "
                            "it in DATA_AFTER_CALL (cmake/ModalLazy.cmake), or do not load the library lazily.")
      endif()
      list(APPEND data "${name}:${library_index}:${bytes}:${copy}")
    else()
      message(FATAL_ERROR "modal_lazy_generate: symbol ${name} of ${library} has type ${type}, which is not handled")
    endif()
  endforeach()
  set(needed ${still_needed})
  math(EXPR library_index "${library_index} + 1")
endforeach()

# --- the assembly ---------------------------------------------------------------
set(s "# Generated by cmake/modal_lazy_generate.cmake from ${ARCHIVE}: do not edit.\n")
string(APPEND s "\t.section .note.GNU-stack,\"\",@progbits\n")
string(APPEND s "\t.text\n")
set(index 0)
foreach(entry IN LISTS functions)
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 0 name)
  string(APPEND s "\t.globl ${name}\n\t.type ${name}, @function\n\t.p2align 4\n${name}:\n"
                  "\t.cfi_startproc\n\tjmp *modal_lazy_slots+${index}*8(%rip)\n\t.cfi_endproc\n\t.size ${name}, .-${name}\n")
  math(EXPR index "${index} + 1")
endforeach()
list(LENGTH functions function_count)
# Entries: push the index, go to the common part, which saves the argument
# registers (integer, vector, and %rax: the vector count of a variadic call),
# calls modal_lazy_resolve(index) with the stack 16-byte aligned, restores
# them and jumps to the address it returned. On entry to a stub %rsp is 8 mod
# 16; after the index, 7 registers and 136 bytes it is 0 mod 16.
set(index 0)
foreach(entry IN LISTS functions)
  string(APPEND s "\t.p2align 3\n.Lmodal_lazy_entry_${index}:\n\tpushq $${index}\n\tjmp .Lmodal_lazy_common\n")
  math(EXPR index "${index} + 1")
endforeach()
string(APPEND s "\t.p2align 4\n.Lmodal_lazy_common:\n"
                "\tpushq %rdi\n\tpushq %rsi\n\tpushq %rdx\n\tpushq %rcx\n\tpushq %r8\n\tpushq %r9\n\tpushq %rax\n"
                "\tsubq $136, %rsp\n")
foreach(i RANGE 0 7)
  math(EXPR offset "${i} * 16")
  string(APPEND s "\tmovdqu %xmm${i}, ${offset}(%rsp)\n")
endforeach()
string(APPEND s "\tmovq 192(%rsp), %rdi\n\tcall modal_lazy_resolve\n\tmovq %rax, %r11\n")
foreach(i RANGE 0 7)
  math(EXPR offset "${i} * 16")
  string(APPEND s "\tmovdqu ${offset}(%rsp), %xmm${i}\n")
endforeach()
string(APPEND s "\taddq $136, %rsp\n"
                "\tpopq %rax\n\tpopq %r9\n\tpopq %r8\n\tpopq %rcx\n\tpopq %rdx\n\tpopq %rsi\n\tpopq %rdi\n"
                "\taddq $8, %rsp\n\tjmp *%r11\n")

# Slots, first at the entries; the resolver overwrites each with its symbol's address.
string(APPEND s "\t.data\n\t.p2align 3\n\t.globl modal_lazy_slots\n\t.hidden modal_lazy_slots\nmodal_lazy_slots:\n")
set(index 0)
foreach(entry IN LISTS functions)
  string(APPEND s "\t.quad .Lmodal_lazy_entry_${index}\n")
  math(EXPR index "${index} + 1")
endforeach()
if(function_count EQUAL 0)
  string(APPEND s "\t.quad 0\n")
endif()

# The data symbols: zeroed here, exported (EXPORTS), the initialized ones
# filled from the library's own copy when it is loaded.
set(exports "{\n")
foreach(entry IN LISTS data)
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 0 name)
  list(GET parts 2 bytes)
  string(APPEND s "\t.globl ${name}\n\t.type ${name}, @object\n\t.p2align 4\n${name}:\n\t.zero ${bytes}\n"
                  "\t.size ${name}, ${bytes}\n")
  string(APPEND exports "  ${name};\n")
endforeach()
string(APPEND exports "};\n")

# Tables (modal_lazy_tables in apps/modal/lazy_load.cpp).
string(APPEND s "\t.section .rodata\n")
set(index 0)
foreach(soname IN LISTS sonames)
  string(APPEND s ".Lmodal_lazy_library_${index}:\n\t.asciz \"${soname}\"\n")
  math(EXPR index "${index} + 1")
endforeach()
set(index 0)
foreach(entry IN LISTS functions data)
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 0 name)
  string(APPEND s ".Lmodal_lazy_name_${index}:\n\t.asciz \"${name}\"\n")
  math(EXPR index "${index} + 1")
endforeach()
string(APPEND s "\t.section .data.rel.ro,\"aw\"\n\t.p2align 3\n")
string(APPEND s "\t.globl modal_lazy_libraries\n\t.hidden modal_lazy_libraries\nmodal_lazy_libraries:\n")
list(LENGTH sonames library_count)
set(index 0)
foreach(soname IN LISTS sonames)
  string(APPEND s "\t.quad .Lmodal_lazy_library_${index}\n")
  math(EXPR index "${index} + 1")
endforeach()
# struct Function { const char* name; long library; }
string(APPEND s "\t.globl modal_lazy_functions\n\t.hidden modal_lazy_functions\nmodal_lazy_functions:\n")
set(index 0)
foreach(entry IN LISTS functions)
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 1 library)
  string(APPEND s "\t.quad .Lmodal_lazy_name_${index}\n\t.quad ${library}\n")
  math(EXPR index "${index} + 1")
endforeach()
# struct Data { const char* name; long library; void* address; long bytes; long copy; }
string(APPEND s "\t.globl modal_lazy_data\n\t.hidden modal_lazy_data\nmodal_lazy_data:\n")
foreach(entry IN LISTS data)
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 0 name)
  list(GET parts 1 library)
  list(GET parts 2 bytes)
  list(GET parts 3 copy)
  string(APPEND s "\t.quad .Lmodal_lazy_name_${index}\n\t.quad ${library}\n\t.quad ${name}\n\t.quad ${bytes}\n"
                  "\t.quad ${copy}\n")
  math(EXPR index "${index} + 1")
endforeach()
list(LENGTH data data_count)
string(APPEND s "\t.globl modal_lazy_counts\n\t.hidden modal_lazy_counts\nmodal_lazy_counts:\n"
                "\t.quad ${library_count}\n\t.quad ${function_count}\n\t.quad ${data_count}\n")

file(WRITE ${OUTPUT} "${s}")
file(WRITE ${EXPORTS} "${exports}")
