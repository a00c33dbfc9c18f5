# ced::io — reading and writing PLY, PCD, LAS, CSV; RGB-D frames.
ced_library(ced_io io
  src/io/ply.cpp
  src/io/las.cpp
  src/io/laz.cpp
  src/io/copc.cpp
  src/io/stream.cpp
  src/io/records.cpp
  src/io/pcd.cpp
  src/io/lzf.cpp
  src/io/csv.cpp
  src/io/output_file.cpp
  src/io/io.cpp
  src/io/rgbd.cpp
  src/io/transform_io.cpp)
target_include_directories(ced_io SYSTEM PRIVATE ${CED_STB_INCLUDE_DIR})
target_link_libraries(ced_io PUBLIC ced_core)
