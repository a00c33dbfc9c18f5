// SPDX-License-Identifier: MIT
// Temporary files for the I/O tests: one directory per test process, removed
// when the tests end.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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

}  // namespace ced_test

/// Expects `haystack` (convertible to std::string) to contain `needle`.
#define EXPECT_CONTAINS(haystack, needle)                          \
  EXPECT_NE(std::string(haystack).find(needle), std::string::npos) \
      << "expected to find \"" << (needle) << "\" in: " << (haystack)
