// SPDX-License-Identifier: MIT
// Exact tiles in memory (core/tile_geometry.cpp): the union of the tiles' core
// keypoints is the whole cloud's result, index for index, whatever the tile
// size. The tiled runs through files: test_tiled_*.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "test_support.hpp"
#include "tiled_support.hpp"

namespace {

using ced_test::room16;
using ced_test::specs;

void expect_tiles_exact(const ced::point_cloud& c, const ced::detect_params& p,
                        const std::vector<std::string>& modalities, double tile, const std::string& what) {
  const auto m = specs(modalities);
  const auto whole = ced::detect(c, p, m).keypoints;
  const auto tiled = ced::detect_tiled(c, p, m, tile);
  EXPECT_EQ(tiled, whole) << what << ", tile size " << tile << ": " << tiled.size() << " against " << whole.size();
}

}  // namespace

TEST(Tiles, GridCoversEveryPointOnceAndHalosHoldTheirCores) {
  const auto c = ced_test::make_room(4000, 3);
  ced::detect_params p;
  const double lo[3] = {-0.01, -0.01, -0.01}, hi[3] = {0.33, 0.33, 0.33};
  const auto g = ced::make_tile_grid(lo, hi, 0.07, p);
  EXPECT_EQ(g.dims[0], 5u);
  EXPECT_GT(g.halo, p.nms_radius + p.block_scale * p.radius + p.radius);
  std::vector<std::uint64_t> near;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const std::uint64_t t = g.tile_of(c.position(i));
    ASSERT_LT(t, g.count());
    const auto box = g.core_box(t);
    const auto co = g.coords(t);
    for (std::size_t k = 0; k < 3; ++k) {
      const double x = c.position(i)[k];
      if (co[k] > 0) {
        EXPECT_GE(x, box[k]);
      }
      if (co[k] + 1 < g.dims[k]) {
        EXPECT_LT(x, box[k + 3]);
      }
    }
    g.tiles_near(c.position(i), near);
    EXPECT_TRUE(std::find(near.begin(), near.end(), t) != near.end());
  }
}

// The batch locate and tile_of (in vectors on each build the CPU has) give
// locate()'s and tile_of()'s numbers point for point: random points in and around the grid, points on
// the cores' faces and one halo from them, float neighbours of those, and
// non-finite points (marked −1).
TEST(Tiles, BatchLocateGivesLocatesNumbers) {
  ced::tile_grid g;
  g.lo = {-3.3, 1.7, -0.2};
  g.size = 0.7;
  g.dims = {9, 5, 3};
  g.halo = 0.45;
  std::vector<float> xyz;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 12.0);
  for (int i = 0; i < 20000; ++i)
    for (std::size_t k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(g.lo[k] + u(rng) * g.size));
  for (int c = -1; c <= 10; ++c)
    for (const double off : {0.0, g.halo, -g.halo})
      for (int step = -64; step <= 64; ++step) {  // the floats around a face, where rounding decides
        float p[3];
        for (std::size_t k = 0; k < 3; ++k) {
          p[k] = static_cast<float>(g.lo[k] + c * g.size + off);
          for (int t = 0; t < std::abs(step); ++t) p[k] = std::nextafter(p[k], step < 0 ? -INFINITY : INFINITY);
          xyz.push_back(p[k]);
        }
      }
  const std::size_t finite = xyz.size() / 3;
  const float bad[] = {NAN, INFINITY, -INFINITY};
  for (const float b : bad)
    for (std::size_t k = 0; k < 3; ++k) {
      float p[3] = {0.1f, 2.0f, 0.3f};
      p[k] = b;
      xyz.insert(xyz.end(), p, p + 3);
    }
  xyz.insert(xyz.end(), {1e30f, -1e30f, 3e38f});             // finite, far outside: clamped like locate()
  for (const std::string& isa : ced::detail::kernel_isas())  // each build the CPU has: vectors of 8, 4, none
    for (std::size_t skip = 0; skip < 8; ++skip) {           // every point in every lane
      ced::detail::force_kernel_isa(isa);
      const std::size_t n = xyz.size() / 3 - skip;
      const float* from = xyz.data() + 3 * skip;
      std::vector<std::int32_t> cells(9 * n, 7);
      g.locate_many(from, n, cells.data());
      std::vector<std::uint64_t> tiles(n, 12345);
      g.tile_of_many(from, n, tiles.data());
      ced::detail::force_generic_kernel(false);
      const std::string at = " (" + isa + ", from " + std::to_string(skip) + ")";
      for (std::size_t i = 0; i < n; ++i) {
        const float* p = from + 3 * i;
        ASSERT_EQ(tiles[i], g.tile_of(p)) << "point " << i << at;  // for every point, finite or not
        if (i + skip >= finite && i + 1 < n) {
          EXPECT_EQ(cells[9 * i + 3], -1) << "point " << i << " is not finite" << at;
          continue;
        }
        std::int64_t own[3], c0[3], c1[3];
        g.locate(p, own, c0, c1);
        for (std::size_t k = 0; k < 3; ++k) {
          ASSERT_EQ(cells[9 * i + k], own[k]) << "point " << i << ", axis " << k << at;
          ASSERT_EQ(cells[9 * i + 3 + k], c0[k]) << "point " << i << ", axis " << k << at;
          ASSERT_EQ(cells[9 * i + 6 + k], c1[k]) << "point " << i << ", axis " << k << at;
        }
      }
    }
}

