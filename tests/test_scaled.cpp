// SPDX-License-Identifier: MIT
// Modalities at another scale (ced/scaled.hpp, spec option scale=K) and the
// robust presets: a hand-computed case, an O(N^2) oracle on random clouds,
// thread-count invariance, tiles, specs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
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

/// xyz:0.2,scale=K + rgb:TC by its definition, with brute-force neighbours.
ced_test::oracle_result robust6d_oracle(const ced::point_cloud& c, double r, std::uint32_t k, double scale, double tc) {
  using namespace ced_test;
  const oracle_result at_r = oracle(c, {field_channel(c, {"red", "green", "blue"}, 255, tc)}, r, r, k);
  const oracle_result at_2r = oracle(c, {xyz_channel(c, 0.2, scale * r)}, scale * r, scale * r, k);
  oracle_result out;
  out.neighbor_count = at_r.neighbor_count;
  const std::size_t n = c.size();
  out.saliency.assign(2, std::vector<double>(n, 0.0));
  for (std::size_t i = 0; i < n; ++i) {
    if (at_r.neighbor_count[i] < k) continue;  // the detection's gate stays at r
    out.saliency[0][i] = at_2r.saliency[0][i];
    out.saliency[1][i] = at_r.saliency[0][i];
  }
  out.candidate.assign(n, 0);
  std::vector<double> product(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.candidate[i] = out.saliency[0][i] >= 0.2 * scale * r || out.saliency[1][i] >= tc;
    product[i] = out.saliency[0][i] * out.saliency[1][i];
  }
  const auto nms = brute_neighbors(c, r);
  for (std::size_t i = 0; i < n; ++i) {
    if (!out.candidate[i]) continue;
    bool maximum = true;
    for (auto j : nms[i])
      if (product[j] > product[i]) maximum = false;
    if (maximum) out.keypoints.push_back(static_cast<std::uint32_t>(i));
  }
  return out;
}

}  // namespace

TEST(Scaled, HandComputedLine) {
  // Three points 4 cm apart, r = 5 cm: at r, A sees B; at 2r, A sees B and C.
  ced::point_cloud c;
  c.push_back(0, 0, 0);
  c.push_back(0.04f, 0, 0);
  c.push_back(0.08f, 0, 0);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  p.min_neighbors = 1;
  const auto plain = ced::detect(c, p, specs({"xyz:0.2"}));
  const auto twice = ced::detect(c, p, specs({"xyz:0.2,scale=2"}));
  EXPECT_NEAR(plain.saliency[0][0], 0.02, 1e-7);  // mean of A, B: x = 0.02
  EXPECT_NEAR(twice.saliency[0][0], 0.04, 1e-7);  // mean of A, B, C: x = 0.04
  EXPECT_NEAR(twice.saliency[0][1], 0.0, 1e-7);
  EXPECT_NEAR(twice.saliency[0][2], 0.04, 1e-7);
  EXPECT_EQ(twice.names[0], "xyz,scale=2");
  EXPECT_DOUBLE_EQ(twice.thresholds[0], 0.2 * 0.1);  // the ratio of 2r
  // The gate stays at r: with min_neighbors 3, no point has 3 neighbours within r.
  p.min_neighbors = 3;
  const auto gated = ced::detect(c, p, specs({"xyz:0.2,scale=2"}));
  for (float s : gated.saliency[0]) EXPECT_EQ(s, 0.0f);
  // Compile time: the same numbers.
  p.min_neighbors = 1;
  const auto fixed = ced::detect(c, p, ced::scaled<ced::xyz>{ced::xyz(0.2), 2});
  EXPECT_EQ(fixed.saliency[0], twice.saliency[0]);
}

