// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "ced/preprocess.hpp"
#include "core/block_partition.hpp"
#include "core/neighbor_index.hpp"
#include "test_support.hpp"

namespace {
/// box_search() gives the points inside [lo, hi] (brute force), and with
/// positions the same points in the same order, each with its own position
/// (bitwise).
void expect_box_search(const ced::neighbor_index& index, const ced::point_cloud& c, const float lo[3],
                       const float hi[3]) {
  std::vector<std::uint32_t> got;
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
}
}  // namespace

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
    expect_box_search(index, c, lo, hi);
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

namespace {
/// A room with coincident points as real scans have them (#57): each fifth
/// point twice (a light duplicate), groups of 40 to 340 points at one place
/// (heavier than a tree's bucket) and 3,000 invalid returns at the origin,
/// +0 and -0 mixed; then shuffled, so that no group is a run of indices.
ced::point_cloud crowded_room(std::size_t n, std::uint32_t seed) {
  const auto base = ced_test::make_room(n, seed);
  std::vector<std::array<float, 3>> p;
  for (std::size_t i = 0; i < base.size(); ++i) {
    const float* q = base.position(i);
    p.push_back({q[0], q[1], q[2]});
    if (i % 5 == 0) p.push_back({q[0], q[1], q[2]});
    if (i % 97 == 0)
      for (std::size_t k = 0; k < 40 + i % 300; ++k) p.push_back({q[0], q[1], q[2]});
  }
  for (int k = 0; k < 3000; ++k) p.push_back({k % 2 ? -0.0f : 0.0f, k % 3 ? 0.0f : -0.0f, 0.0f});
  std::shuffle(p.begin(), p.end(), std::mt19937(seed));
  ced::point_cloud c;
  for (const auto& q : p) c.push_back(q[0], q[1], q[2]);
  return c;
}

/// The k nearest by brute force: i first, then by distance and index.
std::vector<std::uint32_t> brute_k_nearest(const ced::point_cloud& c, std::uint32_t i, std::size_t k) {
  std::vector<std::pair<float, std::uint32_t>> all;
  for (std::size_t j = 0; j < c.size(); ++j)
    if (j != i) all.push_back({ced::squared_distance(c.position(i), c.position(j)), std::uint32_t(j)});
  std::sort(all.begin(), all.end());
  std::vector<std::uint32_t> out{i};
  for (std::size_t t = 0; out.size() < k && t < all.size(); ++t) out.push_back(all[t].second);
  return out;
}
}  // namespace

TEST(NeighborIndex, CoincidentPointsMatchBruteForce) {
  const auto c = crowded_room(1500, 11);
  ASSERT_GT(c.size(), 7000u);
  const ced::block_partition blocks(c.positions().data(), c.size(), 0.03, 1);
  for (const std::uint32_t* order : {static_cast<const std::uint32_t*>(nullptr), blocks.order().data()})
    for (unsigned bucket : {8u, 32u}) {
      const ced::neighbor_index index(c.positions().data(), c.size(), bucket, 1, order);
      std::vector<std::uint32_t> got;
      std::vector<ced::neighbor_index::ranked_point> ranked;
      std::size_t shortcuts = 0;
      for (std::size_t i = 0; i < c.size(); i += 37) {
        const auto self = static_cast<std::uint32_t>(i);
        const float* p = c.position(i);
        for (double r : {0.0, 0.004, 0.03}) {
          std::vector<std::uint32_t> want;
          for (std::size_t j = 0; j < c.size(); ++j)
            if (ced::squared_distance(c.position(j), p) < ced::squared_radius(r)) want.push_back(std::uint32_t(j));
          index.radius_search(p, r, got);
          std::sort(got.begin(), got.end());
          ASSERT_EQ(got, want) << "r=" << r << " i=" << i << " bucket " << bucket;
        }
        float other = INFINITY, distinct = INFINITY;
        for (std::size_t j = 0; j < c.size(); ++j) {
          const float d = std::sqrt(ced::squared_distance(c.position(j), p));
          if (j != i) other = std::min(other, d);
          if (d > 0) distinct = std::min(distinct, d);
        }
        EXPECT_EQ(index.nearest_other_distance(self), other) << i;
        EXPECT_EQ(index.nearest_distinct_distance(self), distinct) << i;
        const std::vector<std::uint32_t> nearest = brute_k_nearest(c, self, 400);
        for (std::size_t k : {1u, 5u, 40u, 400u}) {
          index.k_nearest(p, k, self, ranked,
                          order ? std::size_t(std::find(order, order + c.size(), self) - order) : SIZE_MAX);
          std::vector<std::uint32_t> ids;
          for (const auto& q : ranked) ids.push_back(q.index);
          ASSERT_EQ(ids, std::vector<std::uint32_t>(nearest.begin(), nearest.begin() + std::ptrdiff_t(k)))
              << "k=" << k << " i=" << i << " bucket " << bucket;
          // The shortcut of knn's pass for a point among k coincident ones.
          std::vector<ced::neighbor_index::ranked_point> same(k);
          if (index.coincident_nearest(self, k, same.data())) {
            ++shortcuts;
            for (std::size_t t = 0; t < k; ++t) {
              EXPECT_EQ(same[t].index, ids[t]) << "k=" << k << " i=" << i;
              EXPECT_EQ(same[t].d2, 0.0f);
            }
          }
        }
        const float lo[3] = {p[0] - 0.01f, p[1] - 0.01f, p[2] - 0.01f}, hi[3] = {p[0], p[1] + 0.01f, p[2] + 0.02f};
        expect_box_search(index, c, lo, hi);
      }
      EXPECT_GT(shortcuts, 100u) << "points of coincident groups were sampled";
    }
}

