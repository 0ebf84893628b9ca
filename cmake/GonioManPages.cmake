# cmake -DGONIO=<gonio> -DOUT=<folder> -DVERSION=<x.y.z> -DCOMMANDS=<a;b;...> -P GonioManPages.cmake
# Writes the man pages gonio.1 and gonio-COMMAND.1 from the programs' own --help, so that the two
# never disagree. COMMANDS is the list the build expects (one cmd_<name>.cpp per command); a
# command that `gonio --help` lists and the build does not expect, or the reverse, is an error.

function(gonio_help out)
  execute_process(COMMAND ${GONIO} ${ARGN} --help OUTPUT_VARIABLE text ERROR_VARIABLE err
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "man pages: gonio ${ARGN} --help failed (${rc}): ${err}")
  endif()
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# Roff: backslashes printed as such, no line taken for a request (leading . or ').
function(gonio_roff out text)
  string(REPLACE "\\" "\\e" text "${text}")
  string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" text "${text}")
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# One page: NAME from the summary, SYNOPSIS from the help's Usage line, the help itself as the
# DESCRIPTION (preformatted, as the terminal shows it).
function(gonio_page file title name summary help see_also)
  string(REGEX MATCH "Usage: ([^\n]*)" usage "${help}")
  set(usage "${CMAKE_MATCH_1}")
  string(REGEX REPLACE "Usage: [^\n]*\n?" "" body "${help}")
  gonio_roff(summary "${summary}")
  gonio_roff(usage "${usage}")
  gonio_roff(body "${body}")
  string(REPLACE "-" "\\-" name_roff "${name}")
  string(TOUPPER "${title}" upper)
  file(WRITE "${file}"
       ".TH ${upper} 1 \"\" \"gonio ${VERSION}\" \"gonio manual\"\n"
       ".SH NAME\n${name_roff} \\- ${summary}\n"
       ".SH SYNOPSIS\n.nf\n${usage}\n.fi\n"
       ".SH DESCRIPTION\n.nf\n${body}\n.fi\n"
       ".SH SEE ALSO\n${see_also}\n")
endfunction()

gonio_help(top)
# The command list of gonio --help: "  name   summary" lines after "Subcommands:".
string(REGEX REPLACE ".*\nSubcommands:\n" "" listing "${top}")
string(REPLACE "\n" ";" lines "${listing}")
set(listed)
set(see_also "")
foreach(line ${lines})
  if(line MATCHES "^  ([a-z][a-z0-9-]*)  +(.+)$")
    list(APPEND listed "${CMAKE_MATCH_1}")
    set(summary_${CMAKE_MATCH_1} "${CMAKE_MATCH_2}")
  endif()
endforeach()
list(SORT listed)
set(expected ${COMMANDS})
list(SORT expected)
if(NOT listed STREQUAL expected)
  message(FATAL_ERROR "man pages: gonio --help lists \"${listed}\", the build has \"${expected}\"")
endif()
foreach(c ${listed})
  string(APPEND see_also "\\fBgonio\\-${c}\\fR(1)\n")
endforeach()
string(REGEX MATCH "^([^\n]*)" first "${top}")
string(REGEX REPLACE "^gonio: " "" top_summary "${first}")
string(REGEX REPLACE "^[^\n]*\n" "" top_help "${top}")
gonio_page("${OUT}/gonio.1" gonio gonio "${top_summary}" "${top_help}" "${see_also}")
foreach(c ${listed})
  gonio_help(help ${c})
  # The first line of a command's help repeats its summary; the page starts with the usage.
  string(REGEX REPLACE "^[^\n]*\n(Usage:)" "\\1" help "${help}")
  gonio_page("${OUT}/gonio-${c}.1" "gonio-${c}" "gonio-${c}" "${summary_${c}}" "${help}" "\\fBgonio\\fR(1)")
endforeach()
