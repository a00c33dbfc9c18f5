// SPDX-License-Identifier: MIT
// Keypoint refinement (detect_params::refine): a hand-computed case, a
// brute-force oracle on random clouds, thread-count invariance, exact tiles,
// and the presets that use it.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "test_support.hpp"

namespace {

std::vector<ced::any_modality> specs(const std::vector<std::string>& s) {
  std::vector<ced::any_modality> out;
  for (const auto& x : s) out.push_back(ced::make_modality(x));
  return out;
}

ced::point_cloud cloud_of(const std::vector<std::array<float, 3>>& p) {
  ced::point_cloud c;
  for (const auto& q : p) c.push_back(q[0], q[1], q[2]);
  return c;
}

/// The definition, literally: for each NMS keypoint k, the points within
/// nms_radius (strict, k included), their centroid weighted by the NMS score
/// (the float product of the saliencies, in modality order; the plain
/// centroid when every weight is 0), and the point of the ball nearest to it
/// (ties: the smaller index). Each point once, ascending.
std::vector<std::uint32_t> brute_refine(const ced::point_cloud& c, const ced::detection_result& r, double nms_radius) {
  const auto ball = ced_test::brute_neighbors(c, nms_radius);
  std::vector<float> score(c.size(), 1.0f);
  for (std::size_t i = 0; i < c.size(); ++i) {
    score[i] = r.saliency[0][i];
    for (std::size_t m = 1; m < r.saliency.size(); ++m) score[i] *= r.saliency[m][i];
  }
  std::vector<std::uint32_t> out;
  for (std::uint32_t k : r.keypoints) out.push_back(ced_test::refined_point(c, ball[k], score, k));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace

// An L of eight points, 1 cm apart (in cm): (0..5, 0) then (5, 1), (5, 2).
// radius = nms_radius = 2.25 cm, xyz:0.1 (threshold 0.225 cm), no gate.
// Point 7 = (5, 2) has the neighbours 4 (4, 0) [√5 = 2.236 < 2.25], 5, 6 and
// itself: centroid (4.75, 0.75), saliency |(0.25, 1.25)| = 1.2748 cm, the
// largest; point 0's neighbours 0, 1, 2 give 1 cm. The NMS keeps 0 and 7.
// Refined, 7's ball {4, 5, 6, 7} has the saliencies 0.5, 0.8485, 0.7211,
// 1.2748: the weighted centroid is (4.8505, 0.9780), nearest to point 6
// (5, 1). 0's ball {0, 1, 2} weighs 1, 0.5, 0: centroid (0.333, 0), still
// nearest to point 0.
TEST(Refine, HandComputedL) {
  const auto c = cloud_of({{0.00f, 0, 0},
                           {0.01f, 0, 0},
                           {0.02f, 0, 0},
                           {0.03f, 0, 0},
                           {0.04f, 0, 0},
                           {0.05f, 0, 0},
                           {0.05f, 0.01f, 0},
                           {0.05f, 0.02f, 0}});
  ced::detect_params p;
  p.radius = p.nms_radius = 0.0225;
  p.min_neighbors = 1;
  const auto plain = ced::detect(c, p, specs({"xyz:0.1"}));
  EXPECT_NEAR(plain.saliency[0][7], 0.012748, 1e-6);
  EXPECT_NEAR(plain.saliency[0][0], 0.01, 1e-6);
  EXPECT_EQ(plain.keypoints, (std::vector<std::uint32_t>{0, 7}));
  p.refine = true;
  const auto refined = ced::detect(c, p, specs({"xyz:0.1"}));
  EXPECT_EQ(refined.keypoints, (std::vector<std::uint32_t>{0, 6}));
  // Refinement moves keypoints only: the saliencies and candidates are the same.
  EXPECT_EQ(refined.saliency, plain.saliency);
  EXPECT_EQ(refined.candidate, plain.candidate);
}

// Two equal maxima (a tie keeps both) whose balls are the same three points:
// both refine to the middle one, which is then listed once.
TEST(Refine, KeypointsLandingOnOnePointAreKeptOnce) {
  // A symmetric V: the two tips have the same saliency, the middle a smaller one.
  const auto c = cloud_of({{0.00f, 0.01f, 0}, {0.01f, 0, 0}, {0.02f, 0.01f, 0}});
  ced::detect_params p;
  p.radius = p.nms_radius = 0.025;
  p.min_neighbors = 1;
  const auto plain = ced::detect(c, p, specs({"xyz:0.01"}));
  ASSERT_EQ(plain.keypoints, (std::vector<std::uint32_t>{0, 2}));
  p.refine = true;
  EXPECT_EQ(ced::detect(c, p, specs({"xyz:0.01"})).keypoints, (std::vector<std::uint32_t>{1}));
}

TEST(Refine, MatchesTheBruteForceDefinitionOnRandomClouds) {
  std::mt19937 rng(16);
  const std::vector<std::vector<std::string>> sets = {
      {"xyz:0.2"}, {"xyz:0.2", "rgb:0.1"}, {"xyz:0.2,scale=2"}, {"xyz:0.2,scale=3", "rgb:0.5"}};
  std::size_t moved = 0, total = 0;
  for (int trial = 0; trial < 8; ++trial) {
    const auto c =
        ced_test::make_room(1500 + 300 * std::size_t(trial), 40u + unsigned(trial), trial % 2 ? 0.004f : 0.002f);
    ced::detect_params p;
    p.radius = 0.03 + 0.005 * (trial % 3);
    p.nms_radius = trial % 2 ? p.radius : 1.5 * p.radius;
    p.min_neighbors = 3 + unsigned(trial % 4);
    p.threads = 1 + unsigned(rng() % 3);
    const auto& mods = sets[std::size_t(trial) % sets.size()];
    const auto plain = ced::detect(c, p, specs(mods));
    p.refine = true;
    const auto refined = ced::detect(c, p, specs(mods));
    ASSERT_EQ(refined.saliency, plain.saliency) << "trial " << trial;
    const auto expected = brute_refine(c, plain, p.nms_radius);
    EXPECT_EQ(refined.keypoints, expected) << "trial " << trial;
    EXPECT_TRUE(std::is_sorted(refined.keypoints.begin(), refined.keypoints.end()));
    EXPECT_TRUE(std::adjacent_find(refined.keypoints.begin(), refined.keypoints.end()) == refined.keypoints.end());
    std::vector<std::uint32_t> kept;
    std::set_intersection(plain.keypoints.begin(), plain.keypoints.end(), refined.keypoints.begin(),
                          refined.keypoints.end(), std::back_inserter(kept));
    moved += refined.keypoints.size() - kept.size();
    total += refined.keypoints.size();
  }
  // The oracle is not vacuous: most keypoints move on a noisy room.
  EXPECT_GT(moved, total / 4) << moved << " of " << total;
}

TEST(Refine, SameKeypointsForAnyThreadCount) {
  const auto c = ced_test::make_room(20000, 5, 0.004f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.03;
  p.refine = true;
  p.threads = 1;
  const auto mods = specs({"xyz:0.2,scale=3", "rgb:0.5"});
  const auto one = ced::detect(c, p, mods).keypoints;
  ASSERT_FALSE(one.empty());
  for (unsigned t : {2u, 3u, 8u}) {
    p.threads = t;
    EXPECT_EQ(ced::detect(c, p, mods).keypoints, one) << t << " threads";
  }
}

TEST(Refine, TilesAreExact) {
  std::mt19937 rng(2027);
  for (int trial = 0; trial < 5; ++trial) {
    const auto c = ced_test::make_room(6000 + 1000 * std::size_t(trial), 200u + unsigned(trial), 0.004f);
    ced::detect_params p;
    p.radius = 0.03;
    p.nms_radius = trial % 2 ? p.radius : 2 * p.radius;
    // Small blocks too: the halo then has little slack beyond its terms.
    p.block_scale = trial < 3 ? 0.5 : 6.0;
    p.refine = true;
    const double tile = std::uniform_real_distribution<double>(0.04, 0.3)(rng);
    for (const auto& mods :
         {std::vector<std::string>{"xyz:0.2,scale=2"}, std::vector<std::string>{"xyz:0.2,scale=3", "rgb:0.5"}}) {
      const auto m = specs(mods);
      const auto whole = ced::detect(c, p, m).keypoints;
      EXPECT_EQ(ced::detect_tiled(c, p, m, tile), whole) << "trial " << trial << ", tile " << tile;
    }
  }
}

// A refined keypoint in a core may come from a maximum up to nms_radius
// outside it. Refinement moves keypoints about a centimetre on these clouds,
// so TilesAreExact passes even with the halo of plain detection: this test
// is what holds the bound.
TEST(Refine, HaloGrowsByTheNmsRadius) {
  ced::detect_params p;
  const double plain = ced::exact_halo(p);
  p.refine = true;
  EXPECT_NEAR(ced::exact_halo(p) - plain, 1.01 * p.nms_radius, 1e-12);
}

TEST(Refine, RobustPresetsRefineAndThePapersDoNot) {
  EXPECT_FALSE(ced::preset_refines("ced3d"));
  EXPECT_FALSE(ced::preset_refines("ced6d"));
  EXPECT_TRUE(ced::preset_refines("robust3d"));
  EXPECT_TRUE(ced::preset_refines("robust6d"));
  EXPECT_THROW(ced::preset_refines("robust9d"), std::invalid_argument);
}
