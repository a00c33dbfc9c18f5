// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "ced/io/io.hpp"
#include "ced/io/las.hpp"
#include "ced/io/stream.hpp"
#include "file_support.hpp"
#include "io/laz/types.hpp"

namespace fs = std::filesystem;
using ced::point_cloud;
using ced::scalar_type;
using ced::io::io_error;
using ced::io::las_read_info;
using ced::io::las_write_options;

using ced_test::read_bytes;
using ced_test::temp_dir;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace {

// ------------------------------------------------- a LAS builder for the tests
// Independent of ced's writer: every byte is placed here, following the LAS 1.4
// R15 specification. The tests run on little-endian hosts.

template <class T>
void put(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  s.append(b, sizeof(T));
}

template <class T>
void poke(std::string& s, std::size_t offset, T v) {
  std::memcpy(&s[offset], &v, sizeof(T));
}

template <class T>
T peek(const std::string& s, std::size_t offset) {
  T v;
  std::memcpy(&v, &s[offset], sizeof(T));
  return v;
}

void put_chars(std::string& s, const std::string& text, std::size_t width) {
  std::string t = text.substr(0, width);
  t.resize(width, '\0');
  s += t;
}

const std::size_t k_min_size[11] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

/// One point with every standard LAS attribute.
struct las_point {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint16_t intensity = 0;
  int return_number = 1, number_of_returns = 1;
  int classification = 0;
  bool synthetic = false, key_point = false, withheld = false, overlap = false;
  int scanner_channel = 0;
  bool scan_direction = false, edge = false;
  int scan_angle = 0;  // degrees (0-5) or 0.006-degree units (6-10)
  std::uint8_t user_data = 0;
  std::uint16_t point_source_id = 0;
  double gps_time = 0;
  std::uint16_t red = 0, green = 0, blue = 0, nir = 0;
  std::string extra;  // bytes appended after the standard fields
};

bool has_gps(int f) { return f != 0 && f != 2; }
bool has_rgb(int f) { return f == 2 || f == 3 || f == 5 || f == 7 || f == 8 || f == 10; }
bool has_nir(int f) { return f == 8 || f == 10; }
bool has_wave(int f) { return f == 4 || f == 5 || f == 9 || f == 10; }

/// The record bytes of `p` in point format `f`, padded to `record_length`.
std::string record(int f, const las_point& p, std::size_t record_length) {
  std::string r;
  put(r, p.x);
  put(r, p.y);
  put(r, p.z);
  put(r, p.intensity);
  if (f < 6) {
    put(r, static_cast<std::uint8_t>(p.return_number | p.number_of_returns << 3 | p.scan_direction << 6 | p.edge << 7));
    put(r, static_cast<std::uint8_t>(p.classification | p.synthetic << 5 | p.key_point << 6 | p.withheld << 7));
    put(r, static_cast<std::int8_t>(p.scan_angle));
    put(r, p.user_data);
    put(r, p.point_source_id);
    if (has_gps(f)) put(r, p.gps_time);
    if (has_rgb(f)) {
      put(r, p.red);
      put(r, p.green);
      put(r, p.blue);
    }
  } else {
    put(r, static_cast<std::uint8_t>(p.return_number | p.number_of_returns << 4));
    put(r, static_cast<std::uint8_t>(p.synthetic | p.key_point << 1 | p.withheld << 2 | p.overlap << 3 |
                                     p.scanner_channel << 4 | p.scan_direction << 6 | p.edge << 7));
    put(r, static_cast<std::uint8_t>(p.classification));
    put(r, p.user_data);
    put(r, static_cast<std::int16_t>(p.scan_angle));
    put(r, p.point_source_id);
    put(r, p.gps_time);
    if (has_rgb(f)) {
      put(r, p.red);
      put(r, p.green);
      put(r, p.blue);
    }
    if (has_nir(f)) put(r, p.nir);
  }
  if (has_wave(f)) {  // wave packet: descriptor index, offset, size, location, x(t), y(t), z(t)
    put(r, std::uint8_t{7});
    put(r, std::uint64_t{123456789});
    put(r, std::uint32_t{512});
    put(r, 1.5f);
    put(r, 0.25f);
    put(r, -0.5f);
    put(r, 0.75f);
  }
  EXPECT_EQ(r.size(), k_min_size[f]) << "format " << f;
  r += p.extra;
  r.resize(std::max(r.size(), record_length), '\0');
  return r;
}

/// One extra-bytes descriptor (192 bytes).
std::string descriptor(int data_type, int options, const std::string& name, std::array<double, 3> scale = {1, 1, 1},
                       std::array<double, 3> offset = {0, 0, 0}) {
  std::string d;
  put(d, std::uint16_t{0});
  put(d, static_cast<std::uint8_t>(data_type));
  put(d, static_cast<std::uint8_t>(options));
  put_chars(d, name, 32);
  d.append(4, '\0');       // unused
  d.append(3 * 24, '\0');  // no_data, min, max
  for (double s : scale) put(d, s);
  for (double o : offset) put(d, o);
  put_chars(d, "test field", 32);
  EXPECT_EQ(d.size(), 192u);
  return d;
}

std::string vlr(const std::string& user_id, std::uint16_t record_id, const std::string& payload) {
  std::string v;
  put(v, std::uint16_t{0});
  put_chars(v, user_id, 16);
  put(v, record_id);
  put(v, static_cast<std::uint16_t>(payload.size()));
  put_chars(v, "description", 32);
  return v + payload;
}

/// A whole LAS file.
struct las_file {
  int minor = 2;
  int format = 0;
  std::size_t record_length = 0;  ///< 0: the format's size plus the extra bytes of the first point
  std::array<double, 3> scale{0.01, 0.01, 0.01}, offset{0, 0, 0};
  std::vector<std::string> vlrs;
  std::vector<las_point> points;
  std::int64_t declared = -1;  ///< point count in the header; -1: points.size()
  bool legacy_count_in_14 = false;

  std::size_t header_size() const { return minor >= 4 ? 375 : minor == 3 ? 235 : 227; }

  std::string build() const {
    const std::size_t rl =
        record_length ? record_length : k_min_size[format] + (points.empty() ? 0 : points[0].extra.size());
    const std::uint64_t n = declared >= 0 ? static_cast<std::uint64_t>(declared) : points.size();
    std::string vlr_bytes;
    for (const auto& v : vlrs) vlr_bytes += v;
    std::string h;
    h += "LASF";
    put(h, std::uint16_t{0});                       // file source id
    put(h, std::uint16_t(format >= 6 ? 0x10 : 0));  // global encoding
    h.append(16, '\0');                             // GUID
    put(h, std::uint8_t{1});
    put(h, static_cast<std::uint8_t>(minor));
    put_chars(h, "TEST SYSTEM", 32);
    put_chars(h, "ced test builder", 32);
    put(h, std::uint16_t{100});
    put(h, std::uint16_t{2024});
    put(h, static_cast<std::uint16_t>(header_size()));
    put(h, static_cast<std::uint32_t>(header_size() + vlr_bytes.size()));
    put(h, static_cast<std::uint32_t>(vlrs.size()));
    put(h, static_cast<std::uint8_t>(format));
    put(h, static_cast<std::uint16_t>(rl));
    const bool legacy = minor < 4 || legacy_count_in_14;
    put(h, static_cast<std::uint32_t>(legacy ? n : 0));
    for (int r = 0; r < 5; ++r) put(h, std::uint32_t{0});
    for (double s : scale) put(h, s);
    for (double o : offset) put(h, o);
    for (int k = 0; k < 6; ++k) put(h, 0.0);   // max/min: not used by the reader
    if (minor >= 3) put(h, std::uint64_t{0});  // start of waveform data
    if (minor >= 4) {
      put(h, std::uint64_t{0});  // start of first EVLR
      put(h, std::uint32_t{0});
      put(h, static_cast<std::uint64_t>(n));
      for (int r = 0; r < 15; ++r) put(h, std::uint64_t{0});
    }
    EXPECT_EQ(h.size(), header_size());
    std::string body;
    for (const auto& p : points) body += record(format, p, rl);
    return h + vlr_bytes + body;
  }
};

/// Three points exercising every attribute within its range for format `f`.
std::vector<las_point> sample_points(int f) {
  const bool ext = f >= 6;
  std::vector<las_point> v(3);
  v[0].x = 100;
  v[0].y = 200;
  v[0].z = 300;
  v[0].intensity = 0;
  v[0].return_number = 1;
  v[0].number_of_returns = 1;
  v[0].classification = 2;
  v[0].scan_angle = ext ? -15000 : -90;
  v[0].gps_time = 123456.789;

  v[1].x = -12345;
  v[1].y = 0;
  v[1].z = 2147483647;
  v[1].intensity = 65535;
  v[1].return_number = ext ? 15 : 7;
  v[1].number_of_returns = ext ? 15 : 7;
  v[1].classification = ext ? 255 : 31;
  v[1].scan_angle = ext ? 15000 : 90;
  v[1].user_data = 255;
  v[1].point_source_id = 65535;
  v[1].gps_time = -1.5;
  v[1].red = 65535;
  v[1].green = 1;
  v[1].blue = 256;
  v[1].nir = 40000;

  v[2].x = -2147483647 - 1;
  v[2].y = 7;
  v[2].z = -1;
  v[2].intensity = 1234;
  v[2].return_number = 2;
  v[2].number_of_returns = 3;
  v[2].classification = 9;
  v[2].scan_angle = 0;
  v[2].user_data = 17;
  v[2].point_source_id = 4242;
  v[2].gps_time = 3e9;
  v[2].red = 255;
  v[2].green = 128;
  v[2].blue = 0;
  v[2].nir = 7;
  return v;
}

std::string read_error(const std::string& bytes, const std::string& name = "bad.las") {
  return ced_test::read_error_of([](const std::string& path) { ced::io::read_las(path); }, bytes, name);
}

const ced::column& values(const point_cloud& c, const std::string& name) { return c.get_field(name).values; }

double absolute(const point_cloud& c, std::size_t i, std::size_t k) { return c.origin()[k] + c.position(i)[k]; }

}  // namespace

