// SPDX-License-Identifier: MIT
// detect_params::max_keypoints and ced::strongest(): the N keypoints with the
// highest score (the product of the saliencies), ties to the smaller index.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "ced/ced.hpp"
#include "test_support.hpp"

using ced_test::make_room;
using ced_test::twin_rooms;

namespace {

/// The reference: every keypoint of `all`, sorted by (score desc, index asc), the first n, ascending.
std::vector<std::uint32_t> top_by_sorting(const ced::detection_result& all, std::size_t n) {
  std::vector<std::uint32_t> k = all.keypoints;
  std::stable_sort(k.begin(), k.end(), [&](std::uint32_t a, std::uint32_t b) {
    const float sa = ced::keypoint_score(all, a), sb = ced::keypoint_score(all, b);
    return sa != sb ? sa > sb : a < b;
  });
  k.resize(std::min(n, k.size()));
  std::sort(k.begin(), k.end());
  return k;
}

}  // namespace

TEST(Strongest, HighestScoresTiesToTheSmallerIndexAscending) {
  const std::vector<std::uint32_t> kp = {40, 10, 30, 20, 50};
  const std::vector<float> score = {1.0f, 2.0f, 2.0f, 0.5f, 3.0f};
  EXPECT_EQ(ced::strongest(kp, score, 1), (std::vector<std::uint32_t>{50}));
  EXPECT_EQ(ced::strongest(kp, score, 2), (std::vector<std::uint32_t>{10, 50}));  // 10 beats 30 at 2.0
  EXPECT_EQ(ced::strongest(kp, score, 3), (std::vector<std::uint32_t>{10, 30, 50}));
  EXPECT_EQ(ced::strongest(kp, score, 4), (std::vector<std::uint32_t>{10, 30, 40, 50}));
  // 0 or at least their number: all of them, ascending.
  EXPECT_EQ(ced::strongest(kp, score, 0), (std::vector<std::uint32_t>{10, 20, 30, 40, 50}));
  EXPECT_EQ(ced::strongest(kp, score, 99), (std::vector<std::uint32_t>{10, 20, 30, 40, 50}));
}

TEST(Strongest, NanScoresRankLowestInfinityHighest) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<std::uint32_t> kp = {1, 2, 3, 4};
  const std::vector<float> score = {nan, 0.0f, inf, nan};
  EXPECT_EQ(ced::strongest(kp, score, 1), (std::vector<std::uint32_t>{3}));
  EXPECT_EQ(ced::strongest(kp, score, 2), (std::vector<std::uint32_t>{2, 3}));
  EXPECT_EQ(ced::strongest(kp, score, 3), (std::vector<std::uint32_t>{1, 2, 3}));  // NaNs: the smaller index
}

TEST(Strongest, OneScorePerKeypoint) {
  EXPECT_THROW(ced::strongest({1, 2, 3}, {1.0f, 2.0f}, 1), std::invalid_argument);
}

TEST(MaxKeypoints, KeepsTheStrongestOfTheFullResult) {
  const auto c = make_room(20000, 21);
  ced::detect_params p;
  const auto all = ced::detect(c, p, ced::preset("ced6d"));
  ASSERT_GT(all.keypoints.size(), 40u);
  for (std::size_t n : {std::size_t(1), std::size_t(7), std::size_t(32), all.keypoints.size() - 1}) {
    p.max_keypoints = n;
    const auto r = ced::detect(c, p, ced::preset("ced6d"));
    EXPECT_EQ(r.keypoints.size(), n);
    EXPECT_EQ(r.keypoints, top_by_sorting(all, n)) << n;
    EXPECT_EQ(r.saliency, all.saliency);  // only the keypoints change
    EXPECT_EQ(r.candidate, all.candidate);
  }
  p.max_keypoints = all.keypoints.size();  // as many as there are, or more: all of them
  EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, all.keypoints);
  p.max_keypoints = all.keypoints.size() + 1000;
  EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, all.keypoints);
}

TEST(MaxKeypoints, SameForAnyThreadCountAndBothCompositions) {
  const auto c = make_room(20000, 22);
  ced::detect_params p;
  p.max_keypoints = 25;
  p.threads = 1;
  const auto ref = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{0.1});
  ASSERT_EQ(ref.keypoints.size(), 25u);
  for (unsigned t : {2u, 3u, 8u}) {
    p.threads = t;
    EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, ref.keypoints) << t << " threads";
  }
}

