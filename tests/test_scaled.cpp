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

/// The centroid shift || mean_{N(K r)} p − mean_{N(J r)} p || of every point
/// by brute force (0 with fewer than k neighbours at either scale).
std::vector<double> centroid_shift_oracle(const ced::point_cloud& c, double r, std::uint32_t k, double K, double J) {
  const auto outer = ced_test::brute_neighbors(c, K * r), inner = ced_test::brute_neighbors(c, J * r);
  std::vector<double> s(c.size(), 0.0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (outer[i].size() < k || inner[i].size() < k) continue;
    double d2 = 0;
    for (std::size_t a = 0; a < 3; ++a) {
      double mo = 0, mi = 0;
      for (auto j : outer[i]) mo += c.position(j)[a];
      for (auto j : inner[i]) mi += c.position(j)[a];
      const double d = mo / double(outer[i].size()) - mi / double(inner[i].size());
      d2 += d * d;
    }
    s[i] = std::sqrt(d2);
  }
  return s;
}

/// xyz:0.2,scale=K[,inner=J] + rgb:TC by its definition, with brute-force neighbours.
ced_test::oracle_result robust6d_oracle(const ced::point_cloud& c, double r, std::uint32_t k, double scale, double tc,
                                        double inner = 0) {
  using namespace ced_test;
  const oracle_result at_r = oracle(c, {field_channel(c, {"red", "green", "blue"}, 255, tc)}, r, r, k);
  oracle_result at_2r = oracle(c, {xyz_channel(c, 0.2, scale * r)}, scale * r, scale * r, k);
  if (inner > 0) at_2r.saliency[0] = centroid_shift_oracle(c, r, k, scale, inner);
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

/// A at 0, B at 4 cm, C at 8 cm on the x axis.
ced::point_cloud three_point_line() {
  ced::point_cloud c;
  c.push_back(0, 0, 0);
  c.push_back(0.04f, 0, 0);
  c.push_back(0.08f, 0, 0);
  return c;
}

/// r = 5 cm, every point counted.
ced::detect_params line_params() {
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  p.min_neighbors = 1;
  return p;
}

}  // namespace

TEST(Scaled, HandComputedLine) {
  // Three points 4 cm apart, r = 5 cm: at r, A sees B; at 2r, A sees B and C.
  const ced::point_cloud c = three_point_line();
  ced::detect_params p = line_params();
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
  // The preset's modalities (the centroid shift between r and 2.25r, rgb:0.5; the oracle has no
  // refinement, test_refine.cpp checks that), and xyz at 2r with rgb:0.1.
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const ced::point_cloud c = ced_test::make_room(2500, seed, 0.004f);
    ced::detect_params p;
    p.radius = p.nms_radius = 0.07;
    p.threads = 2;
    const bool preset = seed != 2;
    const auto r = ced::detect(c, p, preset ? ced::preset("robust6d") : specs({"xyz:0.2,scale=2", "rgb:0.1"}));
    const auto o = robust6d_oracle(c, p.radius, p.min_neighbors, preset ? 2.25 : 2, preset ? 0.5 : 0.1, preset ? 1 : 0);
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
  // The centroid shift (the robust presets' geometry) reads both scales inside the halo.
  const auto shift = specs({"xyz:0.2,scale=2.25,inner=1", "rgb:0.1"});
  const auto whole_shift = ced::detect(c, p, shift).keypoints;
  ASSERT_GT(whole_shift.size(), 5u);
  for (double tile : {0.3, 0.17})
    EXPECT_EQ(ced::detect_tiled(c, p, shift, tile), whole_shift) << "shift, tile " << tile;
  EXPECT_DOUBLE_EQ(ced::max_scale_factor(shift), 2.25);
  // A scale that reads past a halo made for the radius alone.
  const auto far = specs({"xyz:0.1,scale=16"});
  p.radius = p.nms_radius = 0.02;
  const auto whole_far = ced::detect(c, p, far).keypoints;
  ASSERT_GT(whole_far.size(), 5u);
  for (double tile : {0.3, 0.2}) EXPECT_EQ(ced::detect_tiled(c, p, far, tile), whole_far) << "scale 16, tile " << tile;
}

