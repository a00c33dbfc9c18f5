// SPDX-License-Identifier: MIT
// Helpers of the tests split from test_stream.cpp.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/io/io.hpp"
#include "ced/io/stream.hpp"
#include "file_support.hpp"

using ced::point_cloud;
using ced::scalar_type;
using ced::io::io_error;
using ced::io::read_options;
using ced_test::read_bytes;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace stream_test {

constexpr double nan_v = std::numeric_limits<double>::quiet_NaN();

/// n points around (500000, 4000000, 100), like projected map coordinates,
/// with fields of several types.
inline point_cloud georeferenced_cloud(std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 60.f);
  point_cloud c;
  c.set_origin({500000.0, 4000000.0, 0.0});
  std::vector<double> intensity(n), red(n), green(n), blue(n), curv(n), gps(n), label(n), cls(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.push_back(u(rng), u(rng), 100.f + u(rng) / 10.f);
    intensity[i] = double((i * 977) % 65536);
    red[i] = double(i % 256);
    green[i] = double((3 * i) % 256);
    blue[i] = 255 - double(i % 256);
    curv[i] = double(u(rng)) / 7.0 - 4.0;
    gps[i] = 1.3e9 + double(i) * 0.001;
    label[i] = double(i) - 50;
    cls[i] = double(i % 100) - 50;
  }
  c.add_field("intensity", scalar_type::uint16, intensity);
  c.add_field("red", scalar_type::uint8, red);
  c.add_field("green", scalar_type::uint8, green);
  c.add_field("blue", scalar_type::uint8, blue);
  c.add_field("curv", scalar_type::float32, curv);
  c.add_field("gps_time", scalar_type::float64, gps);
  c.add_field("label", scalar_type::int32, label);
  c.add_field("class8", scalar_type::int8, cls);
  return c;
}

/// The chunks put together (each with the same fields as the first).
inline point_cloud concatenate(const std::vector<point_cloud>& chunks, const std::array<double, 3>& origin) {
  point_cloud all;
  all.set_origin(origin);
  std::size_t n = 0;
  for (const auto& c : chunks) n += c.size();
  all.resize(n);
  if (chunks.empty()) return all;
  std::size_t at = 0;
  for (const auto& c : chunks) {
    EXPECT_EQ(c.origin(), origin);
    std::copy(c.positions().begin(), c.positions().end(), all.positions().begin() + std::ptrdiff_t(3 * at));
    at += c.size();
  }
  for (std::size_t f = 0; f < chunks[0].fields().size(); ++f) {
    const ced::field& first = chunks[0].fields()[f];
    const std::size_t w = ced::size_of(first.type());
    ced::column col(first.type(), n);
    at = 0;
    for (const auto& c : chunks) {
      EXPECT_EQ(c.fields().size(), chunks[0].fields().size());
      if (c.fields().size() <= f) continue;
      EXPECT_EQ(c.fields()[f].name, first.name);
      EXPECT_EQ(c.fields()[f].type(), first.type()) << first.name;
      if (c.fields()[f].type() != first.type()) continue;
      std::memcpy(col.bytes() + w * at, c.fields()[f].values.bytes(), w * c.size());
      at += c.size();
    }
    all.add_field(first.name, std::move(col));
  }
  return all;
}

/// memcmp() == 0, also for n == 0 with null pointers (empty clouds).
inline bool same_bytes(const void* a, const void* b, std::size_t n) { return n == 0 || std::memcmp(a, b, n) == 0; }

/// Expects a and b to be the same bits: origin, positions, fields (names,
/// types, bytes).
inline void expect_bitwise_equal(const point_cloud& a, const point_cloud& b) {
  ced_test::expect_same_cloud(a, b);  // readable failures
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(same_bytes(a.positions().data(), b.positions().data(), a.positions().size() * sizeof(float)))
      << "positions differ in their bits";
  ASSERT_EQ(a.fields().size(), b.fields().size());
  for (std::size_t f = 0; f < a.fields().size(); ++f) {
    const auto& fa = a.fields()[f];
    const auto& fb = b.fields()[f];
    ASSERT_EQ(fa.type(), fb.type());
    EXPECT_TRUE(same_bytes(fa.values.bytes(), fb.values.bytes(), ced::size_of(fa.type()) * a.size()))
        << fa.name << " differs in its bits";
  }
}

