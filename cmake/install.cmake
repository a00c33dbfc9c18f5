# `cmake --install` (CED_INSTALL): the libraries, the public headers (the API
# lists of CMakeLists.txt, each into its folder under include/: ced/,
# ced/io/, ced/modalities/), the generated ced/version.hpp, the tool, and the
# package files for find_package(ced): cedConfig.cmake, its version file,
# cedTargets.cmake and the plugin helpers cedPlugins.cmake.
# tests/consumer checks the installed tree.
include(CMakePackageConfigHelpers)
install(TARGETS ced_core ced_io ced ced_plugin_api EXPORT cedTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
foreach(header ${CED_CORE_HEADERS} ${CED_IO_HEADERS} ${CED_EXTRA_HEADERS} ${CED_ADAPTOR_HEADERS})
  string(REGEX REPLACE "^(include|modalities)/" "" relative ${header})
  get_filename_component(folder ${relative} DIRECTORY)
  install(FILES ${header} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/${folder})
endforeach()
install(FILES ${PROJECT_BINARY_DIR}/include/ced/version.hpp DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ced)
if(CED_BUILD_CLI)
  install(TARGETS ced_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(EXPORT cedTargets NAMESPACE ced:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ced)
configure_package_config_file(cmake/cedConfig.cmake.in ${PROJECT_BINARY_DIR}/cedConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ced)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cedConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/cedConfig.cmake ${PROJECT_BINARY_DIR}/cedConfigVersion.cmake
  ${PROJECT_SOURCE_DIR}/cmake/cedPlugins.cmake ${PROJECT_SOURCE_DIR}/cmake/find_pcl.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ced)
