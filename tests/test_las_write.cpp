// SPDX-License-Identifier: MIT
// LAS written (src/io/las/write.cpp): round trips, header bytes, formats, colours,
// versions, and what cannot be written.

#include "las_test_support.hpp"

using namespace las_test;

namespace {

/// A georeferenced cloud with every standard field plus extra fields.
point_cloud georeferenced_cloud(bool rgb, bool nir, std::vector<std::array<double, 3>>& truth) {
  point_cloud c;
  const std::array<double, 3> origin{500000, 4000000, 100};
  c.set_origin(origin);
  const std::size_t n = 500;
  for (std::size_t i = 0; i < n; ++i) {
    // Millimetre-exact absolute coordinates spread over ~1 km.
    const std::array<double, 3> p{500000 + std::round(1e3 * (-400.0 + 1.731 * i)) / 1e3,
                                  4000000 + std::round(1e3 * (300.0 - 1.379 * i)) / 1e3,
                                  100 + std::round(1e3 * (0.0117 * i)) / 1e3};
    truth.push_back(p);
    c.push_back(float(p[0] - origin[0]), float(p[1] - origin[1]), float(p[2] - origin[2]));
  }
  const auto series = [&](double a, double b) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = std::fmod(a + b * double(i), 1.0);
    return v;
  };
  const auto ints = [&](double lo, double hi) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = lo + std::fmod(double(i) * 7919.0, hi - lo + 1);
    return v;
  };
  c.add_field("intensity", scalar_type::uint16, ints(0, 65535));
  c.add_field("return_number", scalar_type::uint8, ints(1, 15));
  c.add_field("number_of_returns", scalar_type::uint8, ints(1, 15));
  c.add_field("classification", scalar_type::uint8, ints(0, 255));
  c.add_field("scan_angle", scalar_type::int16, ints(-15000, 15000));
  c.add_field("user_data", scalar_type::uint8, ints(0, 255));
  c.add_field("point_source_id", scalar_type::uint16, ints(0, 65535));
  std::vector<double> gps(n);
  for (std::size_t i = 0; i < n; ++i) gps[i] = 3.5e8 + 0.000123 * double(i);
  c.add_field("gps_time", scalar_type::float64, gps);
  if (rgb) {
    c.add_field("red", scalar_type::uint16, ints(0, 65535));
    c.add_field("green", scalar_type::uint16, ints(100, 200));
    c.add_field("blue", scalar_type::uint16, ints(60000, 65535));
  }
  if (nir) c.add_field("nir", scalar_type::uint16, ints(0, 4095));
  c.add_field("withheld", scalar_type::uint8, ints(0, 1));
  c.add_field("scanner_channel", scalar_type::uint8, ints(0, 3));
  // Extra bytes, one of each type.
  c.add_field("e_i8", scalar_type::int8, ints(-128, 127));
  c.add_field("e_u8", scalar_type::uint8, ints(0, 255));
  c.add_field("e_i16", scalar_type::int16, ints(-32768, 32767));
  c.add_field("e_u16", scalar_type::uint16, ints(0, 65535));
  c.add_field("e_i32", scalar_type::int32, ints(-2147483648.0, 2147483647.0));
  c.add_field("e_u32", scalar_type::uint32, ints(0, 4294967295.0));
  c.add_field("e_i64", scalar_type::int64, ints(-1e15, 1e15));
  c.add_field("e_u64", scalar_type::uint64, ints(0, 1e15));
  std::vector<double> f32 = series(0.1, 0.37);
  for (double& v : f32) v = double(float(v));
  c.add_field("curvature", scalar_type::float32, f32);
  c.add_field("distance_to_something_long_name", scalar_type::float64, series(0.3, 0.123456789));
  return c;
}

void expect_same_fields(const point_cloud& written, const point_cloud& read) {
  for (const auto& f : written.fields()) {
    const ced::field* g = read.find_field(f.name);
    ASSERT_NE(g, nullptr) << f.name;
    EXPECT_EQ(g->values, f.values) << f.name;
  }
}

}  // namespace

class LasRoundTrip : public ::testing::TestWithParam<int> {};