// ------------------------------------------------------------------ reading

class LasFormat : public ::testing::TestWithParam<int> {};

TEST_P(LasFormat, EveryFieldIsRead) {
  const int f = GetParam();
  las_file file;
  file.format = f;
  file.minor = f >= 6 ? 4 : 2;
  file.scale = {0.01, 0.001, 0.5};
  file.offset = {10, -20, 0.25};
  file.points = sample_points(f);
  las_read_info info;
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las", &info);

  EXPECT_EQ(info.version_major, 1);
  EXPECT_EQ(info.version_minor, file.minor);
  EXPECT_EQ(info.point_format, f);
  EXPECT_EQ(info.points, 3u);
  EXPECT_EQ(info.scale, file.scale);
  EXPECT_EQ(info.offset, file.offset);
  EXPECT_EQ(info.system_identifier, "TEST SYSTEM");
  EXPECT_EQ(info.generating_software, "ced test builder");

  ASSERT_EQ(c.size(), 3u);
  // Coordinates reach beyond 1e4: relative to an integer origin.
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(c.origin()[k], std::round(c.origin()[k]));
  for (std::size_t i = 0; i < 3; ++i) {
    const las_point& p = file.points[i];
    const std::int32_t raw[3] = {p.x, p.y, p.z};
    for (std::size_t k = 0; k < 3; ++k) {
      // Float positions: exact to float precision relative to the origin.
      const double expected = raw[k] * file.scale[k] + file.offset[k];
      const double tolerance = 1e-7 * std::max(1.0, std::fabs(expected - c.origin()[k]));
      EXPECT_NEAR(absolute(c, i, k), expected, tolerance) << i << "," << k;
    }
  }

  std::vector<std::string> expected_names = {"intensity",  "return_number", "number_of_returns", "classification",
                                             "scan_angle", "user_data",     "point_source_id"};
  if (has_gps(f)) expected_names.push_back("gps_time");
  if (has_rgb(f)) expected_names.insert(expected_names.end(), {"red", "green", "blue"});
  if (has_nir(f)) expected_names.push_back("nir");
  std::vector<std::string> names;
  for (const auto& fld : c.fields()) names.push_back(fld.name);
  EXPECT_EQ(names, expected_names);

  EXPECT_EQ(c.get_field("intensity").type(), scalar_type::uint16);
  EXPECT_EQ(c.get_field("return_number").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("number_of_returns").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("classification").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("scan_angle").type(), f >= 6 ? scalar_type::int16 : scalar_type::int8);
  EXPECT_EQ(c.get_field("user_data").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("point_source_id").type(), scalar_type::uint16);
  if (has_gps(f)) {
    EXPECT_EQ(c.get_field("gps_time").type(), scalar_type::float64);
  }
  if (has_rgb(f)) {
    for (const char* n : {"red", "green", "blue"}) EXPECT_EQ(c.get_field(n).type(), scalar_type::uint16);
  }
  if (has_nir(f)) {
    EXPECT_EQ(c.get_field("nir").type(), scalar_type::uint16);
  }

  for (std::size_t i = 0; i < 3; ++i) {
    const las_point& p = file.points[i];
    EXPECT_EQ(values(c, "intensity")[i], p.intensity);
    EXPECT_EQ(values(c, "return_number")[i], p.return_number);
    EXPECT_EQ(values(c, "number_of_returns")[i], p.number_of_returns);
    EXPECT_EQ(values(c, "classification")[i], p.classification);
    EXPECT_EQ(values(c, "scan_angle")[i], p.scan_angle);
    EXPECT_EQ(values(c, "user_data")[i], p.user_data);
    EXPECT_EQ(values(c, "point_source_id")[i], p.point_source_id);
    if (has_gps(f)) {
      EXPECT_EQ(values(c, "gps_time")[i], p.gps_time);
    }
    if (has_rgb(f)) {
      EXPECT_EQ(values(c, "red")[i], p.red);
      EXPECT_EQ(values(c, "green")[i], p.green);
      EXPECT_EQ(values(c, "blue")[i], p.blue);
    }
    if (has_nir(f)) {
      EXPECT_EQ(values(c, "nir")[i], p.nir);
    }
  }
}