TEST(Tiles, UnionOfTilesIsTheWholeResultOnRandomClouds) {
  std::mt19937 rng(2026);
  for (int trial = 0; trial < 6; ++trial) {
    const auto c = room16(5000 + 1000 * std::size_t(trial), 100u + unsigned(trial));
    ced::detect_params p;
    p.radius = 0.03 + 0.01 * (trial % 3);
    p.nms_radius = trial % 2 ? p.radius : p.radius * 1.5;
    p.min_neighbors = 5 + unsigned(trial);
    p.threads = 1 + unsigned(trial % 2);
    const double tile = std::uniform_real_distribution<double>(0.05, 0.4)(rng);
    expect_tiles_exact(c, p, {"xyz:0.2", "rgb:0.1"}, tile, "ced6d, trial " + std::to_string(trial));
    expect_tiles_exact(c, p, {"xyz:0.2"}, tile, "ced3d, trial " + std::to_string(trial));
    expect_tiles_exact(c, p, {"xyz:0.2", "lab:0.1", "intensity:0.05,range=auto", "bands(nir,blue):0.1,range=auto"},
                       tile * 0.7, "four modalities, trial " + std::to_string(trial));
  }
}

TEST(Tiles, CoreSalienciesAreBitwiseThoseOfTheWholeCloud) {
  // Stronger than equal keypoints (which float rounding rarely flips): every
  // saliency of a core point, in every modality, is bitwise the whole
  // cloud's, so no decision can differ.
  const auto c = room16(12000, 77);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.03;
  const auto m = specs({"xyz:0.2", "lab:0.1", "intensity:0.05,range=auto", "bands(nir,blue,red):0.1"});
  const auto whole = ced::detect(c, p, m);
  const double lo[3] = {0, 0, 0}, hi[3] = {0.55, 0.55, 0.55};
  const auto g = ced::make_tile_grid(lo, hi, 0.12, p);
  const auto ranges = ced::field_ranges(c);
  std::size_t checked = 0;
  for (std::uint64_t t = 0; t < g.count(); ++t) {
    const auto tile = ced::extract_tile(c, g, t, ranges);
    if (tile.cloud.empty()) continue;
    const auto r = ced::detect(tile.cloud, p, m);
    for (std::size_t i = 0; i < tile.cloud.size(); ++i) {
      if (g.tile_of(tile.cloud.position(i)) != t) continue;
      for (std::size_t k = 0; k < m.size(); ++k)
        ASSERT_EQ(r.saliency[k][i], whole.saliency[k][tile.index[i]])
            << "tile " << t << ", point " << tile.index[i] << ", " << whole.names[k];
      ++checked;
    }
  }
  EXPECT_EQ(checked, c.size());
}