TEST_P(LasRoundTrip, EveryFieldAndMillimetres) {
  const int format = GetParam();
  std::vector<std::array<double, 3>> truth;
  const point_cloud c = georeferenced_cloud(format >= 7, format == 8, truth);
  const std::string path = temp_file("roundtrip_" + std::to_string(format) + ".las");
  ced::io::write_las(path, c);
  las_read_info info;
  const point_cloud r = ced::io::read_las(path, &info);
  EXPECT_EQ(ced::io::read_las_buffer(read_bytes(path), path).size(), r.size());
  EXPECT_EQ(info.version_minor, 4);
  EXPECT_EQ(info.point_format, format);
  EXPECT_EQ(info.points, c.size());
  EXPECT_EQ(info.offset, c.origin());
  EXPECT_EQ(info.scale, (std::array<double, 3>{0.001, 0.001, 0.001}));
  EXPECT_CONTAINS(info.generating_software, "ced");
  ASSERT_EQ(r.size(), c.size());
  double worst = 0;
  for (std::size_t i = 0; i < r.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::fabs(absolute(r, i, k) - truth[i][k]));
  EXPECT_LT(worst, 1e-3);
  expect_same_fields(c, r);
  // Standard fields come back with their LAS types, extra bytes with their own.
  EXPECT_EQ(r.get_field("intensity").type(), scalar_type::uint16);
  EXPECT_EQ(r.get_field("scan_angle").type(), scalar_type::int16);
  for (const auto& f : c.fields()) {
    if (f.name.rfind("e_", 0) == 0 || f.name == "curvature") {
      EXPECT_EQ(r.get_field(f.name).type(), f.type()) << f.name;
    }
  }
  EXPECT_EQ(r.get_field("distance_to_something_long_name").type(), scalar_type::float64);
}

INSTANTIATE_TEST_SUITE_P(Formats678, LasRoundTrip, ::testing::Values(6, 7, 8),
                         [](const auto& p) { return "format" + std::to_string(p.param); });

TEST(LasWrite, HeaderBytes) {
  std::vector<std::array<double, 3>> truth;
  const point_cloud c = georeferenced_cloud(true, false, truth);
  std::ostringstream s(std::ios::binary);
  ced::io::write_las(s, c, las_write_options{{0.01, 0.01, 0.001}, 4});
  const std::string b = s.str();
  EXPECT_EQ(b.substr(0, 4), "LASF");
  EXPECT_EQ(peek<std::uint16_t>(b, 6) & 0x10, 0x10);  // WKT bit, required for formats 6-10
  EXPECT_EQ(b[24], 1);
  EXPECT_EQ(b[25], 4);
  EXPECT_EQ(peek<std::uint16_t>(b, 94), 375);
  EXPECT_EQ(peek<std::uint32_t>(b, 100), 1u);  // the extra-bytes VLR
  EXPECT_EQ(b[104], 7);
  const std::size_t n_extra = 10, extra_size = 1 + 1 + 2 + 2 + 4 + 4 + 8 + 8 + 4 + 8;
  EXPECT_EQ(peek<std::uint32_t>(b, 96), 375 + 54 + 192 * n_extra);
  EXPECT_EQ(peek<std::uint16_t>(b, 105), 36 + extra_size);
  EXPECT_EQ(peek<std::uint32_t>(b, 107), 0u);  // legacy count: 0 for formats 6-10
  EXPECT_EQ(peek<std::uint64_t>(b, 247), c.size());
  EXPECT_EQ(peek<double>(b, 131), 0.01);
  EXPECT_EQ(peek<double>(b, 147), 0.001);
  EXPECT_EQ(peek<double>(b, 155), 500000.0);
  EXPECT_EQ(peek<double>(b, 163), 4000000.0);
  EXPECT_EQ(peek<double>(b, 171), 100.0);
  // min/max x, y, z enclose the data.
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const auto& p : truth)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p[k]), hi[k] = std::max(hi[k], p[k]);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(peek<double>(b, 179 + 16 * k), hi[k], 0.006) << k;
    EXPECT_NEAR(peek<double>(b, 187 + 16 * k), lo[k], 0.006) << k;
  }
  // Points by return.
  std::uint64_t total = 0;
  for (int r = 0; r < 15; ++r) total += peek<std::uint64_t>(b, 255 + 8 * r);
  EXPECT_EQ(total, c.size());
  // The first extra-bytes descriptor.
  const std::size_t d = 375 + 54;
  EXPECT_EQ(b.substr(375 + 2, 9), "LASF_Spec");
  EXPECT_EQ(peek<std::uint16_t>(b, 375 + 18), 4);
  EXPECT_EQ(b[d + 2], 2);  // int8
  EXPECT_EQ(std::string(b.c_str() + d + 4), "e_i8");
  EXPECT_EQ(b.size(), 375 + 54 + 192 * n_extra + c.size() * (36 + extra_size));
}

