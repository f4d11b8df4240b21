# Installs lightskin into a temporary prefix, configures and builds one of examples/ against the
# installed package only (CMAKE_PREFIX_PATH: find_package and pkg-config), then runs it with ARGS
# and requires its "<name> ok" line.
file(REMOVE_RECURSE ${WORK_DIR})
string(REPLACE ";" " " CONSUMER_FLAGS "${CONSUMER_FLAGS}")
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${prefix} RESULT_VARIABLE result OUTPUT_QUIET)
if(result)
  message(FATAL_ERROR "cmake --install failed: ${result}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/${EXAMPLE} -B ${WORK_DIR}/build
                        -G ${GENERATOR} -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release
                        "-DCMAKE_C_FLAGS=${CONSUMER_FLAGS}" "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}"
                        "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}"
                RESULT_VARIABLE result)
if(result)
  message(FATAL_ERROR "configuring examples/${EXAMPLE} against the installed package failed: ${result}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE result)
if(result)
  message(FATAL_ERROR "building examples/${EXAMPLE} failed: ${result}")
endif()
string(REPLACE "|" ";" ARGS "${ARGS}")
execute_process(COMMAND ${WORK_DIR}/build/${EXAMPLE} ${ARGS} RESULT_VARIABLE result OUTPUT_VARIABLE output)
message(STATUS "${EXAMPLE} said:\n${output}")
if(result)
  message(FATAL_ERROR "examples/${EXAMPLE} failed: ${result}")
endif()
if(NOT output MATCHES "${EXAMPLE} ok")
  message(FATAL_ERROR "examples/${EXAMPLE} did not report success")
endif()