// With refinement a keypoint ranks by the maximum it stands for: the highest
// score of the NMS maxima refined onto it. The oracle refines the plain
// run's maxima by the definition (ALGORITHM.md step 7), brute force.
TEST(MaxKeypoints, RefinedKeypointsRankByTheirMaximum) {
  const auto c = make_room(4000, 23);
  ced::detect_params p;
  const auto mods = ced::preset("robust6d");
  const auto plain = ced::detect(c, p, mods);  // the NMS maxima
  const auto ball = ced_test::brute_neighbors(c, p.nms_radius);
  std::vector<float> score(c.size());
  for (std::uint32_t i = 0; i < c.size(); ++i) score[i] = ced::keypoint_score(plain, i);
  std::map<std::uint32_t, float> rank;  // refined point -> the strongest maximum moved to it
  for (std::uint32_t k : plain.keypoints) {
    const std::uint32_t best = ced_test::refined_point(c, ball[k], score, k);
    const auto at = rank.find(best);
    if (at == rank.end() || score[k] > at->second) rank[best] = score[k];
  }
  p.refine = true;
  const auto all = ced::detect(c, p, mods);
  ASSERT_EQ(all.keypoints.size(), rank.size());
  ASSERT_EQ(all.rank_score.size(), all.keypoints.size());
  std::size_t below_own = 0;  // refined keypoints whose own score is lower than their rank
  for (std::size_t q = 0; q < all.keypoints.size(); ++q) {
    ASSERT_EQ(rank.count(all.keypoints[q]), 1u) << all.keypoints[q];
    EXPECT_EQ(all.rank_score[q], rank[all.keypoints[q]]) << all.keypoints[q];
    below_own += ced::keypoint_score(all, all.keypoints[q]) < all.rank_score[q];
  }
  ASSERT_GT(below_own, all.keypoints.size() / 4) << "the test would not tell the ranks from the own scores";
  // The n strongest by those ranks, ties to the smaller index.
  std::vector<std::uint32_t> order = all.keypoints;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return rank[a] != rank[b] ? rank[a] > rank[b] : a < b; });
  for (std::size_t n : {std::size_t(1), std::size_t(10), all.keypoints.size() / 2}) {
    p.max_keypoints = n;
    const auto r = ced::detect(c, p, mods);
    std::vector<std::uint32_t> expected(order.begin(), order.begin() + std::ptrdiff_t(n));
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(r.keypoints, expected) << n;
    ASSERT_EQ(r.rank_score.size(), n);
    for (std::size_t q = 0; q < n; ++q) EXPECT_EQ(r.rank_score[q], rank[r.keypoints[q]]);
  }
}

TEST(MaxKeypoints, UnrefinedKeypointsRankByTheirOwnScore) {
  const auto c = make_room(20000, 30);
  ced::detect_params p;
  p.max_keypoints = 15;
  const auto r = ced::detect(c, p, ced::preset("ced6d"));
  ASSERT_EQ(r.rank_score.size(), r.keypoints.size());
  for (std::size_t q = 0; q < r.keypoints.size(); ++q)
    EXPECT_EQ(r.rank_score[q], ced::keypoint_score(r, r.keypoints[q]));
}

// ced::detect_tiled (in memory) applies the limits to all tiles' keypoints,
// as the whole run does, not to each tile's.
TEST(MaxKeypoints, InMemoryTilesKeepTheWholeRunsStrongest) {
  const auto c = make_room(12000, 31);
  for (const char* preset : {"ced6d", "robust6d"}) {
    ced::detect_params p;
    p.refine = ced::preset_refines(preset);
    const auto mods = ced::preset(preset);
    const auto full = ced::detect(c, p, mods);
    const std::size_t all = full.keypoints.size();
    ASSERT_GT(all, 30u) << preset;
    for (std::size_t n : {std::size_t(7), all / 2}) {
      p.max_keypoints = n;
      const auto whole = ced::detect(c, p, mods).keypoints;
      ASSERT_EQ(whole.size(), n);
      EXPECT_EQ(ced::detect_tiled(c, p, mods, 0.4), whole) << preset << ", max_keypoints " << n;
    }
    p.max_keypoints = 0;
    p.keypoint_share = 0.5 * double(all) / double(ced::candidate_count(full));  // half the keypoints
    const auto whole = ced::detect(c, p, mods).keypoints;
    ASSERT_LT(whole.size(), all) << preset;
    EXPECT_EQ(ced::detect_tiled(c, p, mods, 0.4), whole) << preset << ", keypoint_share " << p.keypoint_share;
  }
}

TEST(MaxKeypoints, ExactTiesGoToTheSmallerIndex) {
  const std::size_t n = 6000;
  const auto c = twin_rooms(n, 24);
  ced::detect_params p;
  const auto all = ced::detect(c, p, ced::preset("ced6d"));
  ASSERT_GT(all.keypoints.size(), 40u);
  // The twins tie: each keypoint of the first copy has its twin, with the same score.
  std::size_t ties = 0;
  for (std::uint32_t k : all.keypoints)
    if (k < n && std::binary_search(all.keypoints.begin(), all.keypoints.end(), k + std::uint32_t(n)))
      ties += ced::keypoint_score(all, k) == ced::keypoint_score(all, k + std::uint32_t(n));
  ASSERT_GT(ties, 20u);
  // An odd count splits a tied pair: the first copy's point is kept.
  for (std::size_t limit : {std::size_t(1), std::size_t(9), all.keypoints.size() / 2 + 1}) {
    p.max_keypoints = limit;
    const auto r = ced::detect(c, p, ced::preset("ced6d"));
    EXPECT_EQ(r.keypoints, top_by_sorting(all, limit)) << limit;
    EXPECT_LT(r.keypoints.front(), n) << limit;
  }
}

