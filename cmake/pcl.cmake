# ced_pcl: PCL's detectors (ISS3D, Harris3D/6D, SIFT) and the registration
# pipeline for `ced eval` (src/pcl/), CED_WITH_PCL (on by default when PCL
# is found, cmake/find_pcl.cmake).
if(CED_WITH_PCL AND NOT CED_PCL_FOUND)
  message(STATUS "PCL not found: ced is built without its PCL component (PCL detectors, ced eval registration)")
elseif(CED_WITH_PCL)
  add_library(ced_pcl STATIC src/pcl/pcl_detectors.cpp src/pcl/pcl_registration.cpp)
  target_compile_options(ced_pcl PRIVATE ${CED_WARNINGS})
  # GCC 12 reports a false -Warray-bounds inside Eigen's SSE code as inlined
  # from PCL's SVD transformation estimation (system headers, not ours).
  set_source_files_properties(src/pcl/pcl_registration.cpp PROPERTIES COMPILE_OPTIONS "-Wno-array-bounds")
  target_include_directories(ced_pcl PUBLIC ${PROJECT_SOURCE_DIR}/src/pcl)
  target_include_directories(ced_pcl PRIVATE ${PROJECT_SOURCE_DIR}/src)  # the private headers (core/timing.hpp)
  target_include_directories(ced_pcl SYSTEM PRIVATE ${CED_PCL_INCLUDE})
  target_compile_definitions(ced_pcl PUBLIC CED_HAS_PCL)
  target_link_libraries(ced_pcl PUBLIC ced::ced PRIVATE ${CED_PCL_REGISTRATION} ${CED_PCL_KEYPOINTS}
    ${CED_PCL_FEATURES} ${CED_PCL_FILTERS} ${CED_PCL_SAMPLE_CONSENSUS} ${CED_PCL_SEARCH} ${CED_PCL_OCTREE}
    ${CED_PCL_KDTREE} ${CED_PCL_COMMON} ${CED_FLANN} Eigen3::Eigen Boost::boost)
  if(CED_BUILD_CLI)
    target_link_libraries(ced_cli PRIVATE ced_pcl)
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
