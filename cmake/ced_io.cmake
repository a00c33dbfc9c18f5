# ced::io — reading and writing PLY, PCD, LAS/LAZ/COPC, CSV; RGB-D frames.
# A staircase: base/ (scalar IO, records, output files, stream support) is
# used by every format; las/ and laz/ by LAS, LAZ and COPC; io.cpp and
# stream.cpp, on top, dispatch through the table of formats (formats.cpp).
ced_library(ced_io io
  src/io/base/records.cpp
  src/io/base/output_file.cpp
  src/io/las/header.cpp
  src/io/las/read.cpp
  src/io/las/write.cpp
  src/io/las/pieces.cpp
  src/io/las/stream.cpp
  src/io/las/entries.cpp
  src/io/laz/chunks.cpp
  src/io/laz/copc.cpp
  src/io/ply/header.cpp
  src/io/ply/read.cpp
  src/io/ply/write.cpp
  src/io/ply/stream.cpp
  src/io/pcd/header.cpp
  src/io/pcd/read.cpp
  src/io/pcd/write.cpp
  src/io/pcd/stream.cpp
  src/io/pcd/lzf.cpp
  src/io/csv/read.cpp
  src/io/csv/write.cpp
  src/io/csv/stream.cpp
  src/io/stream.cpp
  src/io/io.cpp
  src/io/catalogue.cpp
  src/io/formats.cpp
  src/io/rgbd.cpp
  src/io/transform_io.cpp)
target_include_directories(ced_io SYSTEM PRIVATE ${CED_STB_INCLUDE_DIR})
target_link_libraries(ced_io PUBLIC ced_core)
