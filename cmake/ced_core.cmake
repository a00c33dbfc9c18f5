# ced::core — detection: the cloud, modalities, the detector, preprocessing.
# No IO; consumers need no Eigen, and never see CGAL or TBB.
ced_library(ced_core core
  src/core/cloud.cpp
  src/core/cloud_arrays.cpp
  src/core/channels.cpp
  src/core/lab.cpp
  src/core/normals.cpp
  src/core/registry.cpp
  src/core/plugin.cpp
  src/core/transform.cpp
  src/core/preprocess.cpp
  src/core/parallel.cpp
  src/core/arena.cpp
  src/core/validate.cpp
  src/core/neighborhoods.cpp
  src/core/block_partition.cpp
  src/core/tile_geometry.cpp
  src/core/neighbor_index.cpp
  src/core/neighbor_block.cpp
  src/core/list_block.cpp
  src/core/kernel/dispatch.cpp
  src/core/kernel/block_kernel_generic.cpp
  src/core/saliency.cpp
  src/core/scaled.cpp
  src/core/candidates.cpp
  src/core/nms.cpp
  src/core/detect.cpp)
# The neighbour pass is also built for AVX2 and chosen at run time; both
# builds give bitwise identical results (no FMA contraction in either).
include(CheckCXXCompilerFlag)
check_cxx_compiler_flag(-mavx2 CED_COMPILER_HAS_AVX2)
if(CED_COMPILER_HAS_AVX2 AND CMAKE_SYSTEM_PROCESSOR MATCHES "x86_64|AMD64|amd64|i.86")
  target_sources(ced_core PRIVATE src/core/kernel/block_kernel_avx2.cpp)
  set_source_files_properties(src/core/kernel/block_kernel_avx2.cpp PROPERTIES COMPILE_OPTIONS
    "-mavx2;-ffp-contract=off;-Wno-psabi")
  target_compile_definitions(ced_core PRIVATE CED_HAS_AVX2_KERNEL)
  # ... and for AVX-512 (VL, BW, DQ) where the compiler can: the same 8-lane
  # code with its lane masks in mask registers. (GCC 12's AVX-512 headers
  # warn of their own _mm*_undefined_* values: GCC bug 105593.)
  check_cxx_compiler_flag("-mavx512f -mavx512vl -mavx512bw -mavx512dq" CED_COMPILER_HAS_AVX512)
  if(CED_COMPILER_HAS_AVX512)
    target_sources(ced_core PRIVATE src/core/kernel/block_kernel_avx512.cpp)
    set_source_files_properties(src/core/kernel/block_kernel_avx512.cpp PROPERTIES COMPILE_OPTIONS
      "-mavx2;-mavx512f;-mavx512vl;-mavx512bw;-mavx512dq;-ffp-contract=off;-Wno-psabi;-Wno-maybe-uninitialized")
    target_compile_definitions(ced_core PRIVATE CED_HAS_AVX512_KERNEL)
  endif()
endif()
set_source_files_properties(src/core/kernel/block_kernel_generic.cpp PROPERTIES COMPILE_OPTIONS
  "-ffp-contract=off;-Wno-psabi")
# CGAL's searches are one template instantiation each in this unit: with
# GCC's default unit growth, adding code here stopped bounded_priority_queue's
# insert from being inlined into CGAL's k-nearest search (+5 M instructions
# on loft's --radius auto). More room keeps it inlined.
set_source_files_properties(src/core/neighbor_index.cpp PROPERTIES COMPILE_OPTIONS "--param=inline-unit-growth=80")
# CGAL stays private: only src/core/neighbor_index.cpp includes it.
target_link_libraries(ced_core PUBLIC Threads::Threads PRIVATE CGAL::CGAL ${CMAKE_DL_LIBS})
if(CED_WITH_TBB)
  # What CGAL::TBB_support does, without exporting a CGAL target to users.
  target_link_libraries(ced_core PRIVATE TBB::tbb)
  target_compile_definitions(ced_core PRIVATE CED_HAS_TBB CGAL_LINKED_WITH_TBB)
endif()

# ced::plugin_api — headers only, for plugins (cmake/cedPlugins.cmake): the
# include path and C++17, no library.
add_library(ced_plugin_api INTERFACE)
add_library(ced::plugin_api ALIAS ced_plugin_api)
set_target_properties(ced_plugin_api PROPERTIES EXPORT_NAME plugin_api)
target_compile_features(ced_plugin_api INTERFACE cxx_std_17)
target_include_directories(ced_plugin_api INTERFACE
  $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
  $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/modalities>
  $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include>
  $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
