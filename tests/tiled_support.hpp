// SPDX-License-Identifier: MIT
// Clouds, requests and comparisons shared by the tests of tiles: in memory
// (test_tiles.cpp) and through files (test_tiled_*.cpp).
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "file_support.hpp"
#include "test_support.hpp"

namespace ced_test {

inline std::vector<ced::any_modality> specs(const std::vector<std::string>& s) {
  std::vector<ced::any_modality> out;
  for (const auto& x : s) out.push_back(ced::make_modality(x));
  return out;
}

/// The room of test_support, its colour as 16-bit fields that hold 8-bit
/// values except in one corner (so a tile far from it sees only 8-bit values).
inline ced::point_cloud room16(std::size_t n, std::uint32_t seed) {
  ced::point_cloud c = make_room(n, seed);
  for (auto& f : c.fields())
    if (f.name == "red" || f.name == "green" || f.name == "blue") {
      std::vector<double> v(c.size());
      for (std::size_t i = 0; i < c.size(); ++i) v[i] = f.values[i];
      f.values = ced::column(ced::scalar_type::uint16, v);
    }
  auto& red = c.fields()[0];
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c.position(i)[0] < 0.05f && c.position(i)[1] < 0.05f) red.values.set(i, 40000);
  return c;
}

/// A request for room16(n, seed) written as a LAS file (with `origin`): xyz + rgb, r = 0.02.
inline ced::tiled_request room_request(std::size_t n, std::uint32_t seed, const std::string& name, double tile,
                                       const std::array<double, 3>& origin = {0, 0, 0}) {
  ced::point_cloud c = room16(n, seed);
  c.set_origin(origin);
  ced::tiled_request r;
  r.input = temp_file(name);
  ced::io::write_cloud(r.input, c);
  r.tile_size = tile;
  r.params.radius = r.params.nms_radius = 0.02;
  r.modalities = {"xyz:0.2", "rgb:0.1"};
  return r;
}

inline void expect_same_part(const ced::tile_part& a, const ced::tile_part& b, const std::string& what) {
  EXPECT_EQ(a.index, b.index) << what;
  EXPECT_EQ(a.file_index, b.file_index) << what;
  EXPECT_EQ(a.keypoints.positions(), b.keypoints.positions()) << what;
  ASSERT_EQ(a.keypoints.fields().size(), b.keypoints.fields().size()) << what;
  for (std::size_t f = 0; f < a.keypoints.fields().size(); ++f) {
    const auto& x = a.keypoints.fields()[f];
    const auto& y = b.keypoints.fields()[f];
    EXPECT_EQ(x.name, y.name) << what;
    ASSERT_EQ(x.type(), y.type()) << what;
    EXPECT_EQ(0, std::memcmp(x.values.bytes(), y.values.bytes(), ced::size_of(x.type()) * a.index.size()))
        << what << ", field " << x.name;
  }
  EXPECT_EQ(a.saliency, b.saliency) << what;
  EXPECT_EQ(a.names, b.names) << what;
  EXPECT_EQ(a.candidates, b.candidates) << what;
  EXPECT_EQ(a.any_candidates, b.any_candidates) << what;
}

inline ced::tile_part detect_planned_tile(const ced::tile_plan& plan, std::uint64_t id) {
  return ced::detect_tile(plan, ced::read_tile(plan, id));
}

}  // namespace ced_test
