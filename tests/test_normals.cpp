// SPDX-License-Identifier: MIT
// The normals modality (ced/modalities/normals.hpp) and estimate_normals:
// hand-computed cases, an O(N^2) oracle on random clouds, thread-count
// invariance, tiles, specs and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "test_support.hpp"

namespace {

ced::point_cloud with_normals(const std::vector<std::array<float, 3>>& xyz,
                              const std::vector<std::array<double, 3>>& n) {
  ced::point_cloud c;
  std::vector<double> nx, ny, nz;
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    c.push_back(xyz[i][0], xyz[i][1], xyz[i][2]);
    nx.push_back(n[i][0]), ny.push_back(n[i][1]), nz.push_back(n[i][2]);
  }
  c.add_field("nx", ced::scalar_type::float32, nx);
  c.add_field("ny", ced::scalar_type::float32, ny);
  c.add_field("nz", ced::scalar_type::float32, nz);
  return c;
}

/// The smallest eigenvalue of a symmetric 3×3 matrix, in closed form
/// (trigonometric solution of the characteristic polynomial).
double smallest_eigenvalue(const double a[3][3]) {
  const double p1 = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
  if (p1 == 0) return std::min({a[0][0], a[1][1], a[2][2]});
  const double q = (a[0][0] + a[1][1] + a[2][2]) / 3;
  const double p2 =
      (a[0][0] - q) * (a[0][0] - q) + (a[1][1] - q) * (a[1][1] - q) + (a[2][2] - q) * (a[2][2] - q) + 2 * p1;
  const double p = std::sqrt(p2 / 6);
  double b[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b[i][j] = (a[i][j] - (i == j ? q : 0)) / p;
  const double det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) -
                     b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
                     b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
  const double r = std::max(-1.0, std::min(1.0, det / 2));
  const double phi = std::acos(r) / 3;
  return q + 2 * p * std::cos(phi + 2 * M_PI / 3);
}

}  // namespace

TEST(Normals, HandComputedTensorDistance) {
  // A sees B, C (normal +z) and D (normal +x) within r: the mean tensor is
  // (3 ez ezᵀ + ex exᵀ) / 4, so s_A = ||(ex exᵀ − ez ezᵀ) / 4||_F = √2 / 4.
  const std::vector<std::array<float, 3>> xyz = {{0, 0, 0}, {0.01f, 0, 0}, {0, 0.01f, 0}, {0.01f, 0.01f, 0}};
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  p.min_neighbors = 1;
  const auto r = ced::detect(with_normals(xyz, {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {1, 0, 0}}), p,
                             std::vector<ced::any_modality>{ced::make_modality("normals:0.2")});
  EXPECT_NEAR(r.saliency[0][0], std::sqrt(2.0) / 4, 1e-6);
  // D: mean (3 ez ezᵀ + ex exᵀ) / 4 less ex exᵀ: 3/4 of √2.
  EXPECT_NEAR(r.saliency[0][3], 3 * std::sqrt(2.0) / 4, 1e-6);
  EXPECT_EQ(r.keypoints, std::vector<std::uint32_t>{3});
  EXPECT_EQ(r.names[0], "normals");
  // Orientation and length do not matter: −x, (0, 0, −2) give the same.
  const auto flipped = ced::detect(with_normals(xyz, {{0, 0, -2}, {0, 0, 1}, {0, 0, -1}, {-1, 0, 0}}), p,
                                   std::vector<ced::any_modality>{ced::make_modality("normals:0.2")});
  EXPECT_EQ(flipped.saliency, r.saliency);
}