TEST(Tiles, KeypointsOnTileBordersAndTies) {
  // A lattice of 1/128 m (every coordinate and sum exact in float) with a
  // regular pattern of bumps and colour patches: equal saliencies along the
  // lattice's edges and patches (ties keep both), and points lying exactly
  // on the borders of tiles of 1/8 m.
  ced::point_cloud c;
  std::vector<double> red, green, blue;
  for (int i = 0; i < 64; ++i)
    for (int j = 0; j < 64; ++j) {
      const bool bump = i % 16 == 8 && j % 16 == 8;
      c.push_back(float(i) / 128, float(j) / 128, bump ? 1.0f / 64 : 0.0f);
      const bool patch = (i / 16 + j / 16) % 2 == 0;
      red.push_back(patch ? 250 : 10);
      green.push_back(20);
      blue.push_back(patch ? 10 : 250);
    }
  c.add_field("red", ced::scalar_type::uint8, red);
  c.add_field("green", ced::scalar_type::uint8, green);
  c.add_field("blue", ced::scalar_type::uint8, blue);
  ced::detect_params p;
  const auto m = specs({"xyz:0.2", "rgb:0.1"});
  const auto whole = ced::detect(c, p, m);
  // The case is what it claims: keypoints with equal, non-zero scores closer
  // than the NMS radius, and keypoints on the tile borders.
  bool tie = false, on_border = false;
  const auto score = [&](std::uint32_t i) { return whole.saliency[0][i] * whole.saliency[1][i]; };
  for (std::size_t a = 0; a < whole.keypoints.size(); ++a) {
    const float* pa = c.position(whole.keypoints[a]);
    for (int k = 0; k < 2; ++k) on_border = on_border || (pa[k] > 0 && std::fmod(pa[k], 0.125f) == 0);
    for (std::size_t b = a + 1; b < whole.keypoints.size(); ++b) {
      const float* pb = c.position(whole.keypoints[b]);
      const float d2 =
          (pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) + (pa[2] - pb[2]) * (pa[2] - pb[2]);
      const float sa = score(whole.keypoints[a]);
      tie = tie || (d2 < float(p.nms_radius * p.nms_radius) && sa > 0 && sa == score(whole.keypoints[b]));
    }
  }
  ASSERT_TRUE(tie);
  ASSERT_TRUE(on_border);
  for (double tile : {0.125, 0.0625, 0.25, 0.01})
    EXPECT_EQ(ced::detect_tiled(c, p, m, tile), whole.keypoints) << "tile size " << tile;
}

TEST(Tiles, SparseAndEmptyTiles) {
  // Two clusters far apart (every tile between them is empty), a few lone
  // points (tiles with fewer points than min_neighbors), and tiles smaller
  // than the radius (the halo outweighs the core).
  ced::point_cloud a = ced_test::make_room(3000, 11);
  ced::point_cloud c;
  std::vector<double> red;
  for (std::size_t i = 0; i < a.size(); ++i) {
    c.push_back(a.position(i)[0], a.position(i)[1], a.position(i)[2]);
    red.push_back(a.fields()[0].values[i]);
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    c.push_back(a.position(i)[0] + 3.0f, a.position(i)[1] + 2.0f, a.position(i)[2]);
    red.push_back(a.fields()[0].values[i]);
  }
  for (int k = 0; k < 4; ++k) {
    c.push_back(1.0f + 0.3f * float(k), 1.0f, 0.5f);
    red.push_back(100);
  }
  c.add_field("intensity", ced::scalar_type::uint8, red);
  ced::detect_params p;
  p.radius = 0.04;
  p.nms_radius = 0.04;
  for (double tile : {0.5, 0.2, 0.02}) expect_tiles_exact(c, p, {"xyz:0.2", "intensity:0.05"}, tile, "two clusters");
}

TEST(Tiles, PartsDecideDataDependentRangesFromTheWholeCloud) {
  // The corner with 16-bit colour makes the whole cloud's colour 16-bit; a
  // tile away from it must not take its own colour for 8-bit.
  const auto c = room16(8000, 5);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.02;
  const double lo[3] = {0, 0, 0}, hi[3] = {0.45, 0.45, 0.45};
  const auto g = ced::make_tile_grid(lo, hi, 0.15, p);
  const auto tile = ced::extract_tile(c, g, 2);  // x from 0.3: away from the 16-bit corner
  ASSERT_GT(tile.cloud.size(), 100u);
  for (std::size_t i = 0; i < tile.cloud.size(); ++i) ASSERT_LE(tile.cloud.fields()[0].values[i], 255.0);
  ASSERT_TRUE(tile.cloud.fields()[0].whole_range.has_value());
  EXPECT_EQ(tile.cloud.fields()[0].whole_range->hi, 40000.0);
  ced::point_cloud alone = tile.cloud;
  for (auto& f : alone.fields()) f.whole_range.reset();
  const auto m = specs({"rgb:0.1"});
  const auto with = ced::detect(tile.cloud, p, m), without = ced::detect(alone, p, m);
  EXPECT_NE(with.saliency[0], without.saliency[0]);
}

TEST(Tiles, BadTileSizesAreErrors) {
  ced::detect_params p;
  const double lo[3] = {0, 0, 0}, hi[3] = {1000, 1000, 10};
  for (double s : {0.0, -1.0, std::nan(""), double(INFINITY)})
    EXPECT_THROW(ced::make_tile_grid(lo, hi, s, p), std::invalid_argument);
  EXPECT_THROW(ced::make_tile_grid(lo, hi, 0.001, p), std::invalid_argument);  // 10^13 tiles
  try {
    ced::make_tile_grid(lo, hi, 0.001, p);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("too small"), std::string::npos) << e.what();
  }
}