TEST(NeighborIndex, FiftyThousandPointsAtOnePlace) {
  // Invalid LiDAR returns stored at (0, 0, 0): a degenerate tree recursed
  // once a point and crashed (SIGSEGV) `ced info` and `--radius auto`.
  ced::point_cloud c;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 60000; ++i)
    if (i % 6 == 0)
      c.push_back(u(rng) * 10, u(rng) * 10, u(rng));
    else
      c.push_back(0, 0, 0);
  const ced::neighbor_index index(c.positions().data(), c.size(), 32);
  std::vector<std::uint32_t> got;
  index.radius_search(c.position(1), 0.001, got);
  EXPECT_EQ(got.size(), 50000u);
  {  // A forest over a block order, on two threads: the same points
    const ced::block_partition blocks(c.positions().data(), c.size(), 0.5, 1);
    const ced::neighbor_index forest(c.positions().data(), c.size(), 32, 2, blocks.order().data());
    std::vector<std::uint32_t> all;
    forest.radius_search(c.position(1), 0.001, all);
    std::sort(got.begin(), got.end());
    std::sort(all.begin(), all.end());
    EXPECT_EQ(all, got);
  }
  EXPECT_EQ(index.nearest_other_distance(1), 0.0f);
  std::vector<ced::neighbor_index::ranked_point> ranked;
  index.k_nearest(c.position(7), 8, 7, ranked);
  ASSERT_EQ(ranked.size(), 8u);
  EXPECT_EQ(ranked[0].index, 7u);
  EXPECT_EQ(ranked[1].index, 1u);  // ties by index
  EXPECT_EQ(ranked[7].index, 9u);
  // The spread points' spacing, as if the origin's were not there.
  ced::point_cloud spread;
  for (std::size_t i = 0; i < c.size(); i += 6) spread.push_back(c.position(i)[0], c.position(i)[1], c.position(i)[2]);
  const double res = ced::estimate_resolution(c);
  EXPECT_GT(res, 0.0);
  EXPECT_NEAR(res, ced::estimate_resolution(spread), 0.25 * res);
}

TEST(NeighborIndex, ResolutionOfPointsStoredThrice) {
  // Each point three times: every nearest other point is a twin at 0, so the
  // resolution is the distinct positions' spacing (it was 0: "fewer than two
  // distinct points").
  const auto once = ced_test::make_room(1000, 3);
  ced::point_cloud thrice;
  for (int copy = 0; copy < 3; ++copy)
    for (std::size_t i = 0; i < once.size(); ++i)
      thrice.push_back(once.position(i)[0], once.position(i)[1], once.position(i)[2]);
  const double res = ced::estimate_resolution(thrice);
  std::vector<float> d;
  for (std::size_t i = 0; i < thrice.size(); ++i) {
    float best = INFINITY;
    for (std::size_t j = 0; j < thrice.size(); ++j) {
      const float e = std::sqrt(ced::squared_distance(thrice.position(i), thrice.position(j)));
      if (e > 0) best = std::min(best, e);
    }
    d.push_back(best);
  }
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() / 2), d.end());
  EXPECT_EQ(res, double(d[d.size() / 2]));
}
