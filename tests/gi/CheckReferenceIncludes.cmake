# ctest gi_reference_isolation: no product source (gi's technique folders and registry, render, mr, the
# `lightskin` program's commands) includes a header of gi/reference or its private code. Run with
# -DSOURCE_DIR=<repository>. A tool command (apps/lightskin/Bench*, SynthCommand) belongs to lightskin-tools.
set(product_globs
  gi/include/*.h gi/src/*.cpp gi/common/*.h gi/common/*.cpp gi/lightskin/*.h gi/lightskin/*.cpp
  gi/bruteforce/*.h gi/bruteforce/*.cpp gi/volumes/*.h gi/volumes/*.cpp gi/prt/*.h gi/prt/*.cpp
  gi/differential/*.h gi/differential/*.cpp render/*.h render/*.cpp mr/*.h mr/*.cpp apps/lightskin/*.h
  apps/lightskin/*.cpp)
set(files "")
foreach(pattern IN LISTS product_globs)
  file(GLOB_RECURSE found ${SOURCE_DIR}/${pattern})
  list(APPEND files ${found})
endforeach()
list(FILTER files EXCLUDE REGEX "/apps/lightskin/(Bench[^/]*|SynthCommand)\\.cpp$")
list(LENGTH files count)
if(count LESS 50)
  message(FATAL_ERROR "found only ${count} product sources under ${SOURCE_DIR}: wrong SOURCE_DIR?")
endif()
set(offenders "")
foreach(file IN LISTS files)
  file(STRINGS ${file} lines REGEX "#include [<\"](lightskin/gi/reference/|reference/|.*gi/reference/)")
  if(lines)
    file(RELATIVE_PATH relative ${SOURCE_DIR} ${file})
    list(APPEND offenders "${relative}: ${lines}")
  endif()
endforeach()
if(offenders)
  list(JOIN offenders "\n  " text)
  message(FATAL_ERROR "product sources include the test references (gi/reference):\n  ${text}")
endif()
message(STATUS "${count} product sources, none includes gi/reference")
