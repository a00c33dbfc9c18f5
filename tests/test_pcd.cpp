// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <utility>

#include "ced/io/io.hpp"
#include "ced/io/pcd.hpp"
#include "ced/io/stream.hpp"
#include "core/parallel.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;
using ced::point_cloud;
using ced::scalar_type;
using ced::io::io_error;
using ced::io::pcd_format;
using ced::io::pcd_read_info;

using ced_test::expect_same_cloud;
using ced_test::read_bytes;
using ced_test::temp_dir;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace {

point_cloud read_string(const std::string& bytes, pcd_read_info* info = nullptr) {
  return ced::io::read_pcd_buffer(bytes, "test.pcd", info);
}

/// The io_error message from reading `bytes` (through a file named `name`).
std::string read_error(const std::string& bytes, const std::string& name = "bad.pcd") {
  return ced_test::read_error_of([](const std::string& path) { ced::io::read_pcd(path); }, bytes, name);
}

/// Appends little-endian binary values.
struct bytes_builder {
  std::string data;
  template <class T>
  bytes_builder& put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // the tests run on little-endian hosts
    data.append(b, sizeof(T));
    return *this;
  }
};

std::string u32_bytes(std::uint32_t v) { return bytes_builder{}.put(v).data; }

float packed_float(std::uint32_t bits) {
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

const char* format_name(pcd_format f) {
  return f == pcd_format::ascii ? "ascii" : f == pcd_format::binary ? "binary" : "binary_compressed";
}

/// A header for FIELDS x y z (F4) + `extra` fields, n points, unorganized.
std::string header(std::size_t n, const std::string& data, const std::string& fields = "x y z",
                   const std::string& size = "4 4 4", const std::string& type = "F F F", std::string count = "") {
  if (count.empty())
    for (char c : " " + fields)
      if (c == ' ') count += count.empty() ? "1" : " 1";
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " +
         type + "\nCOUNT " + count + "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
         std::to_string(n) + "\nDATA " + data + "\n";
}

point_cloud all_types_cloud() {
  point_cloud c;
  c.push_back(0.f, 0.f, 0.f);
  c.push_back(1.5f, -2.25f, 3.125f);
  c.push_back(-1000.f, 1e-7f, 123.456f);
  c.push_back(9999.5f, -std::numeric_limits<float>::denorm_min(), 0.1f);
  c.push_back(-0.f, 3.4e38f, -1e-30f);
  const scalar_type types[] = {scalar_type::int8,    scalar_type::uint8,  scalar_type::int16, scalar_type::uint16,
                               scalar_type::int32,   scalar_type::uint32, scalar_type::int64, scalar_type::uint64,
                               scalar_type::float32, scalar_type::float64};
  for (scalar_type t : types) {
    std::vector<double> v;
    if (t == scalar_type::int64) {
      v = {-9007199254740992.0, 9007199254740992.0, 0, 1, -5};
    } else if (t == scalar_type::uint64) {
      v = {0, 9007199254740992.0, 18446744073709549568.0, 1, 77};
    } else if (ced::is_integer(t)) {
      const auto r = ced::natural_range(t);
      v = {r[0], r[1], 0, 1, std::floor((r[0] + r[1]) / 3)};
    } else if (t == scalar_type::float32) {
      v = {double(0.1f), double(-3.4e38f), double(std::numeric_limits<float>::denorm_min()), 1e-3f,
           std::numeric_limits<double>::quiet_NaN()};
    } else {
      v = {0.1, -1.7976931348623157e308, 4.9e-324, 1.0 / 3.0, -0.0};
    }
    c.add_field(std::string("f_") + std::string(ced::name_of(t)), t, v);
  }
  c.add_rgb({{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {1, 2, 3}, {200, 100, 50}});
  return c;
}

std::string write_string(const point_cloud& c, pcd_format fmt) {
  std::ostringstream s(std::ios::out | std::ios::binary);
  ced::io::write_pcd(s, c, fmt);
  return s.str();
}

/// A room-like cloud with colour and intensity: compressible like real data.
point_cloud big_cloud(std::size_t n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.f, 4.f);
  point_cloud c;
  std::vector<double> intensity(n), red(n), green(n), blue(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.push_back(u(rng), u(rng), i % 3 == 0 ? 0.f : u(rng));
    intensity[i] = double(i % 1000);
    red[i] = double(i / 1000 % 256);
    green[i] = 128;
    blue[i] = double(i % 7);
  }
  c.add_field("intensity", scalar_type::uint16, intensity);
  c.add_field("red", scalar_type::uint8, red);
  c.add_field("green", scalar_type::uint8, green);
  c.add_field("blue", scalar_type::uint8, blue);
  return c;
}

class PcdRoundTrip : public ::testing::TestWithParam<pcd_format> {};

}  // namespace

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

// ------------------------------------------------------------------ errors

