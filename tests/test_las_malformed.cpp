// SPDX-License-Identifier: MIT
// Malformed LAS files: each is an io_error naming the file and the problem.

#include "las_test_support.hpp"

using namespace las_test;

TEST(LasMalformed, BadSignature) {
  las_file file;
  file.points = sample_points(0);
  std::string bytes = file.build();
  bytes[0] = 'X';
  EXPECT_CONTAINS(read_error(bytes), "not a LAS file (it does not start with the 'LASF' signature)");
  EXPECT_CONTAINS(read_error("LAS"), "'LASF' signature");
  EXPECT_CONTAINS(read_error(""), "'LASF' signature");
}

TEST(LasMalformed, TruncatedHeader) {
  las_file file;
  file.points = sample_points(0);
  EXPECT_CONTAINS(read_error(file.build().substr(0, 100)), "truncated header: the file has 100 bytes");
  file.minor = 4;
  file.format = 6;
  file.points.clear();
  EXPECT_CONTAINS(read_error(file.build().substr(0, 300)), "a LAS 1.4 header needs 375");
}

TEST(LasMalformed, UnsupportedVersion) {
  las_file file;
  std::string bytes = file.build();
  bytes[24] = 2;
  EXPECT_CONTAINS(read_error(bytes), "unsupported LAS version 2.2");
  bytes[24] = 1;
  bytes[25] = 5;
  EXPECT_CONTAINS(read_error(bytes), "unsupported LAS version 1.5");
}

TEST(LasMalformed, HeaderSizeAndPointOffset) {
  las_file file;
  file.points = sample_points(0);
  std::string bytes = file.build();
  poke<std::uint16_t>(bytes, 94, 200);
  EXPECT_CONTAINS(read_error(bytes), "header size 200 is smaller than the 227 bytes of a LAS 1.2 header");
  bytes = file.build();
  poke<std::uint32_t>(bytes, 96, 100);
  EXPECT_CONTAINS(read_error(bytes), "offset to point data (100) is smaller than the header size (227)");
  poke<std::uint32_t>(bytes, 96, 100000);
  EXPECT_CONTAINS(read_error(bytes), "truncated: the point data should start at byte 100000");
}

TEST(LasMalformed, TruncatedPointsAreCaughtBeforeAllocating) {
  las_file file;
  file.format = 1;
  file.points = sample_points(1);
  file.declared = 4000000000;  // 4e9 points of 28 bytes in a file of ~300 bytes
  EXPECT_CONTAINS(read_error(file.build()), "truncated: 4000000000 points declared, room for 3");
  // 1.4: the 64-bit count.
  file.minor = 4;
  file.format = 6;
  file.points = sample_points(6);
  file.declared = std::int64_t{1} << 62;
  EXPECT_CONTAINS(read_error(file.build()), "truncated: 4611686018427387904 points declared, room for 3");
  // A partial last record.
  file.declared = -1;
  EXPECT_CONTAINS(read_error(file.build().substr(0, 375 + 2 * 30 + 29)), "truncated: 3 points declared, room for 2");
}

TEST(LasMalformed, RecordLengthTooSmall) {
  las_file file;
  file.format = 3;
  file.points = sample_points(3);
  std::string bytes = file.build();
  poke<std::uint16_t>(bytes, 105, 30);
  EXPECT_CONTAINS(read_error(bytes),
                  "point record length 30 is too small for point format 3 (it needs at least 34 bytes)");
}

TEST(LasMalformed, UnsupportedPointFormat) {
  las_file file;
  std::string bytes = file.build();
  bytes[104] = 11;
  EXPECT_CONTAINS(read_error(bytes), "unsupported point data record format 11");
}

