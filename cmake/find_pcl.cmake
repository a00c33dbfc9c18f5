# Finds the PCL pieces ced's optional PCL parts use (cmake/pcl.cmake). PCL's
# CMake config drags in VTK (and MPI); this finds the few libraries directly
# instead of find_package(PCL). Sets CED_PCL_FOUND, the default of CED_WITH_PCL.
find_path(CED_PCL_INCLUDE pcl/point_types.h PATH_SUFFIXES pcl-1.14 pcl-1.13 pcl-1.12)
foreach(lib common kdtree io_ply io keypoints features search octree filters sample_consensus registration)
  string(TOUPPER ${lib} LIB)
  find_library(CED_PCL_${LIB} pcl_${lib})
endforeach()
find_library(CED_FLANN flann_cpp)
find_library(CED_LZ4 lz4)  # FLANN's headers call LZ4 (programs that define PCL_NO_PRECOMPILE)
find_package(Boost QUIET)
find_package(Eigen3 3.3 QUIET NO_MODULE)  # only the PCL pieces use Eigen
set(CED_PCL_FOUND OFF)
if(CED_PCL_INCLUDE AND CED_PCL_COMMON AND CED_PCL_KDTREE AND CED_PCL_KEYPOINTS AND CED_PCL_FEATURES AND CED_PCL_SEARCH
   AND CED_PCL_OCTREE AND CED_PCL_FILTERS AND CED_PCL_SAMPLE_CONSENSUS AND CED_PCL_REGISTRATION AND CED_FLANN
   AND Boost_FOUND AND Eigen3_FOUND)
  set(CED_PCL_FOUND ON)
endif()
