// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/block_partition.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "test_support.hpp"

TEST(BlockPartition, CoversEveryPointOnce) {
  const auto c = ced_test::make_room(5000, 8);
  for (unsigned t : {1u, 2u}) {
    const ced::block_partition b(c.positions().data(), c.size(), 0.03, t);
    std::vector<int> seen(c.size(), 0);
    for (std::size_t k = 0; k < b.block_count(); ++k) {
      ASSERT_LE(b.block_size(k), 256u);
      for (std::size_t q = 0; q < b.block_size(k); ++q) {
        ++seen[b.block_points(k)[q]];
        if (q) {
          EXPECT_LT(b.block_points(k)[q - 1], b.block_points(k)[q]);
        }
      }
    }
    EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
  }
}

TEST(BlockPartition, SameBlocksForAnyThreadCount) {
  // Enough points for the sort to split its work into several chunks, and
  // cells small enough for keys of more than one radix digit.
  const auto c = ced_test::make_room(150000, 9);
  const ced::block_partition one(c.positions().data(), c.size(), 0.004, 1);
  ASSERT_GT(one.block_count(), std::size_t(1) << 11);
  for (unsigned t : {2u, 3u, 8u}) {
    const ced::block_partition b(c.positions().data(), c.size(), 0.004, t);
    EXPECT_EQ(b.order(), one.order()) << t << " threads";
    ASSERT_EQ(b.block_count(), one.block_count());
    for (std::size_t k = 0; k < b.block_count(); ++k) ASSERT_EQ(b.block_size(k), one.block_size(k));
  }
}

TEST(BlockPartition, BoxSearchFindsThePointsInTheBoxInOneOrderOnEveryBuild) {
  const auto c = ced_test::make_room(20000, 10);
  const float* xyz = c.positions().data();
  // 2 mm cells: boxes of far more rows than occupied cells (knn or adaptive
  // with a radius far below the spacing), which walk the occupied cells.
  for (const double cell : {0.05, 0.002}) {
    const double inv = 1.0 / cell;
    const ced::block_partition b(xyz, c.size(), cell, 2);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> at(-0.2f, 1.2f), side(0.0f, 0.3f);
    ced::detail::raw_vector<ced::neighbor_index::located_point> located;
    ced::detail::raw_vector<std::uint32_t> ids;
    for (int q = 0; q < 300; ++q) {
      float lo[3], hi[3];
      for (int a = 0; a < 3; ++a) {
        lo[a] = at(rng);
        // Mostly boxes of a few cells; some of many rows (searched point by
        // point), and some that reach the last cell of the order.
        hi[a] = q % 10 == 0 ? lo[a] + 2.0f : q % 10 == 1 ? 2.0f : lo[a] + side(rng);
      }
      // Cell by cell (z, y, x: the key's order), by index within a cell.
      std::vector<std::array<double, 4>> keyed;
      for (std::uint32_t i = 0; i < c.size(); ++i) {
        const float* p = xyz + 3 * std::size_t(i);
        if (p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2])
          keyed.push_back({std::floor(double(p[2]) * inv), std::floor(double(p[1]) * inv),
                           std::floor(double(p[0]) * inv), double(i)});
      }
      std::sort(keyed.begin(), keyed.end());
      std::vector<std::uint32_t> expected;
      for (const auto& k : keyed) expected.push_back(static_cast<std::uint32_t>(k[3]));
      for (const std::string& isa : ced::detail::kernel_isas()) {
        ced::detail::force_kernel_isa(isa);
        b.box_search(lo, hi, ids);
        b.box_search(lo, hi, located);
        ced::detail::force_generic_kernel(false);
        const std::string build = " " + isa;
        ASSERT_EQ(std::vector<std::uint32_t>(ids.begin(), ids.end()), expected)
            << "box " << q << build << " cell " << cell;
        ASSERT_EQ(located.size(), expected.size()) << "box " << q << build;
        for (std::size_t k = 0; k < expected.size(); ++k) {
          ASSERT_EQ(located[k].index, expected[k]) << "box " << q << ", point " << k << build;
          for (int a = 0; a < 3; ++a) ASSERT_EQ(located[k].xyz[a], xyz[3 * std::size_t(expected[k]) + std::size_t(a)]);
        }
      }
    }
  }
}
