// SPDX-License-Identifier: MIT
// PCD (src/io/pcd/): round trips of every scalar type and encoding, hand-written
// files, packed RGB, organized clouds, chunks decoded in parallel.

#include "pcd_test_support.hpp"

using namespace pcd_test;

// ------------------------------------------------------------- round trips

TEST_P(PcdRoundTrip, EveryScalarTypeThroughAFile) {
  const point_cloud c = all_types_cloud();
  const std::string path = temp_file(std::string("roundtrip_") + format_name(GetParam()) + ".pcd");
  ced::io::write_pcd(path, c, GetParam());
  const std::string bytes = read_bytes(path);
  EXPECT_CONTAINS(bytes, "VERSION 0.7\n");
  EXPECT_CONTAINS(bytes, std::string("\nDATA ") + format_name(GetParam()) + "\n");
  EXPECT_CONTAINS(bytes,
                  "FIELDS x y z f_int8 f_uint8 f_int16 f_uint16 f_int32 f_uint32 f_int64 f_uint64 "
                  "f_float32 f_float64 rgb\n");
  EXPECT_CONTAINS(bytes, "SIZE 4 4 4 1 1 2 2 4 4 8 8 4 8 4\n");
  EXPECT_CONTAINS(
      bytes, std::string("TYPE F F F I U I U I U I U F F ") + (GetParam() == pcd_format::ascii ? "U" : "F") + "\n");
  pcd_read_info info;
  const point_cloud r = ced::io::read_pcd(path, &info);
  expect_same_cloud(c, r);
  EXPECT_EQ(info.points_declared, 5u);
  EXPECT_EQ(info.width, 5u);
  EXPECT_EQ(info.height, 1u);
  EXPECT_EQ(info.nonfinite_removed, 0u);
  EXPECT_FALSE(info.organized);
  EXPECT_EQ(info.data_format, format_name(GetParam()));
}

TEST_P(PcdRoundTrip, EveryScalarTypeThroughAStream) {
  const point_cloud c = all_types_cloud();
  expect_same_cloud(c, read_string(write_string(c, GetParam())));
}

TEST_P(PcdRoundTrip, EmptyCloud) {
  point_cloud c;
  c.add_field("intensity", scalar_type::float32, {});
  const point_cloud r = read_string(write_string(c, GetParam()));
  EXPECT_TRUE(r.empty());
  ASSERT_EQ(r.fields().size(), 1u);
  EXPECT_EQ(r.fields()[0].name, "intensity");
}

TEST_P(PcdRoundTrip, BigCloud) {
  const point_cloud c = big_cloud(50000);
  const std::string bytes = write_string(c, GetParam());
  if (GetParam() == pcd_format::binary_compressed) {
    EXPECT_LT(bytes.size(), 50000u * 18 * 9 / 10) << "LZF should compress this cloud";
  }
  expect_same_cloud(c, read_string(bytes));
}

