# Writes a manual page per program from its --help text (run at install time by the Debian
# package's install step, cmake/SiruppPackage.cmake): NAME from the text's first sentence, the
# whole text as DESCRIPTION, and where the documentation is. Called with
#   SIRUPP_BIN_DIR  the build's programs     SIRUPP_PROGRAMS  their names
#   SIRUPP_MAN_DIR  where the .1.gz go       SIRUPP_VERSION   the package's version
find_program(SIRUPP_GZIP_FOR_MAN gzip REQUIRED)
file(MAKE_DIRECTORY "${SIRUPP_MAN_DIR}")
foreach(program ${SIRUPP_PROGRAMS})
  if(program STREQUAL "sirupp-sandbox-exec")
    # A helper with positional arguments only (sandbox/exec_main.cpp).
    set(help "usage: sirupp-sandbox-exec [--cpu S] [--memory MB] [--processes N] [--file-size MB] [--sanitized] [--user UID] [--no-network] -- PROGRAM ARGS...\nThe steps of the sandbox for students' code that bubblewrap does not take: the limits, the user, the socket filter, then PROGRAM. Started by the sandbox, not by hand (docs/sandbox.md).\n")
  else()
    # The helpers started by other programs print their usage on stderr and exit 2.
    execute_process(COMMAND "${SIRUPP_BIN_DIR}/${program}" --help OUTPUT_VARIABLE help
                    ERROR_VARIABLE help_err RESULT_VARIABLE result)
    if(help STREQUAL "")
      set(help "${help_err}")
    endif()
    if(NOT help MATCHES "^usage: ")
      message(FATAL_ERROR "${program} --help (exit ${result}) printed no usage: no manual page")
    endif()
  endif()
  # NAME: the line after "usage: ...", up to its first full stop.
  string(REGEX REPLACE "^[^\n]*\n([^\n]*).*$" "\\1" summary "${help}")
  string(REGEX REPLACE "[.:].*$" "" summary "${summary}")
  string(REPLACE "\\" "\\\\" summary "${summary}")
  # roff: backslashes escaped, a line starting with '.' or ' kept as text.
  string(REPLACE "\\" "\\e" body "${help}")
  string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" body "${body}")
  string(TOUPPER "${program}" upper)
  file(WRITE "${SIRUPP_MAN_DIR}/${program}.1"
".TH ${upper} 1 \"\" \"sirupp ${SIRUPP_VERSION}\" \"SIRUPP-LCM\"
.SH NAME
${program} \\- ${summary}
.SH DESCRIPTION
.nf
${body}
.fi
.SH SEE ALSO
The guides in /usr/share/doc/sirupp/docs/ (README.md: the index), and
.B ${program} --help.
")
  execute_process(COMMAND "${SIRUPP_GZIP_FOR_MAN}" -9 -n -f "${SIRUPP_MAN_DIR}/${program}.1"
                  RESULT_VARIABLE result)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "gzip ${SIRUPP_MAN_DIR}/${program}.1 failed")
  endif()
endforeach()
