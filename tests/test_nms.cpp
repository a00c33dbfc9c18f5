// SPDX-License-Identifier: MIT
// The NMS (core/nms.hpp) on its own, against an O(N²) oracle of its
// definition: candidate i is kept when no point j with |p_j - p_i|² <
// nms_radius² (float, strict) has score[j] > score[i].
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "core/block_partition.hpp"
#include "core/neighbor_index.hpp"
#include "core/nms.hpp"

namespace {

using ced::detail::candidate_hits;
using ced::detail::compact_flags;
using ced::detail::non_maximum_suppression;

/// A random cloud with random scores and candidate flags. With `on_grid`,
/// coordinates are multiples of 1/8 (exact in float, as are their squared
/// distances), so many pairs lie exactly at the NMS radius; scores are
/// small integers, so many neighbours tie.
struct nms_case {
  std::vector<float> xyz, score;
  std::vector<std::uint8_t> candidate;
  std::size_t size() const { return score.size(); }
};

nms_case random_case(std::size_t n, std::uint32_t seed, bool on_grid, double candidate_share) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::uniform_int_distribution<int> cell(0, 15), level(0, 6);
  std::bernoulli_distribution is_candidate(candidate_share);
  nms_case c;
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) c.xyz.push_back(on_grid ? cell(rng) * 0.125f : u(rng) * 2.0f);
    c.score.push_back(on_grid ? static_cast<float>(level(rng)) : u(rng));
    c.candidate.push_back(is_candidate(rng) ? 1 : 0);
  }
  return c;
}

/// The definition, literally, over all pairs.
std::vector<std::uint32_t> oracle_nms(const nms_case& c, double nms_radius) {
  const float r2 = static_cast<float>(nms_radius * nms_radius);
  std::vector<std::uint32_t> kept;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!c.candidate[i]) continue;
    bool maximum = true;
    for (std::size_t j = 0; j < c.size() && maximum; ++j) {
      const float dx = c.xyz[3 * j] - c.xyz[3 * i], dy = c.xyz[3 * j + 1] - c.xyz[3 * i + 1],
                  dz = c.xyz[3 * j + 2] - c.xyz[3 * i + 2];
      if (dx * dx + dy * dy + dz * dz < r2 && c.score[j] > c.score[i]) maximum = false;
    }
    if (maximum) kept.push_back(static_cast<std::uint32_t>(i));
  }
  return kept;
}

/// non_maximum_suppression with no stored neighbourhoods (every block queries
/// the block grid), over blocks of side `cell`.
std::vector<std::uint32_t> run_nms(const nms_case& c, double nms_radius, double radius, double cell, unsigned threads) {
  const ced::block_partition blocks(c.xyz.data(), c.size(), cell, threads);
  return non_maximum_suppression(blocks, c.xyz.data(), c.score.data(), c.candidate.data(), nms_radius, radius,
                                 std::vector<candidate_hits>{}, threads);
}

}  // namespace

TEST(Nms, MatchesBruteForceOnRandomClouds) {
  for (const bool on_grid : {false, true})
    for (const std::uint32_t seed : {1u, 2u}) {
      const auto c = random_case(3000, seed, on_grid, 0.5);
      for (const double nms_radius : {0.125, 0.25, 0.3}) {
        const auto want = oracle_nms(c, nms_radius);
        const auto candidates = compact_flags(c.candidate);
        ASSERT_FALSE(want.empty());
        ASSERT_LT(want.size(), candidates.size()) << "fixture too easy: the NMS suppresses nothing";
        // The radius the neighbourhoods were found with does not matter
        // without stored neighbourhoods: smaller, equal and larger.
        for (const double radius : {nms_radius / 2, nms_radius, 2 * nms_radius})
          for (const double cell : {0.1, 0.5})
            for (const unsigned threads : {1u, 2u}) {
              SCOPED_TRACE(testing::Message() << "grid " << on_grid << " seed " << seed << " nms_radius " << nms_radius
                                              << " radius " << radius << " cell " << cell << " threads " << threads);
              EXPECT_EQ(run_nms(c, nms_radius, radius, cell, threads), want);
            }
      }
    }
}

