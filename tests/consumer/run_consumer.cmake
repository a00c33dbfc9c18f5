# Builds and runs the consumer project against ced.
#   find_package:     installs the already-built ced into WORK_DIR/prefix first,
#                     checks the installed headers (exactly the API list, no
#                     private or third-party include), compiles each on its
#                     own, and loads an out-of-tree plugin into the installed
#                     `ced`; then configures the consumer again as if PCL and
#                     Open3D were not installed: it must configure, say so,
#                     and build the adaptors that remain.
#   add_subdirectory: builds ced from source inside the consumer: the
#                     libraries the consumer programs link (ced::core,
#                     ced::io, ced::ced), not ced's optional parts (Python
#                     module, PCL component) that no consumer target needs.
# Compiles through LAUNCHER (the launcher of ced's own build, e.g. ccache),
# else through ccache when it is installed: WORK_DIR's paths stay the same
# from run to run, so a rerun compiles only what changed.
file(REMOVE_RECURSE ${WORK_DIR})
set(args -DCED_CONSUMER_MODE=${MODE} -DCMAKE_BUILD_TYPE=Release -DCED_SOURCE_DIR=${CED_SOURCE_DIR})
if(NOT LAUNCHER)
  find_program(LAUNCHER ccache)
endif()
if(LAUNCHER)
  list(APPEND args -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
if(MODE STREQUAL "find_package")
  execute_process(COMMAND ${CMAKE_COMMAND} --install ${CED_BINARY_DIR} --prefix ${WORK_DIR}/prefix
                  RESULT_VARIABLE rc OUTPUT_QUIET)
  if(rc)
    message(FATAL_ERROR "install failed: ${rc}")
  endif()
  set(include_dir ${WORK_DIR}/prefix/include)
  # The installed tree is the API list, nothing more, nothing less.
  file(GLOB_RECURSE installed RELATIVE ${include_dir} ${include_dir}/*)
  list(SORT installed)
  file(STRINGS ${EXPECTED_HEADERS} expected)
  list(SORT expected)
  if(NOT installed STREQUAL expected)
    set(extra ${installed})
    list(REMOVE_ITEM extra ${expected})
    set(missing ${expected})
    list(REMOVE_ITEM missing ${installed})
    message(FATAL_ERROR "installed headers differ from the API list: not in the list: [${extra}]; "
                        "missing: [${missing}]")
  endif()
  foreach(header ${installed})
    if(header MATCHES "^ced/(eigen|pcl|open3d)[.]hpp$")
      continue()  # the optional adaptors include their libraries, and only they
    endif()
    file(STRINGS ${include_dir}/${header} includes REGEX "^[ \t]*#[ \t]*include")
    foreach(line ${includes})
      if(line MATCHES "[<\"](CGAL|tbb|oneapi|Eigen|nlohmann|stb|core|io/scalar_io|kernel)[/_.]")
        message(FATAL_ERROR "installed header ${header} includes a private or third-party header: ${line}")
      endif()
    endforeach()
  endforeach()
  list(APPEND args -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCED_INCLUDE_DIR=${include_dir})
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CED_SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build ${args}
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configure failed: ${rc}")
endif()
set(targets)
if(MODE STREQUAL "add_subdirectory")
  set(targets --target consumer consumer_core consumer_adaptors)
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build -j2 ${targets} RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "build failed: ${rc}")
endif()
foreach(program consumer consumer_core consumer_adaptors)
  execute_process(COMMAND ${WORK_DIR}/build/${program} WORKING_DIRECTORY ${WORK_DIR}/build RESULT_VARIABLE rc)
  if(rc)
    message(FATAL_ERROR "${program} failed: ${rc}")
  endif()
endforeach()
if(MODE STREQUAL "find_package" AND EXISTS ${WORK_DIR}/prefix/bin/ced)
  execute_process(COMMAND ${WORK_DIR}/prefix/bin/ced modalities --plugin ${WORK_DIR}/build/libced_ndvi.so
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc OR NOT out MATCHES "ndvi")
    message(FATAL_ERROR "the installed ced did not load the out-of-tree plugin (exit ${rc}): ${out}${err}")
  endif()
  message(STATUS "installed ced loaded the out-of-tree plugin: ndvi listed")
endif()

# As if PCL and Open3D were not installed: find_package(ced ...
# OPTIONAL_COMPONENTS pcl open3d) still configures, and says what is missing.
if(MODE STREQUAL "find_package")
  set(bare ${args} -DCMAKE_DISABLE_FIND_PACKAGE_Open3D=ON)
  if(PCL_INCLUDE)  # ced's build's (cmake/find_pcl.cmake): hidden from the consumer
    list(APPEND bare -DCMAKE_IGNORE_PATH=${PCL_INCLUDE})
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -S ${CED_SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/bare ${bare}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc OR NOT out MATCHES "no ced::pcl \\(its library is not installed\\)"
     OR NOT out MATCHES "no ced::open3d \\(its library is not installed\\)")
    message(FATAL_ERROR "without PCL and Open3D the consumer must configure and say so (exit ${rc}): ${out}${err}")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/bare --target consumer_adaptors RESULT_VARIABLE rc)
  execute_process(COMMAND ${WORK_DIR}/bare/consumer_adaptors RESULT_VARIABLE run OUTPUT_VARIABLE out)
  if(rc OR run OR out MATCHES "pcl|open3d")
    message(FATAL_ERROR "without PCL and Open3D: consumer_adaptors failed (build ${rc}, run ${run}): ${out}")
  endif()
  message(STATUS "without PCL and Open3D the consumer configures, says so, and runs: ${out}")
endif()
