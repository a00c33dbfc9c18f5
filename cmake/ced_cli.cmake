# The `ced` tool (CED_BUILD_CLI) and ced-mpi (CED_MPI): src/cli/, src/mpi/.
# Both load plugins (cmake/cedPlugins.cmake).
if(CED_BUILD_CLI)
  find_package(CLI11 QUIET CONFIG)
  add_executable(ced_cli
    src/cli/main.cpp
    src/cli/common.cpp
    src/cli/config.cpp
    src/cli/inputs.cpp
    src/cli/detectors.cpp
    src/cli/detect.cpp
    src/cli/detect_write.cpp
    src/cli/info.cpp
    src/cli/eval.cpp
    src/cli/registration.cpp
    src/cli/convert.cpp
    src/cli/tiled_commands.cpp
    src/cli/view.cpp
    src/cli/modalities.cpp)
  set_target_properties(ced_cli PROPERTIES OUTPUT_NAME ced)
  target_compile_options(ced_cli PRIVATE ${CED_WARNINGS})
  target_link_libraries(ced_cli PRIVATE ced::ced)
  ced_enable_plugins(ced_cli)
endif()

# ced-mpi: the tiles of `ced detect --tile-size` shared between MPI ranks,
# on by default when Boost.MPI and an MPI are found (Debian: libboost-mpi-dev,
# openmpi-bin; found and the option set in CMakeLists.txt). Not with the
# sanitizers.
if(CED_MPI)
  if(NOT (MPI_CXX_FOUND AND Boost_MPI_FOUND))
    message(FATAL_ERROR "CED_MPI=ON needs MPI and Boost.MPI (Debian: libboost-mpi-dev openmpi-bin)")
  endif()
  add_executable(ced_mpi
    src/mpi/main.cpp
    src/cli/common.cpp
    src/cli/config.cpp
    src/cli/inputs.cpp
    src/cli/detect.cpp
    src/cli/detect_write.cpp
    src/cli/tiled_commands.cpp)
  set_target_properties(ced_mpi PROPERTIES OUTPUT_NAME ced-mpi)
  target_compile_options(ced_mpi PRIVATE ${CED_WARNINGS})
  target_link_libraries(ced_mpi PRIVATE ced::ced Boost::mpi Boost::serialization MPI::MPI_CXX)
  ced_enable_plugins(ced_mpi)
  install(TARGETS ced_mpi RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  message(STATUS "ced: ced-mpi is built (MPI ${MPI_CXX_VERSION})")
else()
  message(STATUS "ced: ced-mpi is not built (needs Boost.MPI and an MPI: libboost-mpi-dev openmpi-bin)")
endif()

# The tools' operator new: large blocks in transparent huge pages
# (src/cli/huge_pages.cpp). Not under the sanitizers, which replace it.
if(NOT (CED_SANITIZE OR CED_FUZZ OR CED_TSAN))
  foreach(tool ced_cli ced_mpi)
    if(TARGET ${tool})
      target_sources(${tool} PRIVATE src/cli/huge_pages.cpp)
    endif()
  endforeach()
endif()
