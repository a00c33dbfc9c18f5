// SPDX-License-Identifier: MIT
// Helpers of the tests split from test_pcd.cpp.
#pragma once

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

namespace pcd_test {

inline point_cloud read_string(const std::string& bytes, pcd_read_info* info = nullptr) {
  return ced::io::read_pcd_buffer(bytes, "test.pcd", info);
}

/// The io_error message from reading `bytes` (through a file named `name`).
inline std::string read_error(const std::string& bytes, const std::string& name = "bad.pcd") {
  return ced_test::read_error_of([](const std::string& path) { ced::io::read_pcd(path); }, bytes, name);
}

using ced_test::bytes_builder;

inline std::string u32_bytes(std::uint32_t v) { return bytes_builder{}.put(v).data; }

inline float packed_float(std::uint32_t bits) {
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

inline const char* format_name(pcd_format f) {
  return f == pcd_format::ascii ? "ascii" : f == pcd_format::binary ? "binary" : "binary_compressed";
}

/// A header for FIELDS x y z (F4) + `extra` fields, n points, unorganized.
inline std::string header(std::size_t n, const std::string& data, const std::string& fields = "x y z",
                          const std::string& size = "4 4 4", const std::string& type = "F F F",
                          std::string count = "") {
  if (count.empty())
    for (char c : " " + fields)
      if (c == ' ') count += count.empty() ? "1" : " 1";
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " +
         type + "\nCOUNT " + count + "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
         std::to_string(n) + "\nDATA " + data + "\n";
}

inline point_cloud all_types_cloud() {
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

inline std::string write_string(const point_cloud& c, pcd_format fmt) {
  std::ostringstream s(std::ios::out | std::ios::binary);
  ced::io::write_pcd(s, c, fmt);
  return s.str();
}

/// A room-like cloud with colour and intensity: compressible like real data.
inline point_cloud big_cloud(std::size_t n) {
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

}  // namespace pcd_test