TEST_P(PcdRoundTrip, GeoreferencedCoordinatesKeepTheirPrecision) {
  point_cloud c;
  c.set_origin({512000.0, 4123000.0, 300.0});
  std::vector<std::array<double, 3>> abs;
  for (int i = 0; i < 50; ++i) {
    const std::array<double, 3> p{512345.678 + 0.731 * i, 4123456.789 - 1.37 * i, 312.345 + 0.01 * i};
    abs.push_back(p);
    c.push_back(float(p[0] - 512000.0), float(p[1] - 4123000.0), float(p[2] - 300.0));
  }
  const std::string bytes = write_string(c, GetParam());
  EXPECT_CONTAINS(bytes, "SIZE 8 8 8\n");
  const point_cloud r = read_string(bytes);
  ASSERT_EQ(r.size(), c.size());
  EXPECT_NE(r.origin()[0], 0.0);
  for (std::size_t i = 0; i < r.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(r.origin()[k] + r.position(i)[k], abs[i][k], 1e-3) << i;
}

TEST(PcdCompression, ConstantCloudCompressesAtLzfsMaximumRatio) {
  point_cloud c;
  c.resize(200000);  // all zeros: LZF's best case, ~88:1
  const std::string bytes = write_string(c, pcd_format::binary_compressed);
  EXPECT_LT(bytes.size(), 200000u * 12 / 80);
  const point_cloud r = read_string(bytes);
  EXPECT_EQ(r.positions(), c.positions());
}

INSTANTIATE_TEST_SUITE_P(AllFormats, PcdRoundTrip,
                         ::testing::Values(pcd_format::ascii, pcd_format::binary, pcd_format::binary_compressed),
                         [](const auto& p) { return std::string(format_name(p.param)); });

// ------------------------------------------------------------ hand written

TEST(PcdRead, HandWrittenAscii) {
  const std::string text =
      "# .PCD v0.7 - Point Cloud Data file format\r\n"
      "VERSION 0.7\r\n"
      "FIELDS x y z intensity label\r\n"
      "SIZE 4 4 4 4 2\r\n"
      "TYPE F F F F U\r\n"
      "COUNT 1 1 1 1 1\r\n"
      "WIDTH 3\r\n"
      "HEIGHT 1\r\n"
      "VIEWPOINT 0 0 0 1 0 0 0\r\n"
      "POINTS 3\r\n"
      "DATA ascii\r\n"
      "0.5 -1.25 2 0.75 7\r\n"
      "\r\n"
      "1e3 +2 -0 1 65535\r\n"
      "3 4 5 0.125 0";  // no final newline
  pcd_read_info info;
  const point_cloud c = read_string(text, &info);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c.position(0)[0], 0.5f);
  EXPECT_EQ(c.position(0)[1], -1.25f);
  EXPECT_EQ(c.position(1)[0], 1000.f);
  EXPECT_EQ(c.position(2)[2], 5.f);
  EXPECT_EQ(c.origin(), (std::array<double, 3>{0, 0, 0}));
  ASSERT_EQ(c.fields().size(), 2u);
  EXPECT_EQ(c.fields()[0].name, "intensity");
  EXPECT_EQ(c.fields()[0].type(), scalar_type::float32);
  EXPECT_EQ(c.fields()[0].values, (std::vector<double>{0.75, 1, 0.125}));
  EXPECT_EQ(c.fields()[1].name, "label");
  EXPECT_EQ(c.fields()[1].type(), scalar_type::uint16);
  EXPECT_EQ(c.fields()[1].values, (std::vector<double>{7, 65535, 0}));
  EXPECT_EQ(info.data_format, "ascii");
}

TEST(PcdRead, OldHeaderWithoutVersionSizeAndType) {
  // PCD v0.5 style: COLUMNS, no VERSION/SIZE/TYPE/COUNT/VIEWPOINT: all float32.
  const point_cloud c = read_string("COLUMNS x y z w\nPOINTS 2\nDATA ascii\n1 2 3 4\n5 6 7 8\n");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.position(1)[2], 7.f);
  EXPECT_EQ(c.get_field("w").type(), scalar_type::float32);
  EXPECT_EQ(c.get_field("w").values[1], 8.0);
  // WIDTH without POINTS.
  EXPECT_EQ(read_string("VERSION .7\nFIELDS x y z\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n").size(), 1u);
}

TEST(PcdRead, PackedRgbAsFloatAndAsUnsigned) {
  const std::uint32_t colours[2] = {0x00ff8001u, 0x00123456u};
  bytes_builder f, u;
  f.data = header(2, "binary", "x y z rgb", "4 4 4 4", "F F F F");
  u.data = header(2, "binary", "x y z rgb", "4 4 4 4", "F F F U");
  for (int i = 0; i < 2; ++i) {
    f.put(float(i)).put(0.f).put(0.f).put(packed_float(colours[i]));
    u.put(float(i)).put(0.f).put(0.f).put(colours[i]);
  }
  for (const auto* b : {&f, &u}) {
    const point_cloud c = read_string(b->data);
    ASSERT_EQ(c.fields().size(), 3u);
    EXPECT_EQ(c.fields()[0].name, "red");
    EXPECT_EQ(c.fields()[1].name, "green");
    EXPECT_EQ(c.fields()[2].name, "blue");
    for (const auto& fld : c.fields()) EXPECT_EQ(fld.type(), scalar_type::uint8);
    EXPECT_EQ(c.get_field("red").values, (std::vector<double>{255, 0x12}));
    EXPECT_EQ(c.get_field("green").values, (std::vector<double>{128, 0x34}));
    EXPECT_EQ(c.get_field("blue").values, (std::vector<double>{1, 0x56}));
    EXPECT_TRUE(c.has_rgb());
  }
}

TEST(PcdRead, RgbaDropsAlpha) {
  bytes_builder b;
  b.data = header(1, "binary", "x y z rgba", "4 4 4 4", "F F F U");
  b.put(1.f).put(2.f).put(3.f).put(std::uint32_t(0xff102030u));
  const point_cloud c = read_string(b.data);
  ASSERT_EQ(c.fields().size(), 3u);
  EXPECT_EQ(c.get_field("red").values[0], 0x10);
  EXPECT_EQ(c.get_field("green").values[0], 0x20);
  EXPECT_EQ(c.get_field("blue").values[0], 0x30);
}