TEST(Scaled, Robust6dMatchesTheOracleOnRandomClouds) {
  // The preset's modalities (xyz at 2.25r, rgb:0.5; the oracle has no
  // refinement, test_refine.cpp checks that), and xyz at 2r with rgb:0.1.
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const ced::point_cloud c = ced_test::make_room(2500, seed, 0.004f);
    ced::detect_params p;
    p.radius = p.nms_radius = 0.07;
    p.threads = 2;
    const bool preset = seed != 2;
    const auto r = ced::detect(c, p, preset ? ced::preset("robust6d") : specs({"xyz:0.2,scale=2", "rgb:0.1"}));
    const auto o = robust6d_oracle(c, p.radius, p.min_neighbors, preset ? 2.25 : 2, preset ? 0.5 : 0.1);
    ASSERT_EQ(r.saliency.size(), 2u);
    for (std::size_t m = 0; m < 2; ++m)
      for (std::size_t i = 0; i < c.size(); ++i)
        ASSERT_NEAR(r.saliency[m][i], o.saliency[m][i], 1e-5 * (1 + o.saliency[m][i]))
            << "seed " << seed << ", modality " << m << ", point " << i;
    EXPECT_EQ(r.keypoints, o.keypoints) << "seed " << seed;
    EXPECT_GE(r.keypoints.size(), 3u);
  }
}

TEST(Scaled, SameResultForAnyThreadCount) {
  const ced::point_cloud c = ced_test::make_room(6000, 4, 0.003f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  p.threads = 1;
  const auto one = ced::detect(c, p, ced::preset("robust6d"));
  for (unsigned t : {2u, 3u, 8u}) {
    p.threads = t;
    const auto other = ced::detect(c, p, ced::preset("robust6d"));
    EXPECT_EQ(other.saliency, one.saliency) << t << " threads";
    EXPECT_EQ(other.keypoints, one.keypoints) << t << " threads";
  }
}

TEST(Scaled, TilesStayExact) {
  // The halo grows with the largest scale: tiles still give the whole result.
  const ced::point_cloud c = ced_test::make_room(6000, 5, 0.003f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.04;
  const auto m = specs({"xyz:0.2,scale=2", "rgb:0.1,scale=1.5"});
  const auto whole = ced::detect(c, p, m).keypoints;
  ASSERT_GT(whole.size(), 5u);
  for (double tile : {0.3, 0.17}) EXPECT_EQ(ced::detect_tiled(c, p, m, tile), whole) << "tile " << tile;
  EXPECT_DOUBLE_EQ(ced::max_scale_factor(m), 2.0);
  // A scale that reads past a halo made for the radius alone.
  const auto far = specs({"xyz:0.1,scale=16"});
  p.radius = p.nms_radius = 0.02;
  const auto whole_far = ced::detect(c, p, far).keypoints;
  ASSERT_GT(whole_far.size(), 5u);
  for (double tile : {0.3, 0.2}) EXPECT_EQ(ced::detect_tiled(c, p, far, tile), whole_far) << "scale 16, tile " << tile;
}

TEST(Scaled, SpecsAndPresets) {
  EXPECT_EQ(ced::make_modality("rgb:0.1,scale=1.5").name(), "rgb,scale=1.5");
  EXPECT_EQ(ced::make_modality("bands(red,green):0.1,range=0..255,scale=3").name(), "bands(red,green),scale=3");
  for (const char* bad :
       {"xyz:0.2,scale=0", "xyz:0.2,scale=-1", "xyz:0.2,scale=nan", "xyz:0.2,scale=17", "xyz:0.2,scale=two"})
    EXPECT_THROW(ced::make_modality(bad), std::invalid_argument) << bad;
  const auto names = ced::preset_names();
  for (const char* p : {"robust3d", "robust6d"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), p), names.end()) << p;
    // The preset's specs make the preset's modalities.
    const auto made = specs(ced::preset_specs(p));
    const auto given = ced::preset(p);
    ASSERT_EQ(made.size(), given.size());
    for (std::size_t k = 0; k < made.size(); ++k) EXPECT_EQ(made[k].name(), given[k].name());
  }
}