TEST_P(LasFormat, FlagsBecomeFieldsWhenSet) {
  const int f = GetParam();
  las_file file;
  file.format = f;
  file.minor = f >= 6 ? 4 : 3;
  file.points = sample_points(f);
  file.points[0].synthetic = true;
  file.points[1].key_point = true;
  file.points[2].withheld = true;
  file.points[2].scan_direction = true;
  file.points[1].edge = true;
  if (f >= 6) {
    file.points[0].overlap = true;
    file.points[2].scanner_channel = 3;
  }
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  EXPECT_EQ(values(c, "synthetic"), (std::vector<double>{1, 0, 0}));
  EXPECT_EQ(values(c, "key_point"), (std::vector<double>{0, 1, 0}));
  EXPECT_EQ(values(c, "withheld"), (std::vector<double>{0, 0, 1}));
  EXPECT_EQ(values(c, "scan_direction_flag"), (std::vector<double>{0, 0, 1}));
  EXPECT_EQ(values(c, "edge_of_flight_line"), (std::vector<double>{0, 1, 0}));
  if (f >= 6) {
    EXPECT_EQ(values(c, "overlap"), (std::vector<double>{1, 0, 0}));
    EXPECT_EQ(values(c, "scanner_channel"), (std::vector<double>{0, 0, 3}));
  } else {
    EXPECT_EQ(c.find_field("overlap"), nullptr);
  }
  // The flags do not leak into the fields next to them.
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(values(c, "classification")[i], file.points[i].classification);
    EXPECT_EQ(values(c, "return_number")[i], file.points[i].return_number);
    EXPECT_EQ(values(c, "number_of_returns")[i], file.points[i].number_of_returns);
  }
  EXPECT_EQ(c.get_field("withheld").type(), scalar_type::uint8);

  // Without any flag set, no flag fields.
  file.points = sample_points(f);
  const point_cloud plain = ced::io::read_las_buffer(file.build(), "mem.las");
  for (const char* n : {"synthetic", "key_point", "withheld", "overlap", "scanner_channel", "scan_direction_flag",
                        "edge_of_flight_line"})
    EXPECT_EQ(plain.find_field(n), nullptr) << n;
}

INSTANTIATE_TEST_SUITE_P(AllFormats, LasFormat, ::testing::Range(0, 11),
                         [](const auto& p) { return "format" + std::to_string(p.param); });

TEST(LasRead, LegacyVersions) {
  for (int minor : {0, 1, 2, 3, 4}) {
    las_file file;
    file.minor = minor;
    file.format = 1;
    file.points = sample_points(1);
    las_read_info info;
    const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las", &info);
    EXPECT_EQ(info.version_minor, minor);
    EXPECT_EQ(c.size(), 3u);
    EXPECT_EQ(values(c, "gps_time")[1], -1.5);
  }
}

TEST(LasRead, Las14PointCounts) {
  las_file file;
  file.minor = 4;
  file.format = 6;
  file.points = sample_points(6);
  file.legacy_count_in_14 = false;  // legacy count 0, the 64-bit count holds it
  las_read_info info;
  EXPECT_EQ(ced::io::read_las_buffer(file.build(), "mem.las", &info).size(), 3u);
  EXPECT_EQ(info.points, 3u);

  // A legacy format in a 1.4 file with only the legacy count set.
  file.format = 3;
  file.points = sample_points(3);
  file.legacy_count_in_14 = true;
  std::string bytes = file.build();
  poke<std::uint64_t>(bytes, 247, 0);
  EXPECT_EQ(ced::io::read_las_buffer(bytes, "mem.las").size(), 3u);
}

