// SPDX-License-Identifier: MIT
// Helpers of the tests split from test_ply.cpp.
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

#include "ced/io/io.hpp"
#include "ced/io/ply.hpp"
#include "ced/io/stream.hpp"
#include "core/parallel.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;
using ced::point_cloud;
using ced::scalar_type;
using ced::io::io_error;
using ced::io::ply_format;
using ced_test::expect_same_cloud;
using ced_test::read_bytes;
using ced_test::temp_dir;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace ply_test {

inline point_cloud read_string(const std::string& bytes, const std::string& name = "test.ply") {
  std::istringstream in(bytes);
  return ced::io::read_ply(in, name);
}

/// The io_error message from reading `bytes` (through a file named `name`).
inline std::string read_error(const std::string& bytes, const std::string& name = "bad.ply") {
  return ced_test::read_error_of([](const std::string& path) { ced::io::read_ply(path); }, bytes, name);
}

using ced_test::bytes_builder;

inline const char* format_name(ply_format f) {
  return f == ply_format::ascii                  ? "ascii"
         : f == ply_format::binary_little_endian ? "binary_little_endian"
                                                 : "binary_big_endian";
}

inline point_cloud all_types_cloud() {
  point_cloud c;
  c.push_back(0.f, 0.f, 0.f);
  c.push_back(1.5f, -2.25f, 3.125f);
  c.push_back(-1000.f, 1e-7f, 123.456f);
  c.push_back(9999.5f, -std::numeric_limits<float>::denorm_min(), 0.1f);
  c.push_back(std::nanf(""), std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity());
  const scalar_type types[] = {scalar_type::int8,  scalar_type::uint8,  scalar_type::int16,   scalar_type::uint16,
                               scalar_type::int32, scalar_type::uint32, scalar_type::float32, scalar_type::float64};
  for (scalar_type t : types) {
    std::vector<double> v;
    if (ced::is_integer(t)) {
      const auto r = ced::natural_range(t);
      v = {r[0], r[1], 0, 1, std::floor((r[0] + r[1]) / 3)};
    } else if (t == scalar_type::float32) {
      v = {double(0.1f), double(-3.4e38f), double(std::numeric_limits<float>::denorm_min()), 1e-3f, 42};
    } else {
      v = {0.1, -1.7976931348623157e308, 4.9e-324, 1.0 / 3.0, -0.0};
    }
    c.add_field(std::string("f_") + std::string(ced::name_of(t)), t, v);
  }
  c.add_rgb({{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {1, 2, 3}, {200, 100, 50}});
  return c;
}

class PlyRoundTrip : public ::testing::TestWithParam<ply_format> {};

}  // namespace ply_test