TEST(PcdRead, PackedRgbInAscii) {
  // TYPE U (as PCL writes ascii), TYPE F written as an integer, TYPE F written as a float.
  const point_cloud u = read_string(header(1, "ascii", "x y z rgb", "4 4 4 4", "F F F U") + "0 0 0 16711808\n");
  EXPECT_EQ(u.get_field("red").values[0], 255);
  EXPECT_EQ(u.get_field("blue").values[0], 128);
  const point_cloud fi = read_string(header(1, "ascii", "x y z rgb", "4 4 4 4", "F F F F") + "0 0 0 1193046\n");
  EXPECT_EQ(fi.get_field("red").values[0], 0x12);
  EXPECT_EQ(fi.get_field("green").values[0], 0x34);
  EXPECT_EQ(fi.get_field("blue").values[0], 0x56);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "0 0 0 %.9g\n", static_cast<double>(packed_float(0x00123456u)));
  const point_cloud ff = read_string(header(1, "ascii", "x y z rgb", "4 4 4 4", "F F F F") + buf);
  EXPECT_EQ(ff.get_field("red").values[0], 0x12);
  EXPECT_EQ(ff.get_field("blue").values[0], 0x56);
}

TEST(PcdRead, OrganizedCloudDropsNaNPoints) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  // 3 x 2 image; pixels 1 and 4 are invalid (NaN / Inf).
  const float xyz[6][3] = {{0, 0, 1}, {nan, nan, nan}, {2, 0, 1}, {0, 1, 1}, {1, inf, 1}, {2, 1, 1}};
  const std::string head =
      "VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 1\n"
      "WIDTH 3\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\nDATA ";
  bytes_builder binary, field_major;
  binary.data = head + "binary\n";
  for (int i = 0; i < 6; ++i) binary.put(xyz[i][0]).put(xyz[i][1]).put(xyz[i][2]).put(std::uint8_t(10 * i));
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 6; ++i) field_major.put(xyz[i][k]);
  for (int i = 0; i < 6; ++i) field_major.put(std::uint8_t(10 * i));
  const std::string packed = ced::io::lzf_compress(field_major.data);
  const std::string compressed = head + "binary_compressed\n" + u32_bytes(std::uint32_t(packed.size())) +
                                 u32_bytes(std::uint32_t(field_major.data.size())) + packed;
  std::string ascii = head + "ascii\n";
  for (int i = 0; i < 6; ++i) {
    std::ostringstream line;
    line << xyz[i][0] << " " << xyz[i][1] << " " << xyz[i][2] << " " << 10 * i << "\n";
    ascii += line.str();
  }
  for (const std::string* bytes : {&std::as_const(binary.data), &compressed, &std::as_const(ascii)}) {
    pcd_read_info info;
    const point_cloud c = read_string(*bytes, &info);
    ASSERT_EQ(c.size(), 4u);
    EXPECT_EQ(info.width, 3u);
    EXPECT_EQ(info.height, 2u);
    EXPECT_EQ(info.points_declared, 6u);
    EXPECT_EQ(info.nonfinite_removed, 2u);
    EXPECT_TRUE(info.organized);
    EXPECT_EQ(c.get_field("intensity").values, (std::vector<double>{0, 20, 30, 50}));
    EXPECT_EQ(c.position(1)[0], 2.f);
    EXPECT_EQ(c.position(3)[1], 1.f);
  }
}