TEST(LasRead, EmptyFile) {
  las_file file;
  file.format = 3;
  las_read_info info;
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las", &info);
  EXPECT_TRUE(c.empty());
  EXPECT_EQ(info.points, 0u);
  EXPECT_NE(c.find_field("red"), nullptr);
}

TEST(LasRead, SmallCoordinatesKeepAZeroOrigin) {
  las_file file;
  file.format = 0;
  file.scale = {0.001, 0.001, 0.001};
  file.points.resize(2);
  file.points[0].x = 1500;  // 1.5 m
  file.points[1].y = -250;
  file.points[1].z = 9999999;  // 9999.999 m
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  EXPECT_EQ(c.origin(), (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(c.position(0)[0], 1.5f);
  EXPECT_EQ(c.position(1)[1], -0.25f);
  EXPECT_EQ(c.position(1)[2], 9999.999f);
}

TEST(LasRead, GeoreferencedCoordinatesKeepMillimetres) {
  las_file file;
  file.minor = 4;
  file.format = 6;
  file.scale = {0.001, 0.001, 0.001};
  file.offset = {500000, 4000000, 0};
  std::vector<std::array<double, 3>> truth;
  for (int i = 0; i < 2000; ++i) {
    las_point p;
    p.x = -700000 + 811 * i;  // ~1.6 km along x, around 500000
    p.y = 3000000 - 977 * i;  // ~2 km along y, around 4000000
    p.z = 100000 + 13 * i;    // 100 m + ...
    truth.push_back({p.x * 0.001 + 500000, p.y * 0.001 + 4000000, p.z * 0.001});
    file.points.push_back(p);
  }
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  ASSERT_EQ(c.size(), truth.size());
  EXPECT_NE(c.origin()[0], 0.0);
  EXPECT_NE(c.origin()[1], 0.0);
  double worst = 0;
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::fabs(absolute(c, i, k) - truth[i][k]));
  EXPECT_LT(worst, 1e-3);
}

TEST(LasRead, ExtraBytesOfSeveralTypes) {
  las_file file;
  file.minor = 4;
  file.format = 7;
  std::string eb;
  eb += descriptor(1, 0, "u8");
  eb += descriptor(2, 0, "i8");
  eb += descriptor(3, 0, "u16");
  eb += descriptor(4, 0, "i16");
  eb += descriptor(5, 0, "u32");
  eb += descriptor(6, 0, "i32");
  eb += descriptor(7, 0, "u64");
  eb += descriptor(8, 0, "i64");
  eb += descriptor(9, 0, "f32");
  eb += descriptor(10, 0, "f64");
  eb += descriptor(3, 8, "scaled", {0.01, 1, 1});                          // ushort, scale only
  eb += descriptor(4, 8 | 16, "scaled_offset", {0.5, 1, 1}, {100, 0, 0});  // short, scale and offset
  eb += descriptor(6, 16, "offset_only", {1, 1, 1}, {-1000.5, 0, 0});      // long, offset only
  eb += descriptor(0, 3, "undocumented");                                  // 3 bytes to skip
  eb += descriptor(13, 0, "pair");                                         // deprecated 2 x ushort
  eb += descriptor(22, 8, "triple", {0.1, 0.2, 0.5});                      // deprecated 3 x uchar, scaled
  eb += descriptor(1, 0, "intensity");                                     // clashes with a standard field
  eb += descriptor(1, 0, std::string("pad  \0\0", 7));                     // trailing spaces and NULs trimmed
  eb += descriptor(1, 0, "");                                              // no name
  file.vlrs.push_back(vlr("LASF_Projection", 2112, "fake WKT"));
  file.vlrs.push_back(vlr("LASF_Spec", 4, eb));
  file.vlrs.push_back(vlr("other", 1, std::string(10, 'x')));

  for (int i = 0; i < 2; ++i) {
    las_point p;
    p.intensity = static_cast<std::uint16_t>(1000 + i);
    std::string& e = p.extra;
    put(e, static_cast<std::uint8_t>(i ? 255 : 0));
    put(e, static_cast<std::int8_t>(i ? -128 : 127));
    put(e, static_cast<std::uint16_t>(i ? 65535 : 1));
    put(e, static_cast<std::int16_t>(i ? -32768 : 32767));
    put(e, static_cast<std::uint32_t>(i ? 4294967295u : 2));
    put(e, static_cast<std::int32_t>(i ? -2147483647 - 1 : 2147483647));
    put(e, static_cast<std::uint64_t>(i ? (std::uint64_t{1} << 53) : 3));
    put(e, static_cast<std::int64_t>(i ? -(std::int64_t{1} << 52) : -4));
    put(e, i ? 0.25f : -1.5e10f);
    put(e, i ? 1.0 / 3.0 : -2.5e-300);
    put(e, static_cast<std::uint16_t>(i ? 12345 : 0));
    put(e, static_cast<std::int16_t>(i ? -4 : 6));
    put(e, static_cast<std::int32_t>(i ? 1000 : 0));
    e += "abc";
    put(e, static_cast<std::uint16_t>(i ? 10 : 20));
    put(e, static_cast<std::uint16_t>(i ? 30 : 40));
    put(e, static_cast<std::uint8_t>(10));
    put(e, static_cast<std::uint8_t>(20));
    put(e, static_cast<std::uint8_t>(i ? 30 : 40));
    put(e, static_cast<std::uint8_t>(77));
    put(e, static_cast<std::uint8_t>(5));
    put(e, static_cast<std::uint8_t>(6));
    e += "zz";  // undescribed trailing bytes in the record
    file.points.push_back(p);
  }
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  ASSERT_EQ(c.size(), 2u);
  const auto expect = [&](const std::string& name, scalar_type type, std::vector<double> v) {
    const ced::field* fld = c.find_field(name);
    ASSERT_NE(fld, nullptr) << name;
    EXPECT_EQ(fld->type(), type) << name;
    EXPECT_EQ(fld->values, v) << name;
  };
  expect("u8", scalar_type::uint8, {0, 255});
  expect("i8", scalar_type::int8, {127, -128});
  expect("u16", scalar_type::uint16, {1, 65535});
  expect("i16", scalar_type::int16, {32767, -32768});
  expect("u32", scalar_type::uint32, {2, 4294967295.0});
  expect("i32", scalar_type::int32, {2147483647.0, -2147483648.0});
  expect("u64", scalar_type::uint64, {3, 9007199254740992.0});
  expect("i64", scalar_type::int64, {-4, -4503599627370496.0});
  expect("f32", scalar_type::float32, {double(-1.5e10f), 0.25});
  expect("f64", scalar_type::float64, {-2.5e-300, 1.0 / 3.0});
  expect("scaled", scalar_type::float64, {0, 12345 * 0.01});
  expect("scaled_offset", scalar_type::float64, {6 * 0.5 + 100, -4 * 0.5 + 100});
  expect("offset_only", scalar_type::float64, {-1000.5, -0.5});
  expect("pair_0", scalar_type::uint16, {20, 10});
  expect("pair_1", scalar_type::uint16, {40, 30});
  expect("triple_0", scalar_type::float64, {10 * 0.1, 10 * 0.1});
  expect("triple_1", scalar_type::float64, {20 * 0.2, 20 * 0.2});
  expect("triple_2", scalar_type::float64, {40 * 0.5, 30 * 0.5});
  expect("intensity", scalar_type::uint16, {1000, 1001});
  expect("intensity_extra", scalar_type::uint8, {77, 77});
  expect("pad", scalar_type::uint8, {5, 5});
  expect("extra_18", scalar_type::uint8, {6, 6});
  EXPECT_EQ(c.find_field("undocumented"), nullptr);
  // Extra fields follow the standard ones, in descriptor order.
  EXPECT_EQ(c.fields()[11].name, "u8");
}

// ------------------------------------------------------------ malformed input

TEST(LasRead, ChunksDecodedInParallelAreTheFilesPoints) {
  // 40 000 records of 34 bytes: several chunks of records, decoded in
  // parallel from the file (pread) and from memory. The withheld flag is set
  // by the last point only: every chunk of read_las has the field, and so
  // has every chunk of a stream after its first pass.
  las_file file;
  file.format = 3;
  file.offset = {500000, 4000000, 0};
  const std::size_t n = 40000;
  for (std::size_t i = 0; i < n; ++i) {
    las_point p;
    p.x = static_cast<std::int32_t>(i * 7 % 100003) - 50000;
    p.y = static_cast<std::int32_t>(i * 13 % 99991);
    p.z = static_cast<std::int32_t>(i % 1000);
    p.intensity = static_cast<std::uint16_t>(i);
    p.classification = static_cast<int>(i % 32);
    p.gps_time = 0.5 * static_cast<double>(i);
    p.red = static_cast<std::uint16_t>(3 * i);
    p.withheld = i + 1 == n;
    file.points.push_back(p);
  }
  const std::string bytes = file.build();
  const std::string path = temp_file("chunks.las");
  write_bytes(path, bytes);
  const point_cloud c = ced::io::read_las(path);
  ced_test::expect_same_cloud(c, ced::io::read_las_buffer(bytes, "mem.las"));
  ASSERT_EQ(c.size(), n);
  ASSERT_NE(c.find_field("withheld"), nullptr);
  for (std::size_t i = 0; i < n; i += 997) {
    const las_point& p = file.points[i];
    EXPECT_NEAR(absolute(c, i, 0), 500000 + p.x * 0.01, 0.01) << i;
    EXPECT_EQ(values(c, "intensity")[i], p.intensity) << i;
    EXPECT_EQ(values(c, "classification")[i], p.classification) << i;
    EXPECT_EQ(values(c, "gps_time")[i], p.gps_time) << i;
    EXPECT_EQ(values(c, "red")[i], p.red) << i;
    EXPECT_EQ(values(c, "withheld")[i], 0.0) << i;
  }
  EXPECT_EQ(values(c, "withheld")[n - 1], 1.0);

  // Only the selected fields, the same values.
  const point_cloud some = ced::io::read_las(path, nullptr, ced::field_selection::only({"gps_time", "withheld"}));
  ASSERT_EQ(some.fields().size(), 2u);
  EXPECT_EQ(some.positions(), c.positions());
  EXPECT_EQ(values(some, "gps_time"), values(c, "gps_time"));
  EXPECT_EQ(values(some, "withheld"), values(c, "withheld"));

  // The stream: the first chunk has no flag before its first pass, then the
  // chunks are read_las's points.
  auto s = ced::io::open_las_stream(path);
  point_cloud chunk;
  ASSERT_EQ(s->read(30000, {0, 0, 0}, chunk), 30000u);
  EXPECT_EQ(chunk.find_field("withheld"), nullptr);
  while (s->read(30000, {0, 0, 0}, chunk) > 0) {
  }
  EXPECT_EQ(s->origin(), c.origin());
  s->rewind();
  std::size_t at = 0;
  while (s->read(12345, s->origin(), chunk) > 0) {
    ASSERT_EQ(chunk.fields().size(), c.fields().size());
    for (std::size_t i = 0; i < chunk.size(); ++i)
      for (std::size_t k = 0; k < 3; ++k) ASSERT_EQ(chunk.position(i)[k], c.position(at + i)[k]);
    for (std::size_t f = 0; f < c.fields().size(); ++f)
      for (std::size_t i = 0; i < chunk.size(); ++i)
        ASSERT_EQ(chunk.fields()[f].values[i], c.fields()[f].values[at + i]);
    at += chunk.size();
  }
  EXPECT_EQ(at, n);
}

TEST(LasRead, OnlySelectedFieldsAreDecoded) {
  las_file file;
  file.minor = 4;
  file.format = 7;  // colour
  file.vlrs.push_back(vlr("LASF_Spec", 4, descriptor(1, 0, "intensity") + descriptor(3, 0, "nir_extra")));
  for (int i = 0; i < 3; ++i) {
    las_point p;
    p.intensity = static_cast<std::uint16_t>(100 + i);
    p.red = static_cast<std::uint16_t>(10 * i);
    p.green = static_cast<std::uint16_t>(20 * i);
    p.blue = static_cast<std::uint16_t>(30 * i);
    p.x = 1000 * i;
    put(p.extra, static_cast<std::uint8_t>(7 + i));
    put(p.extra, static_cast<std::uint16_t>(500 + i));
    file.points.push_back(p);
  }
  const std::string bytes = file.build();
  const point_cloud all = ced::io::read_las_buffer(bytes, "mem.las");
  ASSERT_NE(all.find_field("intensity_extra"), nullptr);  // the extra field's name, with every field read
  // Names matched ignoring case; an extra field keeps the name it has when
  // every field is read, whatever is selected.
  const point_cloud some = ced::io::read_las_buffer(bytes, "mem.las", nullptr,
                                                    ced::field_selection::only({"RED", "green", "intensity_extra"}));
  std::vector<std::string> names;
  for (const auto& f : some.fields()) names.push_back(f.name);
  EXPECT_EQ(names, (std::vector<std::string>{"red", "green", "intensity_extra"}));
  for (const auto& f : some.fields()) {
    EXPECT_EQ(f.values, all.get_field(f.name).values) << f.name;
    EXPECT_EQ(f.type(), all.get_field(f.name).type()) << f.name;
  }
  EXPECT_EQ(some.positions(), all.positions());
  EXPECT_EQ(some.origin(), all.origin());
  // Nothing selected: positions only. Everything: the default.
  EXPECT_TRUE(ced::io::read_las_buffer(bytes, "mem.las", nullptr, ced::field_selection::only({})).fields().empty());
  EXPECT_EQ(ced::io::read_las_buffer(bytes, "mem.las", nullptr, {}).fields().size(), all.fields().size());
  // read_cloud applies the selection to every format.
  const std::string dir = ced_test::temp_dir().string();
  ced::io::write_cloud(dir + "/all.ply", all);
  ced::io::read_options o;
  o.fields = ced::field_selection::only({"blue", "nir_extra"});
  const point_cloud ply = ced::io::read_cloud(dir + "/all.ply", o);
  ASSERT_EQ(ply.fields().size(), 2u);
  EXPECT_EQ(ply.get_field("blue").values, all.get_field("blue").values);
  EXPECT_EQ(ply.get_field("nir_extra").values, all.get_field("nir_extra").values);
}

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

namespace {

std::string data_path(const std::string& name) { return std::string(CED_TEST_DATA_DIR) + "/" + name; }

/// "" when the point records `a` and `b` (`stride` bytes each) are the same
/// bytes; else how they differ: the number of records, the first record
/// that differs, and the largest change of a raw X, Y or Z integer.
std::string record_difference(const std::string& a, const std::string& b, std::size_t stride) {
  if (a == b) return "";
  std::ostringstream out;
  if (a.size() != b.size() || stride == 0) {
    out << a.size() << " bytes of records against " << b.size();
    return out.str();
  }
  std::size_t first = a.size() / stride, differ = 0;
  std::int64_t most = 0;
  for (std::size_t i = 0; i < a.size() / stride; ++i) {
    if (std::memcmp(&a[i * stride], &b[i * stride], stride) == 0) continue;
    first = std::min(first, i);
    ++differ;
    for (std::size_t k = 0; k < 3; ++k)
      most = std::max<std::int64_t>(most, std::llabs(std::int64_t(peek<std::int32_t>(a, i * stride + 4 * k)) -
                                                     peek<std::int32_t>(b, i * stride + 4 * k)));
  }
  out << differ << " records differ, the first is record " << first << "; X/Y/Z integers move by up to " << most;
  return out.str();
}

/// The point records of a LAS or LAZ file's bytes (decoded).
std::string records_of(const std::string& bytes, const std::string& name) {
  return ced::io::detail::las_point_records(bytes, name);
}

/// The LAS/LAZ files of tests/data whose positions are exact in floats.
const char* const k_public_las_files[] = {"simple.las",
                                          "autzen_trim.las",
                                          "1.2-with-color.las",
                                          "autzen-bmx-2010.las",
                                          "warsaw_small.las",
                                          "sample_c.las",
                                          "file_with_both_wkt_and_geotiff_vlrs.las",
                                          "simple.laz",
                                          "simple-laszip-1.2r0.laz",
                                          "autzen_trim.laz",
                                          "1.2-with-color.copc.laz"};

}  // namespace

class LasWriteLike : public ::testing::TestWithParam<const char*> {};

TEST_P(LasWriteLike, PointRecordsComeBackByteForByte) {
  const std::string name = GetParam();
  const std::string source = read_bytes(data_path(name));
  las_read_info src;
  const point_cloud cloud = ced::io::read_las_buffer(source, name, &src);
  std::vector<std::string> changes;
  const las_write_options opt = ced::io::las_write_options_like(src, cloud, false, &changes);
  EXPECT_TRUE(changes.empty()) << changes.front();
  const std::string want = records_of(source, name);
  const std::size_t stride = want.size() / std::max<std::size_t>(cloud.size(), 1);
  for (const auto format : {ced::io::file_format::las, ced::io::file_format::laz}) {
    std::stringstream s;
    ced::io::write_cloud(s, cloud, format, opt);
    const std::string out = s.str();
    las_read_info got;
    const point_cloud back = ced::io::read_las_buffer(out, "out", &got);
    const std::string what = name + " as " + ced::io::format_name(format);
    EXPECT_EQ(got.version_minor, src.version_minor) << what;
    EXPECT_EQ(got.point_format, src.point_format) << what;
    EXPECT_EQ(got.scale, src.scale) << what;
    EXPECT_EQ(got.offset, src.offset) << what;
    EXPECT_EQ(got.global_encoding & 1, src.global_encoding & 1) << what;
    EXPECT_EQ(got.compressed, format == ced::io::file_format::laz) << what;
    EXPECT_EQ(record_difference(records_of(out, what), want, stride), "") << what;
    // The fields keep their types (scan_angle: int8 degrees in formats 0-5).
    ASSERT_EQ(back.fields().size(), cloud.fields().size()) << what;
    for (std::size_t j = 0; j < cloud.fields().size(); ++j)
      EXPECT_EQ(back.fields()[j].type(), cloud.fields()[j].type()) << what << " " << cloud.fields()[j].name;
  }
}

INSTANTIATE_TEST_SUITE_P(PublicFiles, LasWriteLike, ::testing::ValuesIn(k_public_las_files),
                         [](const ::testing::TestParamInfo<const char*>& p) {
                           std::string s = p.param;
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

TEST(LasWriteLike, FinerThanAFloatMovesOnceThenIsStable) {
  // 1_4_w_evlr.las: scale 1.16e-6 (Z 1.0e-6). Positions are floats relative
  // to the origin: X spans ~500 around the origin's X (float steps up to
  // 2^-16 = 1.5e-5 at 250 from it), Z lies at ~5596 from the origin's Z (0:
  // the centre is within 1e4; steps of 2^-11 = 4.9e-4), both coarser than the
  // scale; Y spans ~5 (steps of 2.4e-7, finer). The source's X and Z
  // integers cannot all come back, which is said once an axis; the first
  // write moves them by at most half a float step; what it wrote comes back
  // byte for byte.
  const std::string name = "1_4_w_evlr.las";
  const std::string source = read_bytes(data_path(name));
  las_read_info src;
  const point_cloud a = ced::io::read_las_buffer(source, name, &src);
  std::vector<std::string> changes;
  const las_write_options opt = ced::io::las_write_options_like(src, a, false, &changes);
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].rfind("X positions are floats", 0), 0u) << changes[0];
  EXPECT_EQ(changes[1].rfind("Z positions are floats", 0), 0u) << changes[1];
  EXPECT_EQ(opt.scale, src.scale);
  ASSERT_TRUE(opt.offset.has_value());
  EXPECT_EQ(*opt.offset, src.offset);
  std::stringstream s1;
  ced::io::write_las(s1, a, opt);
  const std::string want = records_of(source, name), first = records_of(s1.str(), "first");
  ASSERT_EQ(first.size(), want.size());
  const std::size_t stride = 30;
  float far[3] = {0, 0, 0};
  for (std::size_t i = 0; i < a.positions().size(); ++i) far[i % 3] = std::max(far[i % 3], std::fabs(a.positions()[i]));
  double most[3] = {0, 0, 0};
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(first.compare(i * stride + 12, stride - 12, want, i * stride + 12, stride - 12), 0) << i;
    for (std::size_t k = 0; k < 3; ++k) {
      const double moved = std::fabs(double(peek<std::int32_t>(first, i * stride + 4 * k)) -
                                     peek<std::int32_t>(want, i * stride + 4 * k)) *
                           src.scale[k];
      most[k] = std::max(most[k], moved);
      const double half_step = (double(std::nextafter(far[k], 2 * far[k])) - far[k]) / 2;
      EXPECT_LE(moved, half_step + src.scale[k]) << i << "," << k;
    }
  }
  EXPECT_GT(most[0], 0);  // the test's premise: the integers did move
  EXPECT_EQ(most[1], 0);
  EXPECT_GT(most[2], 0);
  las_read_info mid;
  const point_cloud b = ced::io::read_las_buffer(s1.str(), "first", &mid);
  std::stringstream s2;
  ced::io::write_las(s2, b, ced::io::las_write_options_like(mid, b));
  EXPECT_EQ(record_difference(records_of(s2.str(), "second"), first, stride), "");
}

