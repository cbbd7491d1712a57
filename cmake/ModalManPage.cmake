# ModalManPage.cmake — writes the man page modal.1 from the program's own
# help: help2man runs `modal --help` and `modal --version`, and a SUBCOMMANDS
# section holds each subcommand's `--help`, as printed, so the page cannot
# drift from the program. Run at build time by cmake/ModalInstall.cmake:
#   cmake -DMODAL=<program> -DHELP2MAN=<help2man> -DOUTPUT=<modal.1> -P ModalManPage.cmake
foreach(var MODAL HELP2MAN OUTPUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "ModalManPage.cmake: -D${var}=… is required")
  endif()
endforeach()
# A sanitizer build's program is run too: leak reports are not help.
set(ENV{ASAN_OPTIONS} "detect_leaks=0")

execute_process(COMMAND "${MODAL}" --help OUTPUT_VARIABLE help RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${MODAL} --help failed (${status})")
endif()
# The subcommands: the first word of each line of the "Subcommands:" block.
string(REPLACE "\n" ";" lines "${help}")
set(in_block FALSE)
set(subcommands "")
foreach(line IN LISTS lines)
  if(line MATCHES "^Subcommands:")
    set(in_block TRUE)
  elseif(in_block AND line MATCHES "^  ([a-z][a-z0-9_-]*)")
    list(APPEND subcommands "${CMAKE_MATCH_1}")
  elseif(in_block AND line STREQUAL "")
    set(in_block FALSE)
  endif()
endforeach()

# Each subcommand's help, verbatim (roff: backslashes escaped, no line taken
# for a request).
set(include "[SUBCOMMANDS]\n")
foreach(sub IN LISTS subcommands)
  execute_process(COMMAND "${MODAL}" ${sub} --help OUTPUT_VARIABLE text RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${MODAL} ${sub} --help failed (${status})")
  endif()
  string(REPLACE "\\" "\\e" text "${text}")
  string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" text "${text}")
  string(APPEND include ".SS \"modal ${sub}\"\n.nf\n${text}.fi\n")
endforeach()
string(APPEND include "[FILES]\n.TP\n.I share/modal/models/\nthe bundled scenes (TOML), under the installation prefix\n")
get_filename_component(dir "${OUTPUT}" DIRECTORY)
set(include_file "${dir}/modal.h2m")
file(WRITE "${include_file}" "${include}")

execute_process(
  COMMAND "${HELP2MAN}" --no-info --no-discard-stderr --section=1
          "--name=linearization and modal analysis of Lagrangian mechanical systems"
          "--include=${include_file}" "--output=${OUTPUT}" "${MODAL}"
  RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  file(REMOVE "${OUTPUT}")
  message(FATAL_ERROR "help2man failed (${status})")
endif()
