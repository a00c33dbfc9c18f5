# Builds and runs the consumer project against ced.
#   find_package:     installs the already-built ced into WORK_DIR/prefix first.
#   add_subdirectory: builds ced from source inside the consumer.
file(REMOVE_RECURSE ${WORK_DIR})
set(args -DCED_CONSUMER_MODE=${MODE} -DCMAKE_BUILD_TYPE=Release)
if(MODE STREQUAL "find_package")
  execute_process(COMMAND ${CMAKE_COMMAND} --install ${CED_BINARY_DIR} --prefix ${WORK_DIR}/prefix
                  RESULT_VARIABLE rc OUTPUT_QUIET)
  if(rc)
    message(FATAL_ERROR "install failed: ${rc}")
  endif()
  list(APPEND args -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix)
else()
  list(APPEND args -DCED_SOURCE_DIR=${CED_SOURCE_DIR})
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CED_SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build ${args}
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configure failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build -j2 RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "build failed: ${rc}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/consumer RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "consumer failed: ${rc}")
endif()