TEST(LasWriteLike, MovedPointsFallBackAndSaySo) {
  las_read_info src;
  point_cloud c = ced::io::read_las(data_path("simple.las"), &src);
  std::vector<std::string> changes;
  las_write_options opt = ced::io::las_write_options_like(src, c, false, &changes);
  EXPECT_TRUE(changes.empty());
  ASSERT_TRUE(opt.offset.has_value());
  c.positions()[4] += 0.003f;  // off the 0.01 grid
  opt = ced::io::las_write_options_like(src, c, false, &changes);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("not on the source's grid"), std::string::npos) << changes[0];
  EXPECT_EQ(opt.scale, (std::array<double, 3>{0.001, 0.001, 0.001}));
  EXPECT_FALSE(opt.offset.has_value());
  EXPECT_EQ(opt.point_format, 3);  // the format and version are kept
  EXPECT_EQ(opt.version_minor, 2);
  std::stringstream s;
  ced::io::write_las(s, c, opt);
  const point_cloud back = ced::io::read_las_buffer(s.str(), "out");
  EXPECT_NEAR(back.origin()[1] + back.position(1)[1], c.origin()[1] + c.position(1)[1], 0.0005 + 1e-4);
}

TEST(LasWriteLike, FormatsThatCannotBeKeptAreNamed) {
  const point_cloud c = ced::io::read_las(data_path("simple.las"));
  las_read_info src;
  src.version_minor = 2;
  src.point_format = 3;
  src.scale = {0.01, 0.01, 0.01};
  std::vector<std::string> changes;
  las_write_options o = ced::io::las_write_options_like(src, c, true, &changes);  // COPC
  EXPECT_EQ(o.point_format, 7);
  EXPECT_EQ(o.version_minor, 4);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("COPC"), std::string::npos);
  changes.clear();
  src.point_format = 5;  // waveform packets
  o = ced::io::las_write_options_like(src, c, false, &changes);
  EXPECT_EQ(o.point_format, 3);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("waveform"), std::string::npos);
  changes.clear();
  src.point_format = 1;
  src.version_minor = 0;
  o = ced::io::las_write_options_like(src, c, false, &changes);
  EXPECT_EQ(o.version_minor, 2);
  EXPECT_EQ(o.point_format, 1);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("LAS 1.0"), std::string::npos);
  // A source whose gps_time is adjusted standard time says so again.
  src.global_encoding = 1;
  EXPECT_TRUE(ced::io::las_write_options_like(src, c).adjusted_standard_gps_time);
}