TEST(Nms, HandPlacedCases) {
  // Points on the x axis; nms_radius 0.5, so r² = 0.25 exactly in float.
  auto line = [](const std::vector<float>& x, const std::vector<float>& score,
                 const std::vector<std::uint8_t>& candidate) {
    nms_case c;
    for (float v : x) c.xyz.insert(c.xyz.end(), {v, 0.0f, 0.0f});
    c.score = score;
    c.candidate = candidate;
    return c;
  };
  // A greater neighbour exactly at the radius does not suppress (strict <);
  // just inside it does.
  EXPECT_EQ(run_nms(line({0.0f, 0.5f}, {1, 2}, {1, 1}), 0.5, 0.5, 1.0, 1), (std::vector<std::uint32_t>{0, 1}));
  EXPECT_EQ(run_nms(line({0.0f, 0.4999f}, {1, 2}, {1, 1}), 0.5, 0.5, 1.0, 1), (std::vector<std::uint32_t>{1}));
  // Ties keep both; an equal score never suppresses.
  EXPECT_EQ(run_nms(line({0.0f, 0.1f, 0.2f}, {3, 3, 3}, {1, 1, 1}), 0.5, 0.5, 1.0, 1),
            (std::vector<std::uint32_t>{0, 1, 2}));
  // A non-candidate with a greater score suppresses, but is never kept.
  EXPECT_EQ(run_nms(line({0.0f, 0.1f, 2.0f}, {1, 5, 1}, {1, 0, 1}), 0.5, 0.5, 1.0, 1), (std::vector<std::uint32_t>{2}));
  // Only candidates are kept, however isolated.
  EXPECT_EQ(run_nms(line({0.0f, 1.0f, 2.0f}, {1, 1, 1}, {0, 1, 0}), 0.5, 0.5, 1.0, 1), (std::vector<std::uint32_t>{1}));
  // The NMS radius is used, not the saliency radius: at 0.3 apart, a
  // greater neighbour suppresses with nms_radius 0.5 whatever `radius` says,
  // and not with nms_radius 0.25.
  const auto pair = line({0.0f, 0.3f}, {1, 2}, {1, 1});
  EXPECT_EQ(run_nms(pair, 0.5, 0.25, 1.0, 1), (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(run_nms(pair, 0.25, 0.5, 1.0, 1), (std::vector<std::uint32_t>{0, 1}));
  // Duplicates: the same position, the greater score wins.
  EXPECT_EQ(run_nms(line({1.0f, 1.0f}, {2, 1}, {1, 1}), 0.5, 0.5, 1.0, 1), (std::vector<std::uint32_t>{0}));
  // Neighbours in other blocks count (cells of 0.1 put them apart).
  EXPECT_EQ(run_nms(line({0.0f, 0.35f}, {1, 2}, {1, 1}), 0.5, 0.5, 0.1, 2), (std::vector<std::uint32_t>{1}));
}

TEST(Nms, EmptyAndAllCandidates) {
  nms_case none;
  EXPECT_TRUE(run_nms(none, 0.5, 0.5, 1.0, 1).empty());
  // No candidates: nothing kept, whatever the scores.
  auto c = random_case(500, 9, false, 0.0);
  EXPECT_TRUE(run_nms(c, 0.2, 0.2, 0.3, 2).empty());
  // All candidates, all scores equal: one big tie, everyone kept.
  for (auto& s : c.score) s = 0.5f;
  for (auto& f : c.candidate) f = 1;
  const auto all = run_nms(c, 0.2, 0.2, 0.3, 2);
  ASSERT_EQ(all.size(), c.size());
  for (std::size_t i = 0; i < all.size(); ++i) EXPECT_EQ(all[i], i);
}

TEST(Nms, CompactFlags) {
  EXPECT_TRUE(compact_flags({}).empty());
  EXPECT_TRUE(compact_flags({0, 0, 0}).empty());
  EXPECT_EQ(compact_flags({1}), (std::vector<std::uint32_t>{0}));
  // Any non-zero flag counts; the first and the last index are included.
  EXPECT_EQ(compact_flags({1, 0, 2, 0, 0, 255, 1}), (std::vector<std::uint32_t>{0, 2, 5, 6}));
  std::vector<std::uint8_t> flags(1000, 0);
  std::vector<std::uint32_t> want;
  for (std::uint32_t i = 3; i < flags.size(); i += 7) {
    flags[i] = 1;
    want.push_back(i);
  }
  EXPECT_EQ(compact_flags(flags), want);
}
