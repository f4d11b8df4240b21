cmake_minimum_required(VERSION 3.20) # IN_LIST in script mode
# Every dynamic symbol liblightskin.so exports is lsk_* (or the version node), at least the
# documented entry points are there, and the SONAME is liblightskin.so.<major>.<minor>.
#
# Exported means what the dynamic linker can bind to: a defined (not UND) .dynsym entry with GLOBAL,
# WEAK or UNIQUE binding and DEFAULT or PROTECTED visibility. `nm -D --defined-only` is not that: it
# also lists LOCAL .dynsym entries, which the ASan Debug (-O0) build has (a `std::vector<int>` member
# instance, bound LOCAL by the version script's `local: *;` but kept in .dynsym for a relocation,
# `t ..._M_realloc_insert...@@LIGHTSKIN_0.1`). No other library can bind to such an entry, so it is
# not part of the ABI; readelf shows the binding and visibility to decide on.
execute_process(COMMAND readelf --dyn-syms --wide ${LIBRARY} OUTPUT_VARIABLE table RESULT_VARIABLE result)
if(result)
  message(FATAL_ERROR "readelf failed on ${LIBRARY}: ${result}")
endif()
string(REPLACE "\n" ";" lines "${table}")
set(count 0)
set(exported "")
set(rows 0)
foreach(line IN LISTS lines)
  # "   Num:    Value          Size Type    Bind   Vis      Ndx Name"
  if(NOT line MATCHES "^ *[0-9]+: +[0-9a-f]+ +(0x)?[0-9a-f]+ +([A-Z_0-9]+) +([A-Z_0-9]+) +([A-Z_0-9]+) +([A-Z0-9]+) *(.*)$")
    continue()
  endif()
  math(EXPR rows "${rows} + 1")
  set(bind "${CMAKE_MATCH_3}")
  set(visibility "${CMAKE_MATCH_4}")
  set(section "${CMAKE_MATCH_5}")
  set(name "${CMAKE_MATCH_6}")
  if(section STREQUAL "UND" OR NOT bind MATCHES "^(GLOBAL|WEAK|UNIQUE|GNU_UNIQUE)$"
     OR NOT visibility MATCHES "^(DEFAULT|PROTECTED)$")
    continue()
  endif()
  string(REGEX REPLACE " *\\([0-9]+\\)$" "" name "${name}") # readelf's version index suffix, if any
  string(REGEX REPLACE "@.*" "" bare "${name}")
  if(NOT bare MATCHES "^lsk_" AND NOT bare MATCHES "^LIGHTSKIN_[0-9.]+$")
    message(FATAL_ERROR "liblightskin.so exports '${name}' (${line}): only lsk_* may be exported")
  endif()
  list(APPEND exported "${bare}")
  math(EXPR count "${count} + 1")
endforeach()
# A readelf whose layout this parser does not understand must not pass as "nothing exported".
if(rows EQUAL 0)
  message(FATAL_ERROR "no .dynsym rows parsed from readelf's output for ${LIBRARY}:\n${table}")
endif()
foreach(required lsk_version lsk_last_error lsk_session_create lsk_session_create_from_source lsk_session_destroy
                 lsk_session_submit lsk_session_process_next lsk_session_report lsk_session_render
                 lsk_session_technique)
  if(NOT required IN_LIST exported)
    message(FATAL_ERROR "liblightskin.so does not export ${required}")
  endif()
endforeach()
execute_process(COMMAND readelf -d ${LIBRARY} OUTPUT_VARIABLE dynamic)
if(NOT dynamic MATCHES "SONAME\\)[^\n]*\\[liblightskin\\.so\\.[0-9]+\\.[0-9]+\\]")
  message(FATAL_ERROR "liblightskin.so has no SONAME liblightskin.so.<major>.<minor>:\n${dynamic}")
endif()
message(STATUS "${count} exported symbols, all lsk_*")