TEST(LasWrite, ExplicitPointFormatAndOffset) {
  point_cloud c;
  c.set_origin({500000, 4000000, 0});
  c.push_back(1.25f, -2.5f, 3.0f);
  c.push_back(-1.0f, 0.5f, 0.25f);
  las_write_options o;
  o.version_minor = 2;
  o.point_format = 3;  // gps_time and colour slots, though the cloud has neither
  o.scale = {0.01, 0.01, 0.01};
  o.offset = std::array<double, 3>{499000, 3999000, -10};
  std::stringstream s;
  ced::io::write_las(s, c, o);
  const std::string bytes = s.str();
  las_read_info info;
  const point_cloud back = ced::io::read_las_buffer(bytes, "out", &info);
  EXPECT_EQ(info.point_format, 3);
  EXPECT_EQ(info.version_minor, 2);
  EXPECT_EQ(info.offset, (*o.offset));
  EXPECT_EQ(peek<std::int32_t>(bytes, 227), 100125);  // (500001.25 - 499000) / 0.01
  EXPECT_EQ(peek<std::int32_t>(bytes, 227 + 4), 99750);
  EXPECT_EQ(peek<std::int32_t>(bytes, 227 + 8), 1300);
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(absolute(back, i, k), absolute(c, i, k), 1e-6);
  o.point_format = 7;  // LAS 1.4 only
  EXPECT_THROW(ced::io::write_las(s, c, o), std::invalid_argument);
  o.point_format = 4;  // waveform
  EXPECT_THROW(ced::io::write_las(s, c, o), std::invalid_argument);
  o.point_format = -1;
  o.offset = std::array<double, 3>{0, std::numeric_limits<double>::quiet_NaN(), 0};
  EXPECT_THROW(ced::io::write_las(s, c, o), std::invalid_argument);
}

