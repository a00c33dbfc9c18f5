// SPDX-License-Identifier: MIT
// The corner modality (ced/modalities/corner.hpp): hand-computed cases, an
// O(N^2) oracle on random clouds, thread-count invariance, tiles and specs;
// and any_modality::with_threshold, which the top-N protocol uses.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "test_support.hpp"

namespace {

/// det(M)^(1/3) of a symmetric 3×3 matrix given as xx, yy, zz, xy, xz, yz.
double corner_of(const double m[6]) {
  const double det =
      m[0] * (m[1] * m[2] - m[5] * m[5]) - m[3] * (m[3] * m[2] - m[5] * m[4]) + m[4] * (m[3] * m[5] - m[1] * m[4]);
  return std::cbrt(std::max(0.0, det));
}

/// Points on a 1 cm lattice with the given normals as fields (nx, ny, nz).
ced::point_cloud lattice_with_normals(int side, std::array<double, 3> (*normal_of)(int, int)) {
  ced::point_cloud c;
  std::vector<double> nx, ny, nz;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) {
      c.push_back(0.01f * float(i), 0.01f * float(j), 0.0f);
      const auto n = normal_of(i, j);
      nx.push_back(n[0]), ny.push_back(n[1]), nz.push_back(n[2]);
    }
  c.add_field("nx", ced::scalar_type::float32, nx);
  c.add_field("ny", ced::scalar_type::float32, ny);
  c.add_field("nz", ced::scalar_type::float32, nz);
  return c;
}

}  // namespace

static_assert(ced::is_modality_v<ced::corner>);
static_assert(ced::sums_neighbors_v<ced::evaluator_t<ced::corner>>);

TEST(Corner, HandComputedFromGivenNormals) {
  ced::detect_params p;
  p.radius = p.nms_radius = 0.1;  // every point of a 5×5 lattice sees all 25
  p.min_neighbors = 1;
  // One normal everywhere (a plane): M = n nᵀ has rank 1, det 0.
  const auto plane = lattice_with_normals(5, [](int, int) { return std::array<double, 3>{0, 0, 1}; });
  // Two directions (a crease): rank 2, det 0.
  const auto crease = lattice_with_normals(5, [](int i, int) {
    return std::array<double, 3>{i < 2 ? 1.0 : 0.0, 0, i < 2 ? 0.0 : 1.0};
  });
  // x, y and z in thirds (a corner of three faces, as near as 25 points
  // allow): 8 points along x, 8 along y, 9 along z, so M = diag(8, 8, 9)/25.
  const auto three = lattice_with_normals(5, [](int i, int j) {
    const int k = 5 * i + j;
    return k < 8    ? std::array<double, 3>{1, 0, 0}
           : k < 16 ? std::array<double, 3>{0, 1, 0}
                    : std::array<double, 3>{0, 0, 1};
  });
  // Unnormalised and sign-flipped normals count as the same axes.
  const auto flipped = lattice_with_normals(5, [](int i, int j) {
    const int k = 5 * i + j;
    return k < 8    ? std::array<double, 3>{-3, 0, 0}
           : k < 16 ? std::array<double, 3>{0, 2, 0}
                    : std::array<double, 3>{0, 0, -0.5};
  });
  const auto s = [&](const ced::point_cloud& c) { return ced::detect(c, p, ced::corner(0.01)).saliency[0]; };
  for (float v : s(plane)) EXPECT_NEAR(v, 0.0f, 1e-6f);
  for (float v : s(crease)) EXPECT_NEAR(v, 0.0f, 1e-6f);
  const double expected = std::cbrt(8.0 * 8.0 * 9.0) / 25.0;
  for (float v : s(three)) EXPECT_NEAR(v, expected, 1e-6);
  EXPECT_EQ(s(flipped), s(three));
}

