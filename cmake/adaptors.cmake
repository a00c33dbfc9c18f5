# The optional, header-only adaptors (include/ced/eigen.hpp, pcl.hpp, open3d.hpp):
#   ced::eigen  ced::core + Eigen, when Eigen is found;
#   ced::pcl    ced::core + PCL's common, search, kdtree and octree libraries,
#               when PCL is found (cmake/find_pcl.cmake);
#   ced::open3d ced::core + Open3D, when Open3D is found (Debian: libopen3d-dev).
# Their headers are installed always; an installed ced gives the same targets
# through find_package(ced COMPONENTS eigen pcl) (cmake/cedConfig.cmake.in).
# Only the compile units that include an adaptor see its library.
set(CED_ADAPTOR_HEADERS include/ced/eigen.hpp include/ced/pcl.hpp include/ced/open3d.hpp)
find_package(Eigen3 3.3 QUIET NO_MODULE)
if(Eigen3_FOUND)
  add_library(ced_eigen INTERFACE)
  add_library(ced::eigen ALIAS ced_eigen)
  target_link_libraries(ced_eigen INTERFACE ced_core Eigen3::Eigen)
endif()
if(CED_PCL_FOUND)
  add_library(ced_pcl_adaptor INTERFACE)
  add_library(ced::pcl ALIAS ced_pcl_adaptor)
  target_include_directories(ced_pcl_adaptor SYSTEM INTERFACE ${CED_PCL_INCLUDE})
  target_link_libraries(ced_pcl_adaptor INTERFACE ced_core ${CED_PCL_SEARCH} ${CED_PCL_OCTREE} ${CED_PCL_KDTREE}
    ${CED_PCL_COMMON} ${CED_FLANN} Eigen3::Eigen Boost::boost)
  if(CED_LZ4)
    target_link_libraries(ced_pcl_adaptor INTERFACE ${CED_LZ4})
  endif()
endif()
find_package(Open3D QUIET)
if(Open3D_FOUND)
  add_library(ced_open3d INTERFACE)
  add_library(ced::open3d ALIAS ced_open3d)
  target_link_libraries(ced_open3d INTERFACE ced_core Open3D::Open3D)
  # Open3D's link options name Open3D::Open3D in a generator expression that a
  # parent project (add_subdirectory) evaluates: the target must be seen there.
  set_target_properties(Open3D::Open3D PROPERTIES IMPORTED_GLOBAL TRUE)
else()
  message(STATUS "Open3D not found: ced::open3d (ced/open3d.hpp) is not tested (Debian: libopen3d-dev)")
endif()
if(NOT CED_PCL_FOUND)
  message(STATUS "PCL not found: ced::pcl (ced/pcl.hpp) is not tested (Debian: libpcl-dev)")
endif()