TEST(PcdErrors, MissingFileAndNotAPcd) {
  try {
    ced::io::read_pcd(temp_file("does_not_exist.pcd"));
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "cannot open");
    EXPECT_CONTAINS(e.what(), "does_not_exist.pcd");
  }
  EXPECT_CONTAINS(read_error("ply\nformat ascii 1.0\n"), "not a PCD file");
  EXPECT_CONTAINS(read_error(""), "no DATA line");
}

TEST(PcdErrors, HeaderProblems) {
  const std::string tail = "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n0 0 0\n";
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + tail),
                  "SIZE lists 2 values but FIELDS names 3 fields");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F F\nCOUNT 1 1 1\n" + tail),
                  "TYPE lists 4 values but FIELDS names 3 fields");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1\n" + tail),
                  "COUNT lists 2 values but FIELDS names 3 fields");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 2\nTYPE F F F\n" + tail),
                  "field 'z': unsupported TYPE F with SIZE 2");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\n" + tail), "invalid TYPE 'Q'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nCOUNT 1 1 0\n" + tail), "invalid COUNT '0'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y\n" + tail), "no 'z' field");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z x\n" + tail), "field 'x' is declared twice");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nCOLOUR 1\n" + tail), "unknown header keyword 'COLOUR'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nWIDTH -1\nDATA ascii\n"), "invalid WIDTH line");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n"),
                  "POINTS (3) does not equal WIDTH × HEIGHT (2 × 2 = 4)");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nDATA ascii\n"), "neither WIDTH nor POINTS");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nPOINTS 1\nDATA binary_lzma\n"),
                  "unknown DATA format 'binary_lzma'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nPOINTS 1\n0 0 0\n"), "the PCD header has no DATA line");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nSIZE 4 4 4\nPOINTS 1\nDATA ascii\n0 0 0\n"), "no FIELDS line");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z red rgb\nPOINTS 1\nDATA ascii\n0 0 0 1 1\n"),
                  "two fields would be named 'red'");
}

TEST(PcdErrors, AbsurdPointCountIsRejectedBeforeAllocating) {
  const std::string head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4000000000\nPOINTS 4000000000\n";
  EXPECT_CONTAINS(read_error(head + "DATA binary\n" + std::string(12, '\0')),
                  "truncated: POINTS declares 4000000000 points of 12 bytes, but only 12 bytes");
  EXPECT_CONTAINS(read_error(head + "DATA ascii\n0 0 0\n"), "truncated: POINTS declares 4000000000 points");
  EXPECT_CONTAINS(read_error(head + "DATA binary_compressed\n" + u32_bytes(4) + u32_bytes(0xffffffffu) + "\x03xyzw"),
                  "does not match POINTS × point size");
  const std::string ok = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000\nPOINTS 1000000\n";
  EXPECT_CONTAINS(read_error(ok + "DATA binary_compressed\n" + u32_bytes(4) + u32_bytes(12000000) + "\x03xyzw"),
                  "implausible binary_compressed sizes");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nWIDTH 18446744073709551615\nHEIGHT 2\nDATA binary\n"),
                  "overflows");
}

TEST(PcdErrors, TruncatedBinary) {
  point_cloud c;
  for (int i = 0; i < 100; ++i) c.push_back(float(i), 1, 2);
  const std::string bytes = write_string(c, pcd_format::binary);
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 5)),
                  "truncated: POINTS declares 100 points of 12 bytes, but only 1195 bytes of binary data follow");
}

TEST(PcdErrors, TruncatedCompressed) {
  const std::string bytes = write_string(big_cloud(1000), pcd_format::binary_compressed);
  const std::size_t body = bytes.find("DATA binary_compressed\n") + 23;
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 10)), "truncated: the binary_compressed data declares");
  EXPECT_CONTAINS(read_error(bytes.substr(0, body + 5)), "has no size header");
  // Consistent sizes but the LZF stream cut short.
  std::string cut = bytes.substr(0, bytes.size() - 10);
  std::uint32_t size = 0;
  std::memcpy(&size, cut.data() + body, 4);
  size -= 10;
  std::memcpy(cut.data() + body, &size, 4);
  EXPECT_CONTAINS(read_error(cut), "corrupt LZF data");
}

TEST(PcdErrors, BadLzfInAFile) {
  const std::string head = header(1, "binary_compressed");
  // Back-reference before the start.
  EXPECT_CONTAINS(read_error(head + u32_bytes(2) + u32_bytes(12) + std::string("\x20\x02", 2)),
                  "corrupt LZF data (a back-reference at input offset 0 points before the start");
  // Output overflow: 13 literal bytes for 12.
  EXPECT_CONTAINS(read_error(head + u32_bytes(14) + u32_bytes(12) + "\x0c" + std::string(13, 'a')),
                  "corrupt LZF data (the output would exceed the declared 12 bytes)");
  // Flipped control byte of a real stream.
  std::string bytes = write_string(big_cloud(1000), pcd_format::binary_compressed);
  const std::size_t body = bytes.find("DATA binary_compressed\n") + 23;
  bytes[body + 8] = static_cast<char>(0xff);
  EXPECT_CONTAINS(read_error(bytes), "corrupt LZF data");
}

