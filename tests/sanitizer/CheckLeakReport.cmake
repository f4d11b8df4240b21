# Runs the leak-check program (cmake -P, from tests/sanitizer/CMakeLists.txt) in the test's environment,
# i.e. with cmake/sanitizers/lsan.supp, and checks LeakSanitizer's verdict:
#   MODE=leaks: the run must fail (under ASan, LeakSanitizer exits with 1) and the report must name each of
#               EXPECT (our allocation sites, separated by commas) in a leak's allocation stack. A leak may be
#               reported as indirect: the leaked .oni source and the openni::PlaybackControl it owns point
#               at each other, and LeakSanitizer reports every block of such a cycle as indirect;
#   MODE=clean: the same work without the deliberate leaks must pass (exit 0) with no report.
execute_process(COMMAND ${PROGRAM} ${ONI} ${ARGUMENTS} RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
message("${output}")
if(NOT output MATCHES "lightskin leak check: finished")
  message(FATAL_ERROR "the leak-check program did not run to its end (exit ${result})")
endif()
if(MODE STREQUAL "clean")
  if(NOT result EQUAL 0 OR output MATCHES "LeakSanitizer")
    message(FATAL_ERROR "the clean run must pass without a leak report (exit ${result})")
  endif()
  return()
endif()
if(result EQUAL 0)
  message(FATAL_ERROR "the run with deliberate leaks passed: LeakSanitizer did not fail it")
endif()
if(NOT output MATCHES "ERROR: LeakSanitizer: detected memory leaks")
  message(FATAL_ERROR "no LeakSanitizer report")
endif()
# One block per leak: "Direct (or Indirect) leak of N byte(s) ... allocated from:" followed by its frames.
string(REPLACE "\n\n" ";" blocks "${output}")
string(REPLACE "," ";" sites "${EXPECT}")
foreach(site IN LISTS sites)
  set(found FALSE)
  foreach(block IN LISTS blocks)
    string(FIND "${block}" " leak of " leak)
    string(FIND "${block}" "${site}" at)
    if(leak GREATER_EQUAL 0 AND at GREATER_EQUAL 0)
      set(found TRUE)
    endif()
  endforeach()
  if(NOT found)
    message(FATAL_ERROR "LeakSanitizer did not report the deliberate leak in ${site}: a suppression hides our code")
  endif()
endforeach()
