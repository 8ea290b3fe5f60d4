# Test: a man page made by help_to_man.cmake renders without groff warnings
# and shows every flag that the binary's --help lists.
#   cmake -DBINARY=... -DPAGE=... -P cmake/check_man_page.cmake
execute_process(COMMAND groff -man -Tascii -ww ${PAGE} OUTPUT_VARIABLE rendered ERROR_VARIABLE warnings
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT warnings STREQUAL "")
  message(FATAL_ERROR "groff on ${PAGE}: exit ${rc}\n${warnings}")
endif()
# groff -Tascii overstrikes bold text (c\bc): take the plain characters.
string(ASCII 8 backspace)
string(REGEX REPLACE ".${backspace}" "" rendered "${rendered}")
execute_process(COMMAND ${BINARY} --help OUTPUT_VARIABLE help)
string(REGEX MATCHALL "\n  --[a-z0-9-]+" flags "${help}")
list(LENGTH flags count)
if(count LESS 3)
  message(FATAL_ERROR "${BINARY} --help lists only ${count} flags")
endif()
foreach(flag IN LISTS flags)
  string(STRIP "${flag}" flag)
  string(FIND "${rendered}" "${flag}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${PAGE} does not show ${flag}")
  endif()
endforeach()
message(STATUS "${PAGE}: ${count} flags, no warnings")