TEST(Normals, EstimatedOnPlanesAndACrease) {
  // A 1 cm grid on z = 0: every normal is ±z, made +z (largest component
  // positive), and the saliency is 0 everywhere.
  ced::point_cloud plane;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) plane.push_back(0.01f * i, 0.01f * j, 0);
  const auto n = ced::estimate_normals(plane, 0.025, 1);
  for (std::size_t i = 0; i < plane.size(); ++i) {
    EXPECT_NEAR(n[3 * i], 0, 1e-6);
    EXPECT_NEAR(n[3 * i + 1], 0, 1e-6);
    EXPECT_NEAR(n[3 * i + 2], 1, 1e-6);
  }
  // Fewer than 3 neighbours, or all at one place: (0, 0, 0).
  ced::point_cloud sparse;
  sparse.push_back(0, 0, 0);
  sparse.push_back(1, 0, 0);
  sparse.push_back(1, 0, 0);
  sparse.push_back(1, 0, 0);
  const auto z = ced::estimate_normals(sparse, 0.1, 1);
  for (float v : z) EXPECT_EQ(v, 0.0f);
  EXPECT_THROW(ced::estimate_normals(plane, 0, 1), std::invalid_argument);
  EXPECT_THROW(ced::estimate_normals(plane, std::nan(""), 1), std::invalid_argument);
  EXPECT_TRUE(ced::estimate_normals(ced::point_cloud{}, 0.1, 1).empty());
  // A crease: the plane z = 0 (x < 0) meets the plane x = 0 (z > 0). Points
  // on the crease are salient, points far from it are not.
  ced::point_cloud crease;
  for (int i = -10; i < 0; ++i)
    for (int j = 0; j < 10; ++j) crease.push_back(0.01f * i, 0.01f * j, 0);
  for (int k = 0; k < 10; ++k)
    for (int j = 0; j < 10; ++j) crease.push_back(0, 0.01f * j, 0.01f * k);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.03;
  const auto r =
      ced::detect(crease, p, std::vector<ced::any_modality>{ced::make_modality("normals:0.2,from=estimate")});
  const float far_away = r.saliency[0][0 * 10 + 5];         // x = −0.10
  const float at_crease = r.saliency[0][100 + 0 * 10 + 5];  // x = 0, z = 0
  EXPECT_NEAR(far_away, 0, 1e-6);
  EXPECT_GT(at_crease, 0.2f);
}

TEST(Normals, MatchesTheOracleOnRandomClouds) {
  for (std::uint32_t seed : {1u, 2u}) {
    const ced::point_cloud c = ced_test::make_room(2000, seed, 0.003f);
    const double r = 0.06, k = seed == 1 ? 1.0 : 0.5;
    // Every estimated normal is a unit eigenvector of the smallest eigenvalue
    // of its brute-force neighbourhood's covariance.
    const auto normals = ced::estimate_normals(c, k * r, 2);
    const auto nb = ced_test::brute_neighbors(c, k * r);
    for (std::size_t i = 0; i < c.size(); ++i) {
      const float* n = normals.data() + 3 * i;
      if (nb[i].size() < 3) {
        EXPECT_EQ(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 0.0f) << i;
        continue;
      }
      double mean[3] = {0, 0, 0}, cov[3][3] = {};
      for (auto j : nb[i])
        for (int a = 0; a < 3; ++a) mean[a] += c.position(j)[a] / double(nb[i].size());
      for (auto j : nb[i])
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            cov[a][b] += (c.position(j)[a] - mean[a]) * (c.position(j)[b] - mean[b]) / double(nb[i].size());
      double q = 0;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) q += n[a] * cov[a][b] * n[b];
      const double trace = cov[0][0] + cov[1][1] + cov[2][2];
      ASSERT_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0, 1e-5) << i;
      ASSERT_LE(q - smallest_eigenvalue(cov), 1e-5 * trace) << "seed " << seed << ", point " << i;
    }
    // The detection: the tensor distance and the NMS by their definitions.
    ced::detect_params p;
    p.radius = p.nms_radius = r;
    p.threads = 2;
    const std::string spec = seed == 1 ? "normals:0.15" : "normals:0.15,radius=0.5";
    const auto got = ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality(spec)});
    ced_test::oracle_channel ch;
    for (std::size_t i = 0; i < c.size(); ++i) {
      const float* n = normals.data() + 3 * i;
      ch.values.push_back({n[0] * n[0], n[1] * n[1], n[2] * n[2], n[0] * n[1], n[0] * n[2], n[1] * n[2]});
    }
    const double r2 = std::sqrt(2.0);
    ch.scale = {1, 1, 1, r2, r2, r2};
    ch.norm = 2;
    ch.threshold = 0.15;
    const auto o = ced_test::oracle(c, {ch}, r, r, p.min_neighbors);
    for (std::size_t i = 0; i < c.size(); ++i)
      ASSERT_NEAR(got.saliency[0][i], o.saliency[0][i], 1e-5) << "seed " << seed << ", point " << i;
    EXPECT_EQ(got.keypoints, o.keypoints) << "seed " << seed;
    EXPECT_GE(got.keypoints.size(), 3u);
  }
}

