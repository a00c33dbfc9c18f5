// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <vector>

#include "core/block_partition.hpp"
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