TEST(LasWrite, SmallestFormatAndColourValuesAsTheyAre) {
  point_cloud c;
  c.push_back(1, 2, 3);
  c.push_back(-1, 0.5f, 0);
  las_read_info info;
  std::stringstream s;
  ced::io::write_las(s, c);
  point_cloud r = ced::io::read_las_buffer(s.str(), "mem.las", &info);
  EXPECT_EQ(info.point_format, 6);
  EXPECT_EQ(values(r, "return_number"), (std::vector<double>{1, 1}));  // missing returns: 1 of 1
  EXPECT_EQ(values(r, "number_of_returns"), (std::vector<double>{1, 1}));
  EXPECT_EQ(r.origin(), (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(r.position(1)[1], 0.5f);

  c.add_rgb({{255, 0, 128}, {1, 2, 3}});  // uint8 colour: written as is, not scaled to 16 bits
  s.str("");
  ced::io::write_las(s, c);
  r = ced::io::read_las_buffer(s.str(), "mem.las", &info);
  EXPECT_EQ(info.point_format, 7);
  EXPECT_EQ(values(r, "red"), (std::vector<double>{255, 1}));
  EXPECT_EQ(values(r, "blue"), (std::vector<double>{128, 3}));
  EXPECT_EQ(r.get_field("red").type(), scalar_type::uint16);

  c.add_field("NIR", scalar_type::uint8, {9, 10});  // any case; 8 bits become 16 (bands reads v / 255 back)
  s.str("");
  ced::io::write_las(s, c);
  r = ced::io::read_las_buffer(s.str(), "mem.las", &info);
  EXPECT_EQ(info.point_format, 8);
  EXPECT_EQ(values(r, "nir"), (std::vector<double>{9 * 257, 10 * 257}));
  EXPECT_EQ(r.find_field("NIR"), nullptr);

  // nir without colour: format 6 with nir as extra bytes.
  point_cloud d;
  d.push_back(0, 0, 0);
  d.add_field("nir", scalar_type::uint16, {300});
  s.str("");
  ced::io::write_las(s, d);
  r = ced::io::read_las_buffer(s.str(), "mem.las", &info);
  EXPECT_EQ(info.point_format, 6);
  EXPECT_EQ(values(r, "nir"), (std::vector<double>{300}));
}

TEST(LasWrite, FloatColoursAreFractionsAndSixteenBitSlotsAreNeverClamped) {
  point_cloud c;
  for (int i = 0; i < 3; ++i) c.push_back(0, 0, 0);
  c.add_field("red", scalar_type::float32, {0, 0.5, 1});  // Open3D's colours: fractions of the full scale
  c.add_field("green", scalar_type::float64, {1, 0.25, 0});
  c.add_field("blue", scalar_type::float32, {0.2, 0, 1});
  c.add_field("nir", scalar_type::float32, {0.75, 1, 0});
  c.add_field("intensity", scalar_type::float32, {0, 12.4, 65535});
  std::stringstream s;
  ced::io::write_las(s, c);
  const point_cloud r = ced::io::read_las_buffer(s.str(), "mem.las");
  EXPECT_EQ(values(r, "red"), (std::vector<double>{0, 32768, 65535}));
  EXPECT_EQ(values(r, "green"), (std::vector<double>{65535, 16384, 0}));
  EXPECT_EQ(values(r, "blue"), (std::vector<double>{13107, 0, 65535}));
  EXPECT_EQ(values(r, "nir"), (std::vector<double>{49151, 65535, 0}));
  EXPECT_EQ(values(r, "intensity"), (std::vector<double>{0, 12, 65535}));  // rounded, not scaled

  const auto refused = [](const char* name, scalar_type type, std::vector<double> v, const std::string& what) {
    point_cloud d;
    for (int i = 0; i < 3; ++i) d.push_back(0, 0, 0);
    for (const char* colour : {"red", "green", "blue"})
      if (std::string(colour) != name) d.add_field(colour, scalar_type::float32, {0, 0.5, 1});
    d.add_field(name, type, std::move(v));
    std::stringstream t;
    try {
      ced::io::write_las(t, d);
      ADD_FAILURE() << name << ": written";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  refused("green", scalar_type::float32, {0, 1.5, 1}, "field 'green' cannot be written as LAS green: point 1 has 1.5");
  refused("nir", scalar_type::float64, {-0.25, 0, 1}, "point 0 has -0.25 (a float nir must be a fraction in [0, 1]");
  refused("intensity", scalar_type::float32, {-5, 0, 0}, "point 0 has -5 (LAS stores it as an integer in 0 .. 65535)");
  refused("intensity", scalar_type::int32, {0, 70000, 0}, "point 1 has 70000");
  refused("intensity", scalar_type::float32, {0, 0, std::nan("")}, "point 2 has nan");
}

TEST(LasWrite, StandardNamesWithOtherTypesAreConvertedAndClamped) {
  point_cloud c;
  for (int i = 0; i < 4; ++i) c.push_back(0, 0, 0);
  c.add_field("Intensity", scalar_type::float32, {0, 12.6, 65535, 7});
  c.add_field("classification", scalar_type::int32, {-1, 2, 300, 7});
  c.add_field("return_number", scalar_type::float64, {0, 3, 99, 2});
  c.add_field("synthetic", scalar_type::float32, {0, 0.5, -1, std::nan("")});
  c.add_field("scan_angle", scalar_type::int8, {-90, 0, 45, 90});  // int8: whole degrees
  std::stringstream s;
  ced::io::write_las(s, c);
  const point_cloud r = ced::io::read_las_buffer(s.str(), "mem.las");
  EXPECT_EQ(values(r, "intensity"), (std::vector<double>{0, 13, 65535, 7}));
  EXPECT_EQ(values(r, "classification"), (std::vector<double>{0, 2, 255, 7}));
  EXPECT_EQ(values(r, "return_number"), (std::vector<double>{0, 3, 15, 2}));
  EXPECT_EQ(values(r, "synthetic"), (std::vector<double>{0, 1, 1, 0}));
  EXPECT_EQ(values(r, "scan_angle"), (std::vector<double>{-15000, 0, 7500, 15000}));  // 0.006-degree units
  EXPECT_EQ(r.find_field("Intensity"), nullptr);
}

TEST(LasWrite, LegacyVersions) {
  std::vector<std::array<double, 3>> truth;
  point_cloud c = georeferenced_cloud(true, true, truth);
  for (int minor : {2, 3}) {
    std::stringstream s;
    ced::io::write_las(s, c, las_write_options{{0.001, 0.001, 0.001}, minor});
    las_read_info info;
    const point_cloud r = ced::io::read_las_buffer(s.str(), "mem.las", &info);
    EXPECT_EQ(info.version_minor, minor);
    EXPECT_EQ(info.point_format, 3);  // gps_time and colour
    EXPECT_EQ(peek<std::uint16_t>(s.str(), 94), minor == 3 ? 235 : 227);
    EXPECT_EQ(peek<std::uint32_t>(s.str(), 107), c.size());
    ASSERT_EQ(r.size(), c.size());
    for (std::size_t i = 0; i < r.size(); ++i) {
      for (std::size_t k = 0; k < 3; ++k) ASSERT_NEAR(absolute(r, i, k), truth[i][k], 1e-3);
      EXPECT_EQ(values(r, "return_number")[i], std::min(7.0, values(c, "return_number")[i]));
      EXPECT_EQ(values(r, "classification")[i], std::min(31.0, values(c, "classification")[i]));
      // int16 scan angle in 0.006-degree units -> whole degrees, clamped to int8.
      const double degrees = std::round(values(c, "scan_angle")[i] * 0.006);
      EXPECT_EQ(values(r, "scan_angle")[i], std::clamp(degrees, -128.0, 127.0));
      EXPECT_EQ(values(r, "red")[i], values(c, "red")[i]);
      EXPECT_EQ(values(r, "gps_time")[i], values(c, "gps_time")[i]);
    }
    // No nir slot or scanner channel in formats 0-5: extra bytes.
    EXPECT_EQ(values(r, "nir"), values(c, "nir"));
    EXPECT_EQ(values(r, "scanner_channel"), values(c, "scanner_channel"));
    EXPECT_EQ(values(r, "withheld"), values(c, "withheld"));
    EXPECT_EQ(values(r, "e_i64"), values(c, "e_i64"));
  }
  point_cloud plain;
  plain.push_back(1, 2, 3);
  std::stringstream s;
  ced::io::write_las(s, plain, las_write_options{{0.01, 0.01, 0.01}, 2});
  las_read_info info;
  ced::io::read_las_buffer(s.str(), "mem.las", &info);
  EXPECT_EQ(info.point_format, 0);
  plain.add_field("gps_time", scalar_type::float64, {5});
  s.str("");
  ced::io::write_las(s, plain, las_write_options{{0.01, 0.01, 0.01}, 2});
  ced::io::read_las_buffer(s.str(), "mem.las", &info);
  EXPECT_EQ(info.point_format, 1);
}

TEST(LasWrite, EmptyCloud) {
  std::stringstream s;
  ced::io::write_las(s, point_cloud{});
  las_read_info info;
  EXPECT_TRUE(ced::io::read_las_buffer(s.str(), "mem.las", &info).empty());
  EXPECT_EQ(info.points, 0u);
  EXPECT_EQ(s.str().size(), 375u);
}

TEST(LasWrite, WhatCannotBeWritten) {
  point_cloud c;
  c.push_back(0, 0, 0);
  std::stringstream s;
  EXPECT_THROW(ced::io::write_las(s, c, las_write_options{{0.01, 0.01, 0.01}, 1}), std::invalid_argument);
  EXPECT_THROW(ced::io::write_las(s, c, las_write_options{{0.01, 0, 0.01}, 4}), std::invalid_argument);

  point_cloud long_name = c;
  long_name.add_field(std::string(33, 'a'), scalar_type::uint8, {1});
  EXPECT_THROW(ced::io::write_las(s, long_name), std::invalid_argument);
  point_cloud x_field = c;
  x_field.add_field("X", scalar_type::float32, {1});
  EXPECT_THROW(ced::io::write_las(s, x_field), std::invalid_argument);

  point_cloud nan_point = c;
  nan_point.push_back(std::nanf(""), 0, 0);
  try {
    ced::io::write_las(s, nan_point);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_CONTAINS(e.what(), "point 1 has a non-finite coordinate");
  }
  point_cloud far = c;
  far.push_back(3e6f, 0, 0);  // 3e9 mm: beyond int32
  try {
    ced::io::write_las(s, far);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_CONTAINS(e.what(), "does not fit a 32-bit LAS integer");
  }
  EXPECT_NO_THROW(ced::io::write_las(s, far, las_write_options{{0.01, 0.01, 0.01}, 4}));

  // A failed write to a path leaves nothing behind.
  const std::string path = temp_file("failed.las");
  EXPECT_THROW(ced::io::write_las(path, nan_point), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
  for (const auto& e : fs::directory_iterator(temp_dir()))
    EXPECT_EQ(e.path().filename().string().find(".failed.las.tmp"), std::string::npos);
}

TEST(LasWrite, ReadThenWriteIsLossless) {
  // A file with flags and extra bytes, read, written, read again.
  las_file file;
  file.minor = 4;
  file.format = 8;
  file.scale = {0.001, 0.001, 0.01};
  file.offset = {631000, 4833000, 0};
  file.vlrs.push_back(vlr("LASF_Spec", 4, descriptor(4, 8, "height", {0.01, 1, 1}) + descriptor(9, 0, "f")));
  file.points = sample_points(8);
  for (auto& p : file.points) {
    p.z = std::clamp(p.z, -100000, 100000);
    p.x = std::clamp(p.x, -1000000, 1000000);
    p.extra.clear();
    put(p.extra, std::int16_t{-1234});
    put(p.extra, 0.125f);
  }
  file.points[1].withheld = true;
  file.points[2].overlap = true;
  const point_cloud a = ced::io::read_las_buffer(file.build(), "mem.las");
  std::stringstream s;
  ced::io::write_las(s, a, las_write_options{file.scale, 4});
  const point_cloud b = ced::io::read_las_buffer(s.str(), "mem.las");
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(absolute(b, i, k), absolute(a, i, k), 1e-6);
  ASSERT_EQ(b.fields().size(), a.fields().size());
  for (std::size_t j = 0; j < a.fields().size(); ++j) {
    EXPECT_EQ(b.fields()[j].name, a.fields()[j].name);
    EXPECT_EQ(b.fields()[j].type(), a.fields()[j].type()) << a.fields()[j].name;
    EXPECT_EQ(b.fields()[j].values, a.fields()[j].values) << a.fields()[j].name;
  }
}

// ------------------------------- LAS -> LAS gives back what it read (#57 item 8)
