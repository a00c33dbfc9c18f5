// SPDX-License-Identifier: MIT
// Helpers of the tests split from test_las.cpp.
#pragma once

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

namespace las_test {

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

inline void put_chars(std::string& s, const std::string& text, std::size_t width) {
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

inline bool has_gps(int f) { return f != 0 && f != 2; }
inline bool has_rgb(int f) { return f == 2 || f == 3 || f == 5 || f == 7 || f == 8 || f == 10; }
inline bool has_nir(int f) { return f == 8 || f == 10; }
inline bool has_wave(int f) { return f == 4 || f == 5 || f == 9 || f == 10; }

/// The record bytes of `p` in point format `f`, padded to `record_length`.
inline std::string record(int f, const las_point& p, std::size_t record_length) {
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
inline std::string descriptor(int data_type, int options, const std::string& name,
                              std::array<double, 3> scale = {1, 1, 1}, std::array<double, 3> offset = {0, 0, 0}) {
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

inline std::string vlr(const std::string& user_id, std::uint16_t record_id, const std::string& payload) {
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
inline std::vector<las_point> sample_points(int f) {
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

inline std::string read_error(const std::string& bytes, const std::string& name = "bad.las") {
  return ced_test::read_error_of([](const std::string& path) { ced::io::read_las(path); }, bytes, name);
}

inline const ced::column& values(const point_cloud& c, const std::string& name) { return c.get_field(name).values; }

inline double absolute(const point_cloud& c, std::size_t i, std::size_t k) { return c.origin()[k] + c.position(i)[k]; }

}  // namespace las_test
