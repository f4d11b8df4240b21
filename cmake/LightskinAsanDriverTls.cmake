# ASan builds only (LIGHTSKIN_SANITIZE): the libraries of Mesa's software driver that hold general-dynamic
# thread-local storage, to be linked into every GL program so that they load at start-up (gl/CMakeLists.txt).
#
# Why: GCC 12's LeakSanitizer (libasan 8) crashes at exit, "Tracer caught signal 11", when a dynamic TLS block
# happens to start 16 bytes past a page boundary. Its __tls_get_addr hook does not know glibc 2.36's layout and
# guesses the glibc 2.19 one: for such a block it reads the 16 bytes before it (ASan's chunk header) as
# {start, size} and later scans that bogus range, e.g. "DTLS 26 at 0x3c28-0x1800004d2a" (docs/TESTING.md has
# the log). The block is libLLVM-15's, which Mesa dlopens with swrast_dri.so, and glibc allocates it with
# malloc on the first access of each thread; its address decides everything, so a given binary crashes every
# time or never. A library in the start-up set gets its TLS in the static block instead, which the hook
# recognises ("static tls"), so no block goes through the guess. Leak checking is unchanged.
#
# Sets LIGHTSKIN_ASAN_DRIVER_TLS_LIBRARIES: the driver's direct dependencies with a PT_TLS segment that are not
# DF_STATIC_TLS (initial-exec TLS is always static); empty, with a warning, if the driver is not found.
function(lightskin_find_asan_driver_tls_libraries)
  set(result "")
  find_file(LIGHTSKIN_SWRAST_DRI swrast_dri.so
    PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/dri /usr/lib64/dri /usr/lib/dri NO_DEFAULT_PATH)
  find_program(LIGHTSKIN_READELF readelf)
  find_program(LIGHTSKIN_LDD ldd)
  if(NOT LIGHTSKIN_SWRAST_DRI OR NOT LIGHTSKIN_READELF OR NOT LIGHTSKIN_LDD)
    message(WARNING "ASan build: Mesa's swrast_dri.so, readelf or ldd not found; GL test processes may hit "
      "LeakSanitizer's dynamic-TLS crash at exit (cmake/LightskinAsanDriverTls.cmake)")
    set(LIGHTSKIN_ASAN_DRIVER_TLS_LIBRARIES "" PARENT_SCOPE)
    return()
  endif()
  execute_process(COMMAND ${LIGHTSKIN_LDD} ${LIGHTSKIN_SWRAST_DRI} OUTPUT_VARIABLE ldd_output
    RESULT_VARIABLE ldd_result)
  if(NOT ldd_result EQUAL 0)
    message(WARNING "ASan build: ldd ${LIGHTSKIN_SWRAST_DRI} failed (exit ${ldd_result})")
  endif()
  string(REGEX MATCHALL "=> (/[^ \n]+)" resolved "${ldd_output}")
  foreach(entry IN LISTS resolved)
    string(REGEX REPLACE "^=> " "" library "${entry}")
    execute_process(COMMAND ${LIGHTSKIN_READELF} -lW ${library} OUTPUT_VARIABLE segments)
    execute_process(COMMAND ${LIGHTSKIN_READELF} -dW ${library} OUTPUT_VARIABLE dynamic)
    if(segments MATCHES "\n +TLS " AND NOT dynamic MATCHES "STATIC_TLS")
      list(APPEND result ${library})
    endif()
  endforeach()
  message(STATUS "ASan build: GL programs link Mesa's dynamic-TLS libraries at start-up: ${result}")
  set(LIGHTSKIN_ASAN_DRIVER_TLS_LIBRARIES "${result}" PARENT_SCOPE)
endfunction()
