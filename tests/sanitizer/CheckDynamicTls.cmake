# Runs a GL program (cmake -P, from tests/sanitizer/CMakeLists.txt) with ASAN_OPTIONS=verbosity=2, under which
# libasan logs every __tls_get_addr it intercepts, and requires that no dynamic TLS block went through its
# glibc-2.19 guess ("Can't guess glibc version" / "glibc >=2.19 suspected"). That guess is what made
# LeakSanitizer scan a bogus range and crash at exit ("Tracer caught signal 11", cmake/LightskinAsanDriverTls.cmake);
# with Mesa's dynamic-TLS libraries linked at start-up every block is static ("static tls"). The guess is taken
# on every run of a GL program without that link (whether the scan then crashes depends on the block's address),
# so this test fails deterministically when the link is missing.
execute_process(COMMAND ${PROGRAM} doctor RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message("${output}")
  message(FATAL_ERROR "'lightskin doctor' failed (exit ${result})")
endif()
if(NOT output MATCHES "rasterised triangle: ok")
  message(FATAL_ERROR "'lightskin doctor' did not draw (no 'rasterised triangle: ok'): the check needs a GL run")
endif()
# The hook must be logging at all, or the absence below proves nothing.
if(NOT output MATCHES "__tls_get_addr: ")
  message(FATAL_ERROR "no __tls_get_addr lines: ASAN_OPTIONS=verbosity=2 did not reach the program")
endif()
string(REGEX MATCHALL "[^\n]*(Can't guess glibc version|glibc >=2\\.19 suspected)[^\n]*" guessed "${output}")
if(guessed)
  string(REGEX MATCHALL "[^\n]*__tls_get_addr: 0x[^\n]*" calls "${output}")
  string(REPLACE ";" "\n" calls "${calls}")
  string(REPLACE ";" "\n" guessed "${guessed}")
  message(FATAL_ERROR "a dynamic TLS block went through libasan's guess (LeakSanitizer may crash at exit):\n"
    "${guessed}\nthe intercepted calls that allocated TLS blocks:\n${calls}")
endif()
message("no dynamic TLS block went through libasan's guess")