TEST(Normals, SameResultForAnyThreadCount) {
  const ced::point_cloud c = ced_test::make_room(6000, 4, 0.003f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  p.threads = 1;
  const std::vector<ced::any_modality> m = {ced::make_modality("normals:0.2"), ced::make_modality("rgb:0.1")};
  const auto one = ced::detect(c, p, m);
  const auto n1 = ced::estimate_normals(c, 0.05, 1);
  for (unsigned t : {2u, 3u, 8u}) {
    p.threads = t;
    const auto other = ced::detect(c, p, m);
    EXPECT_EQ(other.saliency, one.saliency) << t << " threads";
    EXPECT_EQ(other.keypoints, one.keypoints) << t << " threads";
    EXPECT_EQ(ced::estimate_normals(c, 0.05, t), n1) << t << " threads";
  }
  // Compile time: the same numbers.
  p.threads = 2;
  EXPECT_EQ(ced::detect(c, p, ced::normals(0.2), ced::rgb(0.1)).saliency, one.saliency);
}

TEST(Normals, TilesStayExact) {
  const ced::point_cloud c = ced_test::make_room(6000, 5, 0.003f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.04;
  const std::vector<ced::any_modality> m = {ced::make_modality("normals:0.2"), ced::make_modality("xyz:0.2")};
  const auto whole = ced::detect(c, p, m).keypoints;
  ASSERT_GT(whole.size(), 5u);
  for (double tile : {0.3, 0.17}) EXPECT_EQ(ced::detect_tiled(c, p, m, tile), whole) << "tile " << tile;
}

TEST(Normals, SpecsFieldsAndBadInput) {
  const ced::point_cloud plain = ced_test::make_room(500, 6, 0.003f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.05;
  // from=fields without the fields: an error naming them.
  try {
    ced::detect(plain, p, std::vector<ced::any_modality>{ced::make_modality("normals,from=fields")});
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("nx"), std::string::npos) << e.what();
  }
  for (const char* bad : {"normals,radius=0", "normals,radius=1.5", "normals,radius=x", "normals,radius=-1",
                          "normals,from=mesh", "normals,scale=0"})
    EXPECT_THROW(ced::make_modality(bad), std::invalid_argument) << bad;
  EXPECT_THROW(ced::normals(0.2, ced::normals::source::automatic, 2), std::invalid_argument);
  // auto: the file's normals when present (all +z here: every saliency 0).
  ced::point_cloud flat = plain;
  flat.add_field("NX", ced::scalar_type::float32, std::vector<double>(flat.size(), 0.0));
  flat.add_field("NY", ced::scalar_type::float32, std::vector<double>(flat.size(), 0.0));
  flat.add_field("NZ", ced::scalar_type::float32, std::vector<double>(flat.size(), 1.0));
  const auto r = ced::detect(flat, p, std::vector<ced::any_modality>{ced::make_modality("normals")});
  for (float s : r.saliency[0]) ASSERT_EQ(s, 0.0f);
  // ... unless told to estimate them.
  const auto e = ced::detect(flat, p, std::vector<ced::any_modality>{ced::make_modality("normals,from=estimate")});
  const auto e_plain = ced::detect(plain, p, std::vector<ced::any_modality>{ced::make_modality("normals")});
  EXPECT_EQ(e.saliency, e_plain.saliency);
  // A non-finite normal is named.
  ced::point_cloud bad = plain;
  std::vector<double> nz(bad.size(), 1.0);
  nz[7] = std::nan("");
  bad.add_field("nx", ced::scalar_type::float32, std::vector<double>(bad.size(), 0.0));
  bad.add_field("ny", ced::scalar_type::float32, std::vector<double>(bad.size(), 0.0));
  bad.add_field("nz", ced::scalar_type::float32, nz);
  try {
    ced::detect(bad, p, std::vector<ced::any_modality>{ced::make_modality("normals")});
    FAIL() << "no error";
  } catch (const std::invalid_argument& ex) {
    EXPECT_NE(std::string(ex.what()).find("nz"), std::string::npos) << ex.what();
  }
}