inline bool finite3(const float* p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

/// A first pass in chunks of 7 (positions relative to 0, as `ced plan`
/// reads it), rewind(), then chunks of 7 relative to origin(): put together,
/// they must be read_cloud()'s cloud bit for bit (after dropping the
/// non-finite points when `drop_nonfinite`: PCD). Returns the stream's
/// cloud, with every point.
inline point_cloud expect_stream_reads_like_read_cloud(const std::string& path, const read_options& options,
                                                       bool streaming, bool drop_nonfinite = false) {
  SCOPED_TRACE(path);
  ced::io::read_report report;
  const point_cloud want = ced::io::read_cloud(path, options, &report);

  const auto s = ced::io::open_point_stream(path, options);
  EXPECT_EQ(s->streaming(), streaming);
  EXPECT_EQ(s->details(), report.details);
  point_cloud chunk;
  std::size_t first_pass = 0;
  for (std::size_t n; (n = s->read(7, {0, 0, 0}, chunk)) > 0;) {
    EXPECT_EQ(chunk.size(), n);
    first_pass += n;
  }
  EXPECT_EQ(s->read(7, {0, 0, 0}, chunk), 0u);
  EXPECT_EQ(s->origin(), want.origin());

  point_cloud got;
  for (int pass = 0; pass < 2; ++pass) {  // the same twice
    s->rewind();
    std::vector<point_cloud> chunks;
    for (std::size_t n; (n = s->read(7, s->origin(), chunk)) > 0;) {
      EXPECT_LE(n, 7u);
      chunks.push_back(chunk);
    }
    got = concatenate(chunks, s->origin());
  }
  EXPECT_EQ(got.size(), first_pass);
  if (s->declared_points()) {
    EXPECT_EQ(s->declared_points(), first_pass);
  }

  point_cloud finite = got;
  if (drop_nonfinite) {
    std::vector<std::uint8_t> keep(got.size());
    for (std::size_t i = 0; i < got.size(); ++i) keep[i] = finite3(got.position(i));
    finite.filter(keep);
  }
  expect_bitwise_equal(finite, want);

  // The bounds: the box of the finite points (to float rounding of the
  // positions), or 0 when there are none.
  double lo[3], hi[3];
  s->bounds(lo, hi);
  for (std::size_t k = 0; k < 3; ++k) {
    double wlo = 0, whi = 0;
    bool any = false;
    for (std::size_t i = 0; i < want.size(); ++i) {
      if (!finite3(want.position(i))) continue;
      const double v = want.origin()[k] + want.position(i)[k];
      wlo = any ? std::min(wlo, v) : v;
      whi = any ? std::max(whi, v) : v;
      any = true;
    }
    EXPECT_NEAR(lo[k], wlo, 1e-3) << "axis " << k;
    EXPECT_NEAR(hi[k], whi, 1e-3) << "axis " << k;
  }
  return got;
}

/// The io_error that opening `path` as a stream and reading it through
/// throws (it must name the file), or "<no io_error thrown>".
inline std::string stream_error(const std::string& path, const read_options& options = {}) {
  try {
    const auto s = ced::io::open_point_stream(path, options);
    point_cloud c;
    while (s->read(7, {0, 0, 0}, c) > 0) {
    }
    s->rewind();
    while (s->read(7, s->origin(), c) > 0) {
    }
  } catch (const io_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message does not name the file: " << msg;
    return msg;
  }
  return "<no io_error thrown>";
}

inline std::string read_cloud_error(const std::string& path, const read_options& options = {}) {
  try {
    ced::io::read_cloud(path, options);
  } catch (const io_error& e) {
    return e.what();
  }
  return "<no io_error thrown>";
}

/// `bytes` without its last `cut` bytes, written to `name`; expects reading
/// it in a stream to fail as read_cloud() fails (with the same message when
/// `same_message`).
inline void expect_truncated_fails(const std::string& bytes, std::size_t cut, const std::string& name,
                                   const read_options& options = {}, bool same_message = true) {
  SCOPED_TRACE(name);
  const std::string path = temp_file(name);
  write_bytes(path, bytes.substr(0, bytes.size() - cut));
  const std::string want = read_cloud_error(path, options);
  EXPECT_NE(want, "<no io_error thrown>");
  const std::string got = stream_error(path, options);
  EXPECT_NE(got, "<no io_error thrown>");
  if (same_message) {
    EXPECT_EQ(got, want);
  }
}

using ced_test::bytes_builder;

}  // namespace stream_test
