# Runs the race-check program (cmake -P, from tests/sanitizer/CMakeLists.txt) in the test's environment, i.e.
# with cmake/sanitizers/tsan.supp, and checks ThreadSanitizer's verdict:
#   MODE=race:  the run must fail with a data-race report whose two accesses are both in writeFromTask, the
#               program's own function: a suppression that matched it would hide a race on our data;
#   MODE=clean: the same region with one slot per task must pass (exit 0) with no report.
execute_process(COMMAND ${PROGRAM} ${ARGUMENTS} RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
message("${output}")
if(output MATCHES "never ran at once")
  message(FATAL_ERROR "the two tasks did not run on two threads: the check proves nothing")
endif()
if(MODE STREQUAL "clean")
  if(NOT result EQUAL 0 OR output MATCHES "ThreadSanitizer" OR NOT output MATCHES "lightskin race check: finished")
    message(FATAL_ERROR "the clean run must finish without a ThreadSanitizer report (exit ${result})")
  endif()
  return()
endif()
if(result EQUAL 0)
  message(FATAL_ERROR "the run with a deliberate race passed: ThreadSanitizer did not fail it")
endif()
if(NOT output MATCHES "WARNING: ThreadSanitizer: data race")
  message(FATAL_ERROR "no ThreadSanitizer data-race report (exit ${result})")
endif()
# Both accesses ("Write of size 4 ... by thread" / "Previous write ...") have writeFromTask as their top frame.
string(REGEX MATCHALL "#0 [^\n]*writeFromTask" tops "${output}")
list(LENGTH tops top_count)
if(top_count LESS 2)
  message(FATAL_ERROR "the report does not name writeFromTask on both accesses (${top_count} of 2)")
endif()