TEST(Corner, MatchesTheOracleOnRandomClouds) {
  for (std::uint32_t seed : {1u, 2u}) {
    const ced::point_cloud c = ced_test::make_room(2000, seed, 0.003f);
    const double r = 0.06, k = seed == 1 ? 1.0 : 0.5;
    ced::detect_params p;
    p.radius = p.nms_radius = r;
    p.threads = 2;
    const std::string spec = seed == 1 ? "corner:0.02" : "corner:0.02,radius=0.5";
    const auto got = ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality(spec)});
    // The normals are estimate_normals' (its own oracle is in test_normals);
    // the mean of their tensors over each brute-force neighbourhood, its
    // determinant and the NMS are recomputed here.
    const auto normals = ced::estimate_normals(c, k * r, 1);
    const auto nb = ced_test::brute_neighbors(c, r);
    std::vector<float> want(c.size(), 0.0f);
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (nb[i].size() < p.min_neighbors) continue;
      double m[6] = {0, 0, 0, 0, 0, 0};
      for (auto j : nb[i]) {
        const float* n = normals.data() + 3 * j;
        const double len2 = double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2];
        if (len2 == 0) continue;
        const double x = n[0] / std::sqrt(len2), y = n[1] / std::sqrt(len2), z = n[2] / std::sqrt(len2);
        m[0] += x * x, m[1] += y * y, m[2] += z * z, m[3] += x * y, m[4] += x * z, m[5] += y * z;
      }
      for (double& v : m) v /= double(nb[i].size());
      want[i] = static_cast<float>(corner_of(m));
    }
    for (std::size_t i = 0; i < c.size(); ++i)
      ASSERT_NEAR(got.saliency[0][i], want[i], 2e-5) << "seed " << seed << ", point " << i;
    // NMS by its definition, on the detector's own saliencies.
    std::vector<std::uint32_t> keypoints;
    for (std::uint32_t i = 0; i < c.size(); ++i) {
      const float si = got.saliency[0][i];
      if (!(si >= 0.02f)) continue;
      bool top = true;
      for (auto j : nb[i]) top = top && !(got.saliency[0][j] > si);
      if (top) keypoints.push_back(i);
    }
    EXPECT_EQ(got.keypoints, keypoints) << "seed " << seed;
    EXPECT_GE(got.keypoints.size(), 3u);
  }
}

TEST(Corner, SameForAnyThreadCountAndInTiles) {
  const ced::point_cloud c = ced_test::make_room(6000, 4, 0.003f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  p.threads = 1;
  const std::vector<ced::any_modality> m = {ced::make_modality("corner:0.05")};
  const auto one = ced::detect(c, p, m);
  ASSERT_GT(one.keypoints.size(), 5u);
  for (unsigned t : {2u, 3u}) {
    p.threads = t;
    EXPECT_EQ(ced::detect(c, p, m).saliency, one.saliency) << t << " threads";
  }
  EXPECT_EQ(ced::detect(c, p, ced::corner(0.05)).saliency, one.saliency);  // compile time
  for (double tile : {0.3, 0.17}) EXPECT_EQ(ced::detect_tiled(c, p, m, tile), one.keypoints) << "tile " << tile;
  // corner3d: corner at r and at 1.5 r, refined.
  p.refine = ced::preset_refines("corner3d");
  const auto preset = ced::preset("corner3d");
  ASSERT_EQ(preset.size(), 2u);
  const auto whole = ced::detect(c, p, preset);
  ASSERT_GT(whole.keypoints.size(), 5u);
  for (double tile : {0.3, 0.17}) EXPECT_EQ(ced::detect_tiled(c, p, preset, tile), whole.keypoints) << "tile " << tile;
}

TEST(Corner, SpecsAndBadInput) {
  EXPECT_EQ(ced::make_modality("corner").threshold({}), 0.05);
  EXPECT_EQ(ced::make_modality("corner:0.1,radius=0.5,from=estimate").threshold({}), 0.1);
  EXPECT_THROW(ced::make_modality("corner,radius=2"), std::invalid_argument);
  EXPECT_THROW(ced::make_modality("corner,from=nowhere"), std::invalid_argument);
  EXPECT_THROW(ced::make_modality("corner,size=3"), std::invalid_argument);
  const ced::point_cloud plain = ced_test::make_room(300, 6, 0.003f);
  ced::detect_params p;
  EXPECT_THROW(ced::detect(plain, p, std::vector<ced::any_modality>{ced::make_modality("corner,from=fields")}),
               std::invalid_argument);
}

TEST(WithThreshold, ZeroRanksEveryMaximum) {
  const ced::point_cloud c = ced_test::make_room(4000, 7, 0.002f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  const ced::any_modality strict = ced::make_modality("xyz:0.6");
  const auto natural = ced::detect(c, p, {strict});
  const ced::any_modality open = strict.with_threshold(0);
  EXPECT_EQ(open.name(), strict.name());
  EXPECT_EQ(open.threshold(p), 0.0);
  EXPECT_EQ(strict.threshold(p), 0.6 * p.radius);  // the original is unchanged
  const auto all = ced::detect(c, p, {open});
  EXPECT_EQ(all.saliency, natural.saliency);  // the same measure
  EXPECT_GT(all.keypoints.size(), natural.keypoints.size() + 20);
  // Every natural keypoint is among the maxima, and N of them are the N
  // strongest, whatever the natural count.
  for (auto k : natural.keypoints) EXPECT_TRUE(std::binary_search(all.keypoints.begin(), all.keypoints.end(), k)) << k;
  p.max_keypoints = natural.keypoints.size() + 10;
  EXPECT_EQ(ced::detect(c, p, {open}).keypoints.size(), p.max_keypoints);
  EXPECT_FALSE(ced::any_modality().with_threshold(0));
}