TEST(PcdErrors, BadAscii) {
  const std::string head = header(3, "ascii", "x y z red", "4 4 4 1", "F F F U", "1 1 1 1");
  const std::size_t first_data_line = 12;  // header() writes 11 lines
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 2\n1 abc 3 4\n"),
                  "line " + std::to_string(first_data_line + 2) + ", field 'y': 'abc' is not a number");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 300\n1 1 1 1\n"),
                  "line " + std::to_string(first_data_line + 1) + ", field 'red': '300' is out of range for uint8");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1.5\n0 0 0 1\n0 0 0 1\n"), "'1.5' is not an integer");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n0.0 0.0 0.0\n0 0 0 1\n"),
                  "line " + std::to_string(first_data_line + 1) + ": expected 4 values, found 3");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 1\n" + std::string(20, '\n')),
                  "truncated: the file ends after 2 of 3 points");
  const std::string normal = header(1, "ascii", "x y z n", "4 4 4 4", "F F F F", "1 1 1 2");
  EXPECT_CONTAINS(read_error(normal + "0 0 0 1 x\n"), "field 'n_1': 'x' is not a number");
}

TEST(PcdErrors, StreamNameIsUsedInMessages) {
  try {
    ced::io::read_pcd_buffer("nope", "my_buffer");
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "my_buffer");
  }
}

// ------------------------------------------------------------- threads

namespace {
/// An ascii PCD of about 5 MB, blank lines here and there, `points` points
/// declared; `bad`: points whose intensity is not a number; `lines` lines
/// of points written (fewer than declared: truncated).
std::string big_ascii_pcd(std::size_t points, std::size_t lines, const std::vector<std::size_t>& bad = {}) {
  std::mt19937 rng(9);
  std::ostringstream s;
  s << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity n\nSIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 2\n"
    << "WIDTH " << points << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << points << "\nDATA ascii\n";
  for (std::size_t i = 0; i < lines; ++i) {
    if (i % 7001 == 0) s << "\n  \n";
    s << (rng() % 100000) * 0.001 << " " << (rng() % 100000) * 0.001 << " " << -(double(rng() % 5000) * 0.01) << " ";
    if (std::find(bad.begin(), bad.end(), i) != bad.end())
      s << "x";
    else
      s << rng() % 4096;
    s << " " << (rng() % 100) * 0.01 << " " << (rng() % 100) * 0.01 << "\n";
  }
  if (lines == points) s << "trailing text after the last point is not read\n";
  return s.str();
}

point_cloud read_pcd_on(unsigned threads, const std::string& text) {
  point_cloud c;
  ced::detail::with_thread_limit(threads, [&] { c = ced::io::read_pcd_buffer(text, "big.pcd"); });
  return c;
}

std::string pcd_error_on(unsigned threads, const std::string& text) {
  return ced_test::io_error_of([&] { read_pcd_on(threads, text); });
}
}  // namespace

TEST(PcdThreads, AsciiBlocksOfLinesOnThreadsGiveTheCloudOfOneThread) {
  const std::string text = big_ascii_pcd(150000, 150000);
  ASSERT_GT(text.size(), std::size_t(4) << 20);  // several blocks of 1 MiB
  const point_cloud want = read_pcd_on(1, text);
  ASSERT_EQ(want.size(), 150000u);
  for (unsigned threads : {2u, 3u}) {
    SCOPED_TRACE(threads);
    ced_test::expect_same_cloud(read_pcd_on(threads, text), want);
  }
}

TEST(PcdThreads, AsciiErrorsAreTheOnesOfOneThread) {
  // The first bad value in the file, with its line number, and a truncated
  // file (fewer lines than points), the same on 1, 2 and 3 threads.
  for (const std::string& text : {big_ascii_pcd(150000, 150000, {120000, 70000}), big_ascii_pcd(150000, 140000)}) {
    const std::string want = pcd_error_on(1, text);
    for (unsigned threads : {2u, 3u}) EXPECT_EQ(pcd_error_on(threads, text), want) << threads << " threads";
  }
  // Line 11 is DATA; point i is on line 12 + i plus two blank lines per 7001 points before it.
  EXPECT_NE(pcd_error_on(2, big_ascii_pcd(150000, 150000, {120000, 70000}))
                .find("line " + std::to_string(12 + 70000 + 2 * (70000 / 7001 + 1)) + ", field 'intensity'"),
            std::string::npos);
  EXPECT_NE(pcd_error_on(2, big_ascii_pcd(150000, 140000)).find("the file ends after 140000 of 150000 points"),
            std::string::npos);
}
