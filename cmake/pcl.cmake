# ced's PCL component (src/pcl/): PCL's detectors (ISS3D, Harris3D/6D, SIFT)
# and the registration pipeline for `ced eval`, CED_WITH_PCL (on by default
# when PCL is found, cmake/find_pcl.cmake). Two builds of the same sources:
#   ced_pcl         static, for the tests and benchmarks;
#   ced_pcl_module  libced_pcl.so, which the `ced` tool loads on first use
#                   (src/pcl/pcl_loader.cpp), so that a command that does not
#                   use PCL does not load PCL's libraries. It links PCL and
#                   ced's headers only, and calls the tool's exported ced.
if(CED_WITH_PCL AND NOT CED_PCL_FOUND)
  message(STATUS "PCL not found: ced is built without its PCL component (PCL detectors, ced eval registration)")
elseif(CED_WITH_PCL)
  set(CED_PCL_SOURCES src/pcl/pcl_detectors.cpp src/pcl/pcl_registration.cpp)
  set(CED_PCL_LIBRARIES ${CED_PCL_REGISTRATION} ${CED_PCL_KEYPOINTS} ${CED_PCL_FEATURES} ${CED_PCL_FILTERS}
    ${CED_PCL_SAMPLE_CONSENSUS} ${CED_PCL_SEARCH} ${CED_PCL_OCTREE} ${CED_PCL_KDTREE} ${CED_PCL_COMMON} ${CED_FLANN}
    Eigen3::Eigen Boost::boost)
  # GCC 12 reports a false -Warray-bounds inside Eigen's SSE code as inlined
  # from PCL's SVD transformation estimation (system headers, not ours).
  set_source_files_properties(src/pcl/pcl_registration.cpp PROPERTIES COMPILE_OPTIONS "-Wno-array-bounds")

  add_library(ced_pcl STATIC ${CED_PCL_SOURCES})
  target_compile_options(ced_pcl PRIVATE ${CED_WARNINGS})
  target_include_directories(ced_pcl PUBLIC ${PROJECT_SOURCE_DIR}/src/pcl)
  target_include_directories(ced_pcl PRIVATE ${PROJECT_SOURCE_DIR}/src)  # the private headers (core/timing.hpp)
  target_include_directories(ced_pcl SYSTEM PRIVATE ${CED_PCL_INCLUDE})
  target_compile_definitions(ced_pcl PUBLIC CED_HAS_PCL)
  target_link_libraries(ced_pcl PUBLIC ced::ced PRIVATE ${CED_PCL_LIBRARIES})

  if(CED_BUILD_CLI)
    # The module sits where the tool finds it, relative to the tool: the same
    # path in the build tree (bin/../lib/ced) as installed.
    file(RELATIVE_PATH CED_PCL_MODULE_DIR "${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}"
      "${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}/ced")
    add_library(ced_pcl_module MODULE ${CED_PCL_SOURCES} src/pcl/pcl_module.cpp)
    set_target_properties(ced_pcl_module PROPERTIES OUTPUT_NAME ced_pcl CXX_VISIBILITY_PRESET hidden
      VISIBILITY_INLINES_HIDDEN ON LIBRARY_OUTPUT_DIRECTORY ${CMAKE_RUNTIME_OUTPUT_DIRECTORY}/${CED_PCL_MODULE_DIR})
    target_compile_options(ced_pcl_module PRIVATE ${CED_WARNINGS})
    target_include_directories(ced_pcl_module PRIVATE ${PROJECT_SOURCE_DIR}/src/pcl ${PROJECT_SOURCE_DIR}/src)
    target_include_directories(ced_pcl_module SYSTEM PRIVATE ${CED_PCL_INCLUDE})
    target_link_libraries(ced_pcl_module PRIVATE ced::plugin_api ${CED_PCL_LIBRARIES})
    install(TARGETS ced_pcl_module LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/ced)

    target_sources(ced_cli PRIVATE src/pcl/pcl_loader.cpp)
    target_include_directories(ced_cli PRIVATE ${PROJECT_SOURCE_DIR}/src/pcl)
    target_compile_definitions(ced_cli PRIVATE CED_HAS_PCL
      CED_PCL_MODULE_RELPATH="${CED_PCL_MODULE_DIR}/$<TARGET_FILE_NAME:ced_pcl_module>")
    add_dependencies(ced_cli ced_pcl_module)
    message(STATUS "ced: the tool loads PCL on demand from ${CED_PCL_MODULE_DIR}/libced_pcl.so beside bin/")
  endif()

  if(CED_BUILD_TESTS)
    add_subdirectory(tests/pcl)
  endif()
  if(TARGET bench_detect)
    target_link_libraries(bench_detect PRIVATE ced_pcl)  # PCL's detectors beside ced in one run
  endif()
endif()

# Optional (CED_WITH_PCL_REFERENCE): a PCL reference implementation to check
# ced against on real scans.
if(CED_WITH_PCL_REFERENCE)
  if(CED_PCL_FOUND AND CED_PCL_IO_PLY AND CED_PCL_IO)
    add_executable(pcl_ced tests/reference/pcl_ced.cpp)
    target_include_directories(pcl_ced SYSTEM PRIVATE ${CED_PCL_INCLUDE})
    target_link_libraries(pcl_ced PRIVATE ${CED_PCL_KEYPOINTS} ${CED_PCL_FEATURES} ${CED_PCL_SEARCH} ${CED_PCL_OCTREE}
      ${CED_PCL_IO} ${CED_PCL_IO_PLY} ${CED_PCL_KDTREE} ${CED_PCL_COMMON} ${CED_FLANN}
      Eigen3::Eigen Boost::boost)
  else()
    message(STATUS "PCL not found: the PCL reference implementation is not built")
  endif()
endif()