// detect_params::keypoint_share: the ceil(share x candidates) strongest, as
// max_keypoints would keep that many; with both, the smaller limit.
TEST(KeypointShare, KeepsTheStrongestShareOfTheCandidates) {
  const auto c = make_room(20000, 26);
  ced::detect_params p;
  const auto all = ced::detect(c, p, ced::preset("ced6d"));
  const auto candidates =
      static_cast<std::size_t>(std::count_if(all.candidate.begin(), all.candidate.end(), [](auto v) { return v; }));
  ASSERT_GT(all.keypoints.size(), 40u);
  ASSERT_GT(candidates, 10 * all.keypoints.size());
  const double per_keypoint = double(all.keypoints.size()) / double(candidates);
  for (double share : {0.5 / double(candidates), 0.2 * per_keypoint, 0.5 * per_keypoint, 0.99 * per_keypoint}) {
    p.keypoint_share = share;
    const std::size_t n = static_cast<std::size_t>(std::ceil(share * double(candidates)));
    ASSERT_LT(n, all.keypoints.size()) << share;
    const auto r = ced::detect(c, p, ced::preset("ced6d"));
    EXPECT_EQ(r.keypoints, top_by_sorting(all, n)) << share;
    EXPECT_EQ(r.candidate, all.candidate);
    EXPECT_EQ(ced::keypoint_limit(p, candidates), n);
    p.max_keypoints = std::max<std::size_t>(1, n / 2);  // the smaller limit holds, whichever it is
    EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, top_by_sorting(all, p.max_keypoints)) << share;
    p.max_keypoints = n + 5;
    EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, top_by_sorting(all, n)) << share;
    p.max_keypoints = 0;
  }
  p.keypoint_share = 1;  // more than there are keypoints: all of them
  EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, all.keypoints);
  p.keypoint_share = 0;
  EXPECT_EQ(ced::detect(c, p, ced::preset("ced6d")).keypoints, all.keypoints);
}

TEST(KeypointShare, LimitRoundsUpAndNeverMeansNone) {
  ced::detect_params p;
  EXPECT_EQ(ced::keypoint_limit(p, 1000), 0u);  // nothing set: no limit
  p.keypoint_share = 0.05;
  EXPECT_EQ(ced::keypoint_limit(p, 1000), 50u);
  EXPECT_EQ(ced::keypoint_limit(p, 1001), 51u);
  EXPECT_EQ(ced::keypoint_limit(p, 1480), 74u);  // 0.05 x 1480 rounds to exactly 74 in double
  EXPECT_EQ(ced::keypoint_limit(p, 0), 1u);      // a share of nothing keeps at most one, not "no limit"
  p.max_keypoints = 10;
  EXPECT_EQ(ced::keypoint_limit(p, 1000), 10u);
  p.max_keypoints = 100;
  EXPECT_EQ(ced::keypoint_limit(p, 1000), 50u);
  p.keypoint_share = 1;
  EXPECT_EQ(ced::keypoint_limit(p, std::uint64_t(1) << 40), 100u);
}

TEST(KeypointShare, OutOfRangeIsRefused) {
  const auto c = make_room(2000, 27);
  for (double bad : {-0.1, 1.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
    ced::detect_params p;
    p.keypoint_share = bad;
    EXPECT_THROW(ced::validate(p), std::invalid_argument) << bad;
    EXPECT_THROW(ced::detect(c, p, ced::preset("ced3d")), std::invalid_argument) << bad;
  }
}

TEST(KeypointShare, TheRobustPresetsShareAndAnyThreadCount) {
  for (const char* robust : {"robust3d", "robust6d"}) EXPECT_EQ(ced::preset_keypoint_share(robust), 0.01);
  for (const char* other : {"ced3d", "ced6d"}) EXPECT_EQ(ced::preset_keypoint_share(other), 0.0);
  EXPECT_THROW(ced::preset_keypoint_share("robust9d"), std::invalid_argument);
  // Same for any thread count.
  const auto c = make_room(20000, 28);
  ced::detect_params p;
  p.refine = true;
  p.keypoint_share = 0.01;
  p.threads = 1;
  const auto ref = ced::detect(c, p, ced::preset("robust3d"));
  p.threads = 3;
  EXPECT_EQ(ced::detect(c, p, ced::preset("robust3d")).keypoints, ref.keypoints);
}