TEST(Scaled, CentroidShiftHandComputedAndAgainstTheOracle) {
  // A at 0, B at 4 cm, C at 8 cm, r = 5 cm, K = 2, J = 1: A's centroid at r
  // is 2 cm, at 2r 4 cm: a shift of 2 cm; B's: 4 and 4, no shift.
  const ced::point_cloud line = three_point_line();
  ced::detect_params p = line_params();
  const auto shift = ced::detect(line, p, specs({"xyz:0.2,scale=2,inner=1"}));
  EXPECT_EQ(shift.names[0], "xyz,scale=2,inner=1");
  EXPECT_NEAR(shift.saliency[0][0], 0.02, 1e-7);
  EXPECT_NEAR(shift.saliency[0][1], 0.0, 1e-7);
  EXPECT_NEAR(shift.saliency[0][2], 0.02, 1e-7);
  EXPECT_DOUBLE_EQ(shift.thresholds[0], 0.2 * 0.1);  // the ratio of K·r, as scale= alone
  const auto fixed = ced::detect(line, p, ced::scaled<ced::xyz>{ced::xyz(0.2), 2, 1});
  EXPECT_EQ(fixed.saliency[0], shift.saliency[0]);
  // Fewer than min_neighbors at the inner scale: 0.
  p.min_neighbors = 2;
  const auto gated = ced::detect(line, p, specs({"xyz:0.2,scale=2,inner=0.5"}));
  for (float s : gated.saliency[0]) EXPECT_EQ(s, 0.0f);
  // At inner = 1 the inner centroid comes from the detection's own pass: bitwise
  // what two passes of their own give (centroid_shift_of).
  {
    const ced::point_cloud c = ced_test::make_room(3000, 6, 0.004f);
    ced::detect_params q;
    q.radius = q.nms_radius = 0.05;
    const auto m = ced::make_modality("xyz:0.2,scale=2.25,inner=1");
    const auto one_pass = ced::detect(c, q, {m});
    const auto two_passes = ced::centroid_shift_of(c, q, 2.25, 1, ced::make_modality("xyz:0.2"));
    for (std::size_t i = 0; i < c.size(); ++i)
      ASSERT_EQ(one_pass.saliency[0][i], one_pass.neighbor_count[i] < q.min_neighbors ? 0.0f : two_passes[i]) << i;
  }
  // Random clouds, other scales, against brute force.
  for (std::uint32_t seed : {4u, 5u}) {
    const ced::point_cloud c = ced_test::make_room(2000, seed, 0.004f);
    ced::detect_params q;
    q.radius = q.nms_radius = 0.06;
    q.threads = 2;
    const auto r = ced::detect(c, q, specs({"xyz:0.2,scale=2.5,inner=1.5"}));
    const auto o = centroid_shift_oracle(c, q.radius, q.min_neighbors, 2.5, 1.5);
    for (std::size_t i = 0; i < c.size(); ++i) {
      const double want = r.neighbor_count[i] < q.min_neighbors ? 0.0 : o[i];  // the detection's gate at r
      ASSERT_NEAR(r.saliency[0][i], want, 1e-5 * (1 + want)) << "seed " << seed << ", point " << i;
    }
  }
}

TEST(Scaled, SpecsAndPresets) {
  EXPECT_EQ(ced::make_modality("rgb:0.1,scale=1.5").name(), "rgb,scale=1.5");
  EXPECT_EQ(ced::make_modality("bands(red,green):0.1,range=0..255,scale=3").name(), "bands(red,green),scale=3");
  for (const char* bad :
       {"xyz:0.2,scale=0", "xyz:0.2,scale=-1", "xyz:0.2,scale=nan", "xyz:0.2,scale=17", "xyz:0.2,scale=two",
        "xyz:0.2,inner=1", "xyz:0.2,scale=2,inner=2", "xyz:0.2,scale=2,inner=-1", "xyz:0.2,scale=2,inner=nan"})
    EXPECT_THROW(ced::make_modality(bad), std::invalid_argument) << bad;
  // The shift is of positions: another modality is refused when bound.
  const ced::point_cloud room = ced_test::make_room(300, 1);
  ced::detect_params params;
  params.radius = params.nms_radius = 0.05;
  EXPECT_THROW(ced::detect(room, params, specs({"rgb:0.1,scale=2,inner=1"})), std::invalid_argument);
  // The compile-time form takes any numbers: they are checked when it is bound, as a spec's are when parsed.
  EXPECT_THROW(ced::detect(room, params, ced::scaled<ced::xyz>{ced::xyz(0.2), 20}), std::invalid_argument);
  EXPECT_THROW(ced::detect(room, params, ced::scaled<ced::xyz>{ced::xyz(0.2), 2, 2}), std::invalid_argument);
  EXPECT_THROW(ced::detect(room, params, ced::scaled<ced::xyz>{ced::xyz(0.2), 0}), std::invalid_argument);
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