TEST(PcdRead, CountAboveOneAndPaddingFields) {
  // normal has COUNT 3; "_" is a 4-byte padding field (as in PCL's aligned point types).
  bytes_builder b;
  b.data = header(2, "binary", "x y z _ normal", "4 4 4 1 4", "F F F U F", "1 1 1 4 3");
  for (int i = 0; i < 2; ++i) {
    b.put(float(i)).put(1.f).put(2.f).put(std::uint32_t(0xdeadbeef));
    b.put(0.5f * i).put(-1.f).put(0.25f);
  }
  const point_cloud c = read_string(b.data);
  ASSERT_EQ(c.size(), 2u);
  ASSERT_EQ(c.fields().size(), 3u);
  EXPECT_EQ(c.fields()[0].name, "normal_0");
  EXPECT_EQ(c.fields()[1].name, "normal_1");
  EXPECT_EQ(c.fields()[2].name, "normal_2");
  EXPECT_EQ(c.get_field("normal_0").values, (std::vector<double>{0, 0.5}));
  EXPECT_EQ(c.get_field("normal_2").values, (std::vector<double>{0.25, 0.25}));

  // The same in ascii, with or without the padding values, and compressed (PCL leaves padding out).
  const std::string h = header(2, "ascii", "x y z _ normal", "4 4 4 1 4", "F F F U F", "1 1 1 4 3");
  const point_cloud a = read_string(h + "0 1 2 0 0 0 0 0 -1 0.25\n1 1 2 0.5 -1 0.25\n");
  EXPECT_EQ(a.get_field("normal_0").values, (std::vector<double>{0, 0.5}));
  // field-major: x0 x1 y0 y1 z0 z1 then normal point 0 (3 floats), point 1 (3 floats).
  bytes_builder fm;
  for (float v : {0.f, 1.f, 1.f, 1.f, 2.f, 2.f, 0.f, -1.f, 0.25f, 0.5f, -1.f, 0.25f}) fm.put(v);
  const std::string packed = ced::io::lzf_compress(fm.data);
  const point_cloud z =
      read_string(header(2, "binary_compressed", "x y z _ normal", "4 4 4 1 4", "F F F U F", "1 1 1 4 3") +
                  u32_bytes(std::uint32_t(packed.size())) + u32_bytes(24 + 24) + packed);
  EXPECT_EQ(z.get_field("normal_0").values, (std::vector<double>{0, 0.5}));
  EXPECT_EQ(z.get_field("normal_1").values, (std::vector<double>{-1, -1}));
}

TEST(PcdRead, IntegerAndDoubleCoordinates) {
  bytes_builder b;
  b.data = header(2, "binary", "x y z", "8 2 1", "F I U");
  b.put(600000.25).put(std::int16_t(-3)).put(std::uint8_t(200));
  b.put(600001.5).put(std::int16_t(4)).put(std::uint8_t(0));
  const point_cloud c = read_string(b.data);
  EXPECT_EQ(c.origin(), (std::array<double, 3>{600001, 0, 0}));  // only x lies far from 0
  EXPECT_EQ(c.position(0)[0], -0.75f);
  EXPECT_EQ(c.position(1)[0], 0.5f);
  EXPECT_EQ(c.position(1)[1], 4.f);
  EXPECT_EQ(c.position(0)[2], 200.f);
}

TEST(PcdRead, ChunksDecodedInParallelEqualTheAsciiReader) {
  // 60 000 points of 30 bytes: several chunks of records, decoded in
  // parallel from a file, from memory and from binary_compressed data; NaN
  // points in some chunks only, dropped (or kept) in order.
  point_cloud c;
  const std::size_t n = 60000;
  std::vector<double> rgb[3], s16(n), f32(n), f64(n);
  for (auto& v : rgb) v.resize(n);
  std::size_t nan_points = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool nan = i % 1009 == 3 && i < 30000;
    nan_points += nan;
    c.push_back(nan ? std::numeric_limits<float>::quiet_NaN() : float(i % 317) * 0.25f, float(i % 101),
                1e-3f * float(i));
    for (std::size_t k = 0; k < 3; ++k) rgb[k][i] = double((i * (k + 1)) % 256);
    s16[i] = double(i % 65536) - 32768;
    f32[i] = i % 999 == 1 ? std::numeric_limits<double>::infinity() : double(i) * 0.125;
    f64[i] = double(i) / 7;
  }
  c.add_field("red", scalar_type::uint8, rgb[0]);
  c.add_field("green", scalar_type::uint8, rgb[1]);
  c.add_field("blue", scalar_type::uint8, rgb[2]);
  c.add_field("s16", scalar_type::int16, s16);
  c.add_field("f32", scalar_type::float32, f32);
  c.add_field("f64", scalar_type::float64, f64);
  const std::string dir = temp_dir().string();
  for (const auto& [name, fmt] : {std::pair<const char*, pcd_format>{"a.pcd", pcd_format::ascii},
                                  {"b.pcd", pcd_format::binary},
                                  {"c.pcd", pcd_format::binary_compressed}})
    ced::io::write_pcd(dir + "/" + name, c, fmt);
  pcd_read_info info;
  const point_cloud ascii = ced::io::read_pcd(dir + "/a.pcd", &info);
  EXPECT_EQ(info.nonfinite_removed, nan_points);
  ASSERT_EQ(ascii.size(), n - nan_points);
  for (const char* name : {"b.pcd", "c.pcd"}) {
    SCOPED_TRACE(name);
    pcd_read_info binary_info;
    expect_same_cloud(ascii, ced::io::read_pcd(dir + "/" + name, &binary_info));
    EXPECT_EQ(binary_info.nonfinite_removed, nan_points);
    expect_same_cloud(ascii, ced::io::read_pcd_buffer(read_bytes(dir + "/" + name), name));
    expect_same_cloud(ced::io::read_pcd(dir + "/a.pcd", nullptr, true),
                      ced::io::read_pcd(dir + "/" + name, nullptr, true));
  }
  // Only the selected fields; the same values.
  ced::io::read_options o;
  o.fields = ced::field_selection::only({"f32", "green"});
  const point_cloud some = ced::io::read_cloud(dir + "/c.pcd", o);
  ASSERT_EQ(some.fields().size(), 2u);
  EXPECT_EQ(some.fields()[0].name, "green");
  EXPECT_EQ(some.fields()[0].values, ascii.get_field("green").values);
  EXPECT_EQ(some.fields()[1].values, ascii.get_field("f32").values);
  EXPECT_EQ(some.positions(), ascii.positions());

  // The stream keeps the NaN points; after a first pass its chunks are the
  // points read_pcd keeps them as.
  const point_cloud kept = ced::io::read_pcd(dir + "/b.pcd", nullptr, true);
  auto s = ced::io::open_point_stream(dir + "/b.pcd");
  point_cloud chunk;
  while (s->read(25000, {0, 0, 0}, chunk) > 0) {
  }
  EXPECT_EQ(s->origin(), kept.origin());
  s->rewind();
  std::size_t at = 0;
  while (s->read(7777, s->origin(), chunk) > 0) {
    point_cloud part = kept;
    std::vector<std::uint8_t> keep(kept.size(), 0);
    std::fill(keep.begin() + static_cast<std::ptrdiff_t>(at),
              keep.begin() + static_cast<std::ptrdiff_t>(at + chunk.size()), 1);
    part.filter(keep);
    expect_same_cloud(part, chunk);
    at += chunk.size();
  }
  EXPECT_EQ(at, n);
}

