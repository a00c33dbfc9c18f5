// SPDX-License-Identifier: MIT
// Temporary files for the I/O tests (one directory per test process, removed
// when the tests end), files built byte by byte, and a bit-exact comparison
// of two clouds.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "ced/cloud.hpp"
#include "ced/io/output_file.hpp"

namespace ced_test {

inline std::filesystem::path temp_dir() {
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::path(::testing::TempDir()) / ("ced_test_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

struct remove_temp_dir : ::testing::Environment {
  void TearDown() override { std::filesystem::remove_all(temp_dir()); }
};
inline ::testing::Environment* const g_remove_temp_dir = ::testing::AddGlobalTestEnvironment(new remove_temp_dir);

inline std::string temp_file(const std::string& name) { return (temp_dir() / name).string(); }

/// Appends binary values, little-endian or (big_endian) big-endian: the tests
/// run on little-endian hosts.
struct bytes_builder {
  std::string data;
  bool big_endian = false;
  template <class T>
  bytes_builder& put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));
    data.append(b, sizeof(T));
    return *this;
  }
};

inline void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Writes `bytes` to a temporary file `name`, calls `read(path)`, and returns
/// the io_error message it throws (expecting it to name the file), or
/// "<no io_error thrown>".
/// The io_error message `f()` throws, or "<no io_error thrown>".
template <class F>
std::string io_error_of(F&& f) {
  try {
    f();
  } catch (const ced::io::io_error& e) {
    return e.what();
  }
  return "<no io_error thrown>";
}

template <class Read>
std::string read_error_of(Read&& read, const std::string& bytes, const std::string& name) {
  const std::string path = temp_file(name);
  write_bytes(path, bytes);
  try {
    read(path);
  } catch (const ced::io::io_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message does not name the file: " << msg;
    return msg;
  }
  return "<no io_error thrown>";
}

/// Expects a == b with the same sign bit, or both NaN.
inline void expect_same_value(double a, double b, const std::string& what) {
  if (std::isnan(a)) {
    EXPECT_TRUE(std::isnan(b)) << what;
  } else {
    EXPECT_EQ(a, b) << what;
    EXPECT_EQ(std::signbit(a), std::signbit(b)) << what;
  }
}

/// Expects two clouds to hold the same origin, positions and fields (names,
/// types, values), value for value as expect_same_value.
inline void expect_same_cloud(const ced::point_cloud& a, const ced::point_cloud& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.origin(), b.origin());
  for (std::size_t i = 0; i < 3 * a.size(); ++i)
    expect_same_value(a.positions()[i], b.positions()[i], "position " + std::to_string(i));
  ASSERT_EQ(a.fields().size(), b.fields().size());
  for (std::size_t f = 0; f < a.fields().size(); ++f) {
    const auto& fa = a.fields()[f];
    const auto& fb = b.fields()[f];
    EXPECT_EQ(fa.name, fb.name);
    EXPECT_EQ(fa.type(), fb.type()) << fa.name;
    ASSERT_EQ(fa.values.size(), fb.values.size());
    for (std::size_t i = 0; i < fa.values.size(); ++i)
      expect_same_value(fa.values[i], fb.values[i], fa.name + "[" + std::to_string(i) + "]");
  }
}

}  // namespace ced_test

/// Expects `haystack` (convertible to std::string) to contain `needle`.
#define EXPECT_CONTAINS(haystack, needle)                          \
  EXPECT_NE(std::string(haystack).find(needle), std::string::npos) \
      << "expected to find \"" << (needle) << "\" in: " << (haystack)
