// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/block_partition.hpp"
#include "core/neighbor_index.hpp"
#include "test_support.hpp"

TEST(NeighborIndex, MatchesBruteForce) {
  const auto c = ced_test::make_room(2000, 3);
  // With the identity order and with a block order (the tree over permuted points).
  const ced::block_partition blocks(c.positions().data(), c.size(), 0.03, 1);
  for (const std::uint32_t* order : {static_cast<const std::uint32_t*>(nullptr), blocks.order().data()}) {
    const ced::neighbor_index index(c.positions().data(), c.size(), 8, 1, order);
    std::vector<std::uint32_t> got;
    for (double r : {0.0, 0.01, 0.05, 0.2}) {
      const auto nb = ced_test::brute_neighbors(c, r);
      for (std::size_t i = 0; i < c.size(); i += 7) {
        index.radius_search(c.position(i), r, got);
        std::sort(got.begin(), got.end());
        ASSERT_EQ(got, nb[i]) << "r=" << r << " i=" << i;
      }
    }
    const float lo[3] = {0.1f, 0.1f, -1}, hi[3] = {0.3f, 0.2f, 1};
    // With positions: the same points in the same order, each with its own
    // position (bitwise).
    std::vector<ced::neighbor_index::located_point> located(3);
    index.box_search(lo, hi, located);
    index.box_search(lo, hi, got);
    ASSERT_EQ(located.size(), got.size());
    for (std::size_t t = 0; t < got.size(); ++t) {
      EXPECT_EQ(located[t].index, got[t]);
      EXPECT_EQ(std::memcmp(located[t].xyz, c.position(got[t]), sizeof located[t].xyz), 0);
    }
    std::sort(got.begin(), got.end());
    std::vector<std::uint32_t> want;
    for (std::size_t i = 0; i < c.size(); ++i) {
      const float* q = c.position(i);
      if (q[0] >= lo[0] && q[0] <= hi[0] && q[1] >= lo[1] && q[1] <= hi[1] && q[2] >= lo[2] && q[2] <= hi[2])
        want.push_back(static_cast<std::uint32_t>(i));
    }
    EXPECT_EQ(got, want);
    index.radius_search(c.position(0), -1, got);
    EXPECT_TRUE(got.empty());
    float nearest = INFINITY;
    for (std::size_t j = 1; j < c.size(); ++j)
      nearest = std::min(nearest, std::sqrt(ced::squared_distance(c.position(0), c.position(j))));
    EXPECT_FLOAT_EQ(index.nearest_other_distance(0), nearest);
  }
  ced::neighbor_index none(nullptr, 0);
}

TEST(NeighborIndex, ForestOfTreesMatchesBruteForce) {
  // More than 65,536 points in a block order: the index is several trees.
  const auto c = ced_test::make_room(140000, 4);
  const ced::block_partition blocks(c.positions().data(), c.size(), 0.2, 1);
  const ced::neighbor_index index(c.positions().data(), c.size(), 256, 1, blocks.order().data());
  const ced::neighbor_index index2(c.positions().data(), c.size(), 256, 2, blocks.order().data());
  std::vector<std::uint32_t> got, got2;
  for (std::size_t i = 0; i < c.size(); i += 9973) {
    const float* p = c.position(i);
    std::vector<std::uint32_t> want;
    float nearest = INFINITY;
    for (std::size_t j = 0; j < c.size(); ++j) {
      const float d2 = ced::squared_distance(c.position(j), p);
      if (d2 < ced::squared_radius(0.05)) want.push_back(static_cast<std::uint32_t>(j));
      if (j != i) nearest = std::min(nearest, std::sqrt(d2));
    }
    index.radius_search(p, 0.05, got);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, want) << i;
    EXPECT_FLOAT_EQ(index.nearest_other_distance(static_cast<std::uint32_t>(i)), nearest) << i;
    const float lo[3] = {p[0] - 0.3f, p[1] - 0.3f, p[2] - 0.3f}, hi[3] = {p[0] + 0.3f, p[1] + 0.3f, p[2] + 0.3f};
    index.box_search(lo, hi, got);
    index2.box_search(lo, hi, got2);
    EXPECT_EQ(got, got2) << "the same points in the same order on 1 and 2 threads";
    std::sort(got.begin(), got.end());
    want.clear();
    for (std::size_t j = 0; j < c.size(); ++j) {
      const float* q = c.position(j);
      if (q[0] >= lo[0] && q[0] <= hi[0] && q[1] >= lo[1] && q[1] <= hi[1] && q[2] >= lo[2] && q[2] <= hi[2])
        want.push_back(static_cast<std::uint32_t>(j));
    }
    EXPECT_EQ(got, want) << i;
  }
}
