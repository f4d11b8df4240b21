# cmake -DCOMPILE_COMMANDS=<build>/compile_commands.json [-DALLOWED=<regex of source files>] -P CheckPortableFlags.cmake
#
# Fails when a compile command carries a flag that ties the binary to one CPU: -march/-mtune/-mcpu (native or a
# named CPU) or an instruction-set extension (-mavx2, -mfma, -msse4.2, ...). Everything is built for the x86-64
# baseline; vector code picks its instruction set at run time (core/SimdTarget.h). ALLOWED names the files of
# an opted-in native probe (LIGHTSKIN_BUILD_NATIVE_PROBES).
if(NOT EXISTS "${COMPILE_COMMANDS}")
  message(FATAL_ERROR "${COMPILE_COMMANDS}: missing (configure with a Ninja or Makefile generator)")
endif()
file(STRINGS "${COMPILE_COMMANDS}" commands REGEX "\"command\": ")
list(LENGTH commands count)
if(count EQUAL 0)
  message(FATAL_ERROR "${COMPILE_COMMANDS}: no compile command found")
endif()
set(cpu_flag " -m(arch|tune|cpu)=[^ ]+| -m(no-)?(avx|sse3|ssse3|sse4|fma|f16c|bmi|popcnt|lzcnt|vpclmulqdq|gfni|vaes|aes|pclmul)[^ ]*")
set(offenders "")
foreach(command IN LISTS commands)
  if(command MATCHES "${cpu_flag}")
    set(flag "${CMAKE_MATCH_0}")
    string(REGEX MATCH "-c [^ \"]+" source "${command}")
    if(ALLOWED AND source MATCHES "${ALLOWED}")
      continue()
    endif()
    string(APPEND offenders "\n  ${source}:${flag}")
  endif()
endforeach()
if(offenders)
  message(FATAL_ERROR "compile commands built for one CPU (use Highway's run-time dispatch instead):${offenders}")
endif()
message(STATUS "${count} compile commands, none with a CPU-specific flag")