#ifdef CED_CLI_EXE
namespace {

/// Runs `ced <args>`, its stderr into *err; the exit status.
int run_cli(const std::string& args, std::string* err) {
  const char* exe = std::getenv("CED_CLI");
  const std::string log = temp_file("cli_stderr.txt");
  const std::string cmd = std::string(exe && *exe ? exe : CED_CLI_EXE) + " " + args + " 2>" + log;
  const int rc = std::system(cmd.c_str());
  if (err) *err = read_bytes(log);
  return rc;
}

}  // namespace

TEST(LasConvert, LasToLasKeepsTheRecordsVersionAndFormat) {
  struct pair {
    const char* in;
    const char* out;
  };
  for (const pair p : {pair{"simple.las", "a.las"}, pair{"autzen-bmx-2010.las", "b.las"},
                       pair{"1.2-with-color.copc.laz", "c.las"}, pair{"simple.laz", "d.las"},
                       pair{"simple.las", "e.laz"}, pair{"file_with_both_wkt_and_geotiff_vlrs.las", "f.laz"}}) {
    const std::string out = temp_file(p.out);
    std::string err;
    ASSERT_EQ(run_cli("convert " + data_path(p.in) + " " + out, &err), 0) << err;
    // Nothing of the points changes; only the VLRs that no writer carries (a CRS) are named.
    const std::string wkt = "'LASF_Projection' 2112";
    const std::string vlrs = std::string(p.in).find("simple") == 0 ? ""
                             : std::string(p.in).find("wkt") != std::string::npos
                                 ? "'LASF_Projection' 34735, 'LASF_Projection' 34736, 'LASF_Projection' 34737, " + wkt
                             : std::string(p.in).find("copc") != std::string::npos ? wkt + ", and 1 extended VLR(s)"
                                                                                   : wkt;
    EXPECT_EQ(err, vlrs.empty() ? ""
                                : "ced: note: " + out + ": " + data_path(p.in) + "'s VLRs " + vlrs +
                                      " (a coordinate system, if one is among them) are not copied\n")
        << p.in;
    las_read_info src, got;
    ced::io::read_las(data_path(p.in), &src);
    ced::io::read_las(out, &got);
    EXPECT_EQ(got.version_minor, src.version_minor) << p.in;
    EXPECT_EQ(got.point_format, src.point_format) << p.in;
    EXPECT_EQ(got.scale, src.scale) << p.in;
    EXPECT_EQ(got.offset, src.offset) << p.in;
    const std::string want = records_of(read_bytes(data_path(p.in)), p.in);
    EXPECT_EQ(
        record_difference(records_of(read_bytes(out), out), want, want.size() / std::max<std::uint64_t>(src.points, 1)),
        "")
        << p.in;
  }
}

TEST(LasConvert, ChangesAreSaidOnceOnStderr) {
  std::string err;
  const std::string out = temp_file("voxel.las");
  ASSERT_EQ(run_cli("convert " + data_path("simple.las") + " " + out + " --voxel 20", &err), 0) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("not on the source's grid"), std::string::npos) << err;
  las_read_info got;
  ced::io::read_las(out, &got);
  EXPECT_EQ(got.scale, (std::array<double, 3>{0.001, 0.001, 0.001}));
  EXPECT_EQ(got.point_format, 3);
  EXPECT_EQ(got.version_minor, 2);
  // COPC holds formats 6-8 only.
  ASSERT_EQ(run_cli("convert " + data_path("simple.las") + " " + temp_file("s.copc.laz"), &err), 0) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("COPC"), std::string::npos) << err;
  // A PLY has no scale.
  ASSERT_EQ(run_cli("convert " + data_path("falloff_patch.ply") + " " + temp_file("p.las"), &err), 0) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("no LAS scale"), std::string::npos) << err;
}
#endif