TEST(LasMalformed, LazCompressed) {
  las_file file;
  file.format = 3;
  file.points = sample_points(3);
  std::string bytes = file.build();
  bytes[104] = static_cast<char>(0x83);  // LASzip marks compressed points with bit 7
  // ... and a LASzip VLR says how (test_laz.cpp reads real LAZ files).
  EXPECT_CONTAINS(read_error(bytes, "compressed.las"), "no LASzip VLR");
  bytes[104] = static_cast<char>(0x46);  // bit 6
  EXPECT_CONTAINS(read_error(bytes), "unknown compression of the point data");
}

TEST(LasMalformed, ZeroOrNonFiniteScale) {
  las_file file;
  file.points = sample_points(0);
  file.scale = {0.01, 0, 0.01};
  EXPECT_CONTAINS(read_error(file.build()), "invalid Y scale factor 0 (it must be finite and non-zero)");
  file.scale = {0.01, 0.01, std::numeric_limits<double>::infinity()};
  EXPECT_CONTAINS(read_error(file.build()), "invalid Z scale factor inf");
  file.scale = {std::nan(""), 0.01, 0.01};
  EXPECT_CONTAINS(read_error(file.build()), "invalid X scale factor");
  file.scale = {0.01, 0.01, 0.01};
  file.offset = {0, std::nan(""), 0};
  EXPECT_CONTAINS(read_error(file.build()), "invalid Y offset");
}

TEST(LasMalformed, ExtraBytesThatDoNotFitTheRecord) {
  las_file file;
  file.minor = 4;
  file.format = 6;
  file.vlrs.push_back(vlr("LASF_Spec", 4, descriptor(10, 0, "a") + descriptor(6, 0, "b")));  // 12 bytes
  file.points = sample_points(6);
  for (auto& p : file.points) p.extra = std::string(8, '\0');  // room for 8 only
  EXPECT_CONTAINS(read_error(file.build()),
                  "the extra bytes (12 bytes in 2 descriptors) do not fit in the 38-byte point record (point format 6 "
                  "uses 30 bytes)");
}

TEST(LasMalformed, BadExtraBytesVlr) {
  las_file file;
  file.minor = 4;
  file.format = 6;
  file.points = sample_points(6);
  file.vlrs = {vlr("LASF_Spec", 4, descriptor(1, 0, "a") + "xyz")};
  EXPECT_CONTAINS(read_error(file.build()), "the extra-bytes VLR has 195 bytes, not a multiple of the 192-byte");
  file.vlrs = {vlr("LASF_Spec", 4, descriptor(31, 0, "odd"))};
  EXPECT_CONTAINS(read_error(file.build()), "extra-bytes descriptor 0 ('odd') has unknown data type 31");
  file.vlrs = {vlr("LASF_Spec", 4, descriptor(3, 8, "s", {0, 1, 1}))};
  for (auto& p : file.points) p.extra = "ab";
  EXPECT_CONTAINS(read_error(file.build()), "extra-bytes descriptor 0 ('s') has an invalid scale 0");
}

TEST(LasMalformed, VlrsPastThePointData) {
  las_file file;
  file.points = sample_points(0);
  file.vlrs = {vlr("LASF_Projection", 34735, std::string(40, 'g'))};
  std::string bytes = file.build();
  poke<std::uint16_t>(bytes, 227 + 20, 400);  // the VLR claims 400 bytes
  EXPECT_CONTAINS(read_error(bytes),
                  "VLR 0 ('LASF_Projection' record 34735, 400 bytes) runs past the start of the point data");
  bytes = file.build();
  poke<std::uint32_t>(bytes, 100, 2);  // a second VLR that is not there
  EXPECT_CONTAINS(read_error(bytes), "VLR 1 of 2 (at byte 321) does not fit before the point data");
}

TEST(LasMalformed, FileErrors) {
  try {
    ced::io::read_las(temp_file("does_not_exist.las"));
    ADD_FAILURE() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "cannot open");
    EXPECT_CONTAINS(e.what(), "does_not_exist.las");
  }
  EXPECT_THROW(ced::io::read_las(temp_dir().string()), io_error);
}

// ------------------------------------------------------------------ writing
