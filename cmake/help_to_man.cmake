# Makes a man page from a binary's own --help and --version, so the page and
# the help can never disagree (the help is generated from the flag
# registry, common/flags/flag_help.h). A small help2man that needs nothing but
# CMake:
#
#   cmake -DBINARY=bin/impostor-server -DNAME=impostor-server
#         -DSUMMARY="the bake farm's gRPC server" -DOUT=man/impostor-server.1
#         -P cmake/help_to_man.cmake
#
# Layout of the help it reads: "Usage: ..." lines (continued by indented
# lines), paragraphs, "Heading:" lines, and "  --flag=VALUE  text" entries
# continued by deeper-indented lines. Anything else is kept as text.
cmake_minimum_required(VERSION 3.25)
foreach(var BINARY NAME SUMMARY OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "help_to_man.cmake: -D${var}=... is required")
  endif()
endforeach()

execute_process(COMMAND ${BINARY} --help OUTPUT_VARIABLE help RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${BINARY} --help exited with ${rc}")
endif()
execute_process(COMMAND ${BINARY} --version OUTPUT_VARIABLE version OUTPUT_STRIP_TRAILING_WHITESPACE)

# roff escapes: backslash, hyphen-minus (so options copy and paste), and a
# leading dot or quote (a request otherwise).
function(roff_escape out text)
  string(REPLACE "\\" "\\e" text "${text}")
  string(REPLACE "-" "\\-" text "${text}")
  string(REGEX REPLACE "^([.'])" "\\\\&\\1" text "${text}")
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# CMake lists split on ';' and treat '[' ']' specially: protect them.
string(REPLACE ";" "@SEMI@" help "${help}")
string(REPLACE "[" "@LB@" help "${help}")
string(REPLACE "]" "@RB@" help "${help}")
string(REPLACE "\n" ";" lines "${help}")

string(TOUPPER "${NAME}" upper)
roff_escape(name_escaped "${NAME}")
roff_escape(summary_escaped "${SUMMARY}")
roff_escape(version_escaped "${version}")
set(page ".TH ${upper} 1 \"\" \"${version_escaped}\" \"impostor bake farm\"\n.SH NAME\n${name_escaped} \\- ${summary_escaped}\n")

set(mode "")           # usage | text | entry | pre
set(options_started FALSE)
set(seen_usage FALSE)  # text before the usage line repeats NAME: skipped
foreach(line IN LISTS lines)
  roff_escape(escaped "${line}")
  if(NOT seen_usage AND NOT line MATCHES "^Usage:")
    continue()
  endif()
  if(line MATCHES "^Usage: ?(.*)$")
    set(seen_usage TRUE)
    string(APPEND page ".SH SYNOPSIS\n.nf\n")
    # "Usage:" alone heads an indented block (the CLI's commands): kept
    # as laid out; "Usage: prog ..." is continued by aligned lines.
    set(usage_verbatim TRUE)
    if(CMAKE_MATCH_1)
      set(usage_verbatim FALSE)
      roff_escape(rest "${CMAKE_MATCH_1}")
      string(APPEND page "${rest}\n")
    endif()
    set(mode usage)
  elseif(mode STREQUAL "usage" AND line MATCHES "^ +(.*)$")
    roff_escape(rest "${CMAKE_MATCH_1}")
    if(usage_verbatim)
      string(APPEND page "${escaped}\n")
    else()
      string(APPEND page "${rest}\n")
    endif()
  elseif(line STREQUAL "")
    if(mode STREQUAL "usage")
      string(APPEND page ".fi\n.SH DESCRIPTION\n")
    elseif(mode STREQUAL "pre")
      string(APPEND page "\n")
      continue()
    else()
      string(APPEND page ".PP\n")
    endif()
    set(mode "")
  elseif(line MATCHES "^([A-Z][A-Za-z ,()-]*):$")
    if(NOT options_started)
      string(APPEND page ".SH OPTIONS\n")
      set(options_started TRUE)
    endif()
    roff_escape(title "${CMAKE_MATCH_1}")
    string(APPEND page ".SS ${title}\n")
    set(mode "")
  elseif(line MATCHES "^  (-[^ ]+)( +(.*))?$")
    roff_escape(flag "${CMAKE_MATCH_1}")
    roff_escape(rest "${CMAKE_MATCH_3}")
    string(APPEND page ".TP\n.B ${flag}\n")
    if(rest)
      string(APPEND page "${rest}\n")
    endif()
    set(mode entry)
  elseif(mode STREQUAL "entry" AND line MATCHES "^    +(.*)$")
    roff_escape(rest "${CMAKE_MATCH_1}")
    string(APPEND page "${rest}\n")
  elseif(line MATCHES "^ ")
    # Free-form indented text (the CLI's command list): keep its layout.
    if(NOT mode STREQUAL "pre")
      string(APPEND page ".nf\n")
      set(mode pre)
    endif()
    string(APPEND page "${escaped}\n")
  else()
    if(mode STREQUAL "pre")
      string(APPEND page ".fi\n")
    endif()
    string(APPEND page "${escaped}\n")
    set(mode text)
  endif()
endforeach()
if(mode STREQUAL "pre")
  string(APPEND page ".fi\n")
endif()

string(REPLACE "@SEMI@" ";" page "${page}")
string(REPLACE "@LB@" "[" page "${page}")
string(REPLACE "@RB@" "]" page "${page}")
file(WRITE "${OUT}" "${page}")