TEST(PcdWrite, PacksRgbLikePcl) {
  point_cloud c;
  c.push_back(1, 2, 3);
  c.add_field("intensity", scalar_type::float32, {0.5});
  c.add_rgb({{0x12, 0x34, 0x56}});
  const std::string binary = write_string(c, pcd_format::binary);
  EXPECT_CONTAINS(binary, "FIELDS x y z intensity rgb\nSIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 1\n");
  std::uint32_t bits = 0;
  std::memcpy(&bits, binary.data() + binary.size() - 4, 4);
  EXPECT_EQ(bits, 0x00123456u);
  const std::string ascii = write_string(c, pcd_format::ascii);
  EXPECT_CONTAINS(ascii, "TYPE F F F F U\n");
  EXPECT_CONTAINS(ascii, "DATA ascii\n1 2 3 0.5 1193046\n");
  // Non-uint8 colour fields are written as they are.
  point_cloud d;
  d.push_back(0, 0, 0);
  d.add_field("red", scalar_type::uint16, {300});
  d.add_field("green", scalar_type::uint8, {1});
  d.add_field("blue", scalar_type::uint8, {2});
  EXPECT_CONTAINS(write_string(d, pcd_format::binary), "FIELDS x y z red green blue\n");
}

TEST(PcdWrite, BadFieldsAreRejectedAndLeaveNoFile) {
  point_cloud c;
  c.push_back(0, 0, 0);
  c.add_field("has space", scalar_type::float32, {1});
  const std::string path = temp_file("bad_field.pcd");
  EXPECT_THROW(ced::io::write_pcd(path, c), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
  point_cloud d;
  d.push_back(0, 0, 0);
  d.add_field("x", scalar_type::float32, {1});
  EXPECT_THROW(write_string(d, pcd_format::binary), std::invalid_argument);
  point_cloud e;
  e.push_back(0, 0, 0);
  e.add_rgb({{1, 2, 3}});
  e.add_field("rgb", scalar_type::uint32, {5});
  EXPECT_THROW(write_string(e, pcd_format::binary), std::invalid_argument);
  point_cloud f;
  f.push_back(0, 0, 0);
  f.fields().push_back({"short", scalar_type::float32, {}});
  EXPECT_THROW(write_string(f, pcd_format::binary), std::invalid_argument);
  EXPECT_THROW(ced::io::write_pcd(temp_file("no/such/dir/a.pcd"), c), io_error);
}
