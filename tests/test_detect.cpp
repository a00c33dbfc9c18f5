// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <random>
#include <set>

#include "ced/ced.hpp"
#include "core/arena.hpp"
#include "core/neighbor_index.hpp"
#include "test_support.hpp"

using ced_test::field_channel;
using ced_test::make_room;
using ced_test::oracle;
using ced_test::xyz_channel;

namespace {

void expect_matches_oracle(const ced::detection_result& r, const ced_test::oracle_result& o) {
  ASSERT_EQ(r.saliency.size(), o.saliency.size());
  for (std::size_t m = 0; m < o.saliency.size(); ++m)
    for (std::size_t i = 0; i < o.saliency[m].size(); ++i)
      ASSERT_NEAR(r.saliency[m][i], o.saliency[m][i], 1e-5 * std::max(1.0, std::abs(o.saliency[m][i])))
          << "modality " << m << " point " << i;
  EXPECT_EQ(std::vector<std::uint8_t>(r.candidate.begin(), r.candidate.end()), o.candidate);
  EXPECT_EQ(r.keypoints, o.keypoints);
}

}  // namespace

TEST(Detect, Ced6dMatchesBruteForceOracle) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const auto c = make_room(3000, seed);
    ced::detect_params p;
    const auto r = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{});
    const auto o = oracle(c, {xyz_channel(c, 0.2, p.radius), field_channel(c, {"red", "green", "blue"}, 255, 0.1)},
                          p.radius, p.nms_radius, p.min_neighbors);
    ASSERT_GT(o.keypoints.size(), 5u) << "fixture too easy";
    expect_matches_oracle(r, o);
  }
}

TEST(Detect, RadiiFarBelowTheCloudsSpacingFindNothing) {
  // Cells of such radii number past 2^64 along an axis: the grids grow
  // their cells instead (a float-to-integer overflow before, which UBSan
  // reported: fuzz_spec, `scale=8.1e-25`).
  const auto c = make_room(500, 4);
  for (double r : {1e-30, 1e-12}) {
    ced::detect_params p;
    p.radius = p.nms_radius = r;
    p.threads = 1;
    const auto res = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{});
    EXPECT_TRUE(res.keypoints.empty()) << "radius " << r;
  }
}

TEST(Detect, NmsRadiusDifferentFromRadius) {
  const auto c = make_room(2500, 7);
  for (double nms : {0.02, 0.08}) {
    ced::detect_params p;
    p.radius = 0.04;
    p.nms_radius = nms;
    const auto r = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{});
    const auto o = oracle(c, {xyz_channel(c, 0.2, p.radius), field_channel(c, {"red", "green", "blue"}, 255, 0.1)},
                          p.radius, p.nms_radius, p.min_neighbors);
    expect_matches_oracle(r, o);
  }
}

TEST(Detect, FourModalitiesMatchOracle) {
  const auto c = make_room(2500, 11);
  ced::detect_params p;
  p.min_neighbors = 8;
  const auto r = ced::detect(c, p, ced::xyz{0.25}, ced::rgb{}, ced::bands({"nir"}, 0.15), ced::intensity(0.3));
  const auto o = oracle(c,
                        {xyz_channel(c, 0.25, p.radius), field_channel(c, {"red", "green", "blue"}, 255, 0.1),
                         field_channel(c, {"nir"}, 255, 0.15), field_channel(c, {"intensity"}, 65535, 0.3)},
                        p.radius, p.nms_radius, p.min_neighbors);
  expect_matches_oracle(r, o);
}

TEST(Detect, RuntimeAndCompileTimePathsAgreeBitwise) {
  const auto c = make_room(4000, 5);
  ced::detect_params p;
  const auto a = ced::detect(c, p, ced::xyz{}, ced::rgb{}, ced::lab{});
  const auto b =
      ced::detect(c, p, {ced::make_modality("xyz:0.2"), ced::make_modality("rgb:0.1"), ced::make_modality("lab")});
  EXPECT_EQ(a.keypoints, b.keypoints);
  EXPECT_EQ(a.saliency, b.saliency);
  EXPECT_EQ(a.names, (std::vector<std::string>{"xyz", "rgb", "lab"}));
}

TEST(Detect, SameResultForAnyThreadCountAndBlockSize) {
  const auto c = make_room(30000, 9);
  ced::detect_params p;
  p.threads = 1;
  const auto ref = ced::detect(c, p, ced::preset("ced6d"));
  ASSERT_GT(ref.keypoints.size(), 10u);
  for (unsigned t : {2u, 3u, 8u}) {
    p.threads = t;
    const auto r = ced::detect(c, p, ced::preset("ced6d"));
    EXPECT_EQ(r.keypoints, ref.keypoints) << t << " threads";
    EXPECT_EQ(r.saliency, ref.saliency) << t << " threads";  // bitwise
    EXPECT_EQ(r.candidate, ref.candidate);
  }
  // The block size changes the neighbour order, so saliencies may differ in
  // the last bit; keypoints must not (this cloud has no borderline points).
  p.threads = 2;
  p.block_scale = 2.5;
  const auto r = ced::detect(c, p, ced::preset("ced6d"));
  EXPECT_EQ(r.keypoints, ref.keypoints);
}

// Block sizes from a fraction of the radius to many radii (few and many
// gathered points per block, sub-grids of every shape) all match the oracle.
TEST(Detect, AnyBlockScaleMatchesOracle) {
  const auto c = make_room(2000, 17);
  ced::detect_params p;
  const auto o = oracle(c, {xyz_channel(c, 0.2, p.radius), field_channel(c, {"red", "green", "blue"}, 255, 0.1)},
                        p.radius, p.nms_radius, p.min_neighbors);
  for (double scale : {0.3, 1.0, 3.0, 7.5, 40.0}) {
    SCOPED_TRACE(scale);
    p.block_scale = scale;
    const auto r = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{});
    expect_matches_oracle(r, o);
    EXPECT_EQ(r.neighbor_count, o.neighbor_count);
  }
}

// Four points: a cube corner and its three edge neighbours, 1 cm apart, radius
// 1.5 cm, so every point sees all four. Centroid (0.25, 0.25, 0.25) cm:
//   corner: |(0.25,0.25,0.25)| = 0.25·√3 cm;  tips: |(-0.75,0.25,0.25)| = √0.6875 cm.
// The three tips tie for the maximum and all are kept; the corner is suppressed.
TEST(Detect, HandComputedTetrahedronTiesKeepAll) {
  ced::point_cloud c;
  c.push_back(0, 0, 0);
  c.push_back(0.01f, 0, 0);
  c.push_back(0, 0.01f, 0);
  c.push_back(0, 0, 0.01f);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.015;
  p.min_neighbors = 4;
  const auto r = ced::detect(c, p, ced::xyz{0.2});
  EXPECT_NEAR(r.saliency[0][0], 0.0025 * std::sqrt(3.0), 1e-8);
  for (int i = 1; i < 4; ++i) EXPECT_NEAR(r.saliency[0][std::size_t(i)], 0.01 * std::sqrt(0.6875), 1e-8);
  EXPECT_EQ(r.keypoints, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_EQ(r.neighbor_count, (std::vector<std::uint32_t>{4, 4, 4, 4}));

  p.min_neighbors = 5;  // nobody has 5 neighbours: all saliencies 0, no candidates
  const auto none = ced::detect(c, p, ced::xyz{0.2});
  for (float s : none.saliency[0]) EXPECT_EQ(s, 0.0f);
  EXPECT_TRUE(none.keypoints.empty());
}

// A cube corner sampled on its three faces at 1 cm: the corner is the most
// salient point around and must be the only keypoint near it.
TEST(Detect, CubeCornerIsAKeypoint) {
  ced::point_cloud c;
  const int m = 15;
  std::uint32_t corner = 0;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      if (a == 0 && b == 0) corner = static_cast<std::uint32_t>(c.size());
      c.push_back(a * 0.01f, b * 0.01f, 0);                      // z = 0 face (includes the corner)
      if (b > 0) c.push_back(0, a * 0.01f, b * 0.01f);           // x = 0 face
      if (a > 0 && b > 0) c.push_back(b * 0.01f, 0, a * 0.01f);  // y = 0 face
    }
  ced::detect_params p;
  const auto r = ced::detect(c, p, ced::xyz{0.2});
  ASSERT_TRUE(std::binary_search(r.keypoints.begin(), r.keypoints.end(), corner));
  for (std::uint32_t k : r.keypoints) {
    if (k == corner) continue;
    EXPECT_GE(ced::squared_distance(c.position(k), c.position(corner)), ced::squared_radius(p.nms_radius));
  }
}

namespace {
/// A 1 cm grid plane z = 0 of (2h+1)² points; `left(x)` decides each point's side.
ced::point_cloud plane_with_edge(int h, std::vector<double>& side) {
  ced::point_cloud c;
  for (int y = -h; y <= h; ++y)
    for (int x = -h; x <= h; ++x) {
      c.push_back(x * 0.01f, y * 0.01f, 0);
      side.push_back(x <= 0 ? 0.0 : 1.0);
    }
  return c;
}
/// Lattice points (dx, dy) with |d| < 5.5 (cm), and those with dx >= k. The
/// tests use r = 5.5 cm so that no lattice point lies on the sphere (a 1 cm
/// grid at r = 5 cm puts (3,4) and (5,0) exactly on it, where float rounding
/// decides).
std::pair<int, int> disc_counts(int k) {
  int all = 0, beyond = 0;
  for (int dx = -5; dx <= 5; ++dx)
    for (int dy = -5; dy <= 5; ++dy)
      if (dx * dx + dy * dy <= 30) {
        ++all;
        beyond += dx >= k;
      }
  return {all, beyond};
}
}  // namespace

// Red | blue halves of a plane. A point in the last red column (x = 0) sees
// the blue points with dx >= 1: colour saliency = 2 · (#blue / #all) (L1 of
// (1,0,0) - (0,0,1) is 2). The edge is the only place with colour saliency,
// and interior rows are exact ties, so both edge columns are keypoints there.
TEST(Detect, HandComputedColourEdge) {
  const int h = 16;
  std::vector<double> side;
  auto c = plane_with_edge(h, side);
  std::vector<std::array<std::uint8_t, 3>> rgb;
  for (double s : side)
    rgb.push_back(s == 0 ? std::array<std::uint8_t, 3>{255, 0, 0} : std::array<std::uint8_t, 3>{0, 0, 255});
  c.add_rgb(rgb);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.055;
  const auto r = ced::detect(c, p, ced::rgb{});
  const auto [all, beyond] = disc_counts(1);
  auto index = [&](int x, int y) { return static_cast<std::size_t>((y + h) * (2 * h + 1) + (x + h)); };
  EXPECT_NEAR(r.saliency[0][index(0, 0)], 2.0 * beyond / all, 1e-6);
  EXPECT_NEAR(r.saliency[0][index(1, 0)], 2.0 * beyond / all, 1e-6);
  EXPECT_EQ(r.saliency[0][index(-6, 0)], 0.0f);
  std::set<std::uint32_t> kp(r.keypoints.begin(), r.keypoints.end());
  for (std::uint32_t k : r.keypoints) {
    const float x = c.position(k)[0];
    EXPECT_TRUE(std::abs(x) < 0.001f || std::abs(x - 0.01f) < 0.001f) << "keypoint off the edge at x=" << x;
  }
  // Rows near the plane's top and bottom have truncated neighbourhoods (and
  // other saliencies); rows whose whole NMS window sees full discs tie.
  for (int y = -h + 11; y <= h - 11; ++y) {
    EXPECT_TRUE(kp.count(static_cast<std::uint32_t>(index(0, y)))) << "row " << y;
    EXPECT_TRUE(kp.count(static_cast<std::uint32_t>(index(1, y)))) << "row " << y;
  }
}

// The same edge, but only in a near-infrared band: invisible to rgb,
// found by bands(nir).
TEST(Detect, BandEdgeInvisibleInRgb) {
  const int h = 10;
  std::vector<double> side;
  auto c = plane_with_edge(h, side);
  c.add_rgb(std::vector<std::array<std::uint8_t, 3>>(c.size(), {128, 128, 128}));
  std::vector<double> nir;
  for (double s : side) nir.push_back(s == 0 ? 20 : 220);
  c.add_field("nir", ced::scalar_type::uint8, nir);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.055;
  EXPECT_TRUE(ced::detect(c, p, ced::rgb{}).keypoints.empty());
  const auto r = ced::detect(c, p, {ced::make_modality("bands(nir):0.1")});
  ASSERT_FALSE(r.keypoints.empty());
  const auto [all, beyond] = disc_counts(1);
  EXPECT_NEAR(r.saliency[0][std::size_t(h * (2 * h + 1) + h)], 200.0 / 255.0 * beyond / all, 1e-6);
  for (std::uint32_t k : r.keypoints) EXPECT_LT(std::abs(c.position(k)[0] - 0.005f), 0.006f);
}

// Candidate = OR of the modalities' threshold tests, read off the result.
TEST(Detect, CandidateIsOrOfThresholds) {
  const auto c = make_room(3000, 21);
  ced::detect_params p;
  const auto r = ced::detect(c, p, ced::xyz{0.3}, ced::rgb{0.4});
  std::size_t only_geo = 0, only_rgb = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const bool g = r.saliency[0][i] >= r.thresholds[0], col = r.saliency[1][i] >= r.thresholds[1];
    EXPECT_EQ(bool(r.candidate[i]), g || col) << i;
    only_geo += g && !col;
    only_rgb += col && !g;
  }
  EXPECT_GT(only_geo, 0u);
  EXPECT_GT(only_rgb, 0u);
  EXPECT_DOUBLE_EQ(r.thresholds[0], 0.3 * p.radius);
}

TEST(Detect, EdgeCases) {
  ced::detect_params p;
  ced::point_cloud empty;
  EXPECT_TRUE(ced::detect(empty, p, ced::xyz{}).keypoints.empty());

  ced::point_cloud one;
  one.push_back(1, 2, 3);
  p.min_neighbors = 0;
  auto r = ced::detect(one, p, ced::xyz{});
  EXPECT_EQ(r.saliency[0][0], 0.0f);
  EXPECT_TRUE(r.keypoints.empty());  // 0 < 0.2 * radius: not a candidate
  r = ced::detect(one, p, ced::xyz{0.0});
  EXPECT_EQ(r.keypoints, (std::vector<std::uint32_t>{0}));  // threshold 0: every point is a candidate

  ced::point_cloud same;  // all points identical: zero saliency, one big tie
  for (int i = 0; i < 600; ++i) same.push_back(0.5f, 0.5f, 0.5f);
  p.min_neighbors = 5;
  r = ced::detect(same, p, ced::xyz{0.0});
  EXPECT_EQ(r.keypoints.size(), 600u);
  EXPECT_EQ(r.neighbor_count[0], 600u);
  r = ced::detect(same, p, ced::xyz{});
  EXPECT_TRUE(r.keypoints.empty());

  ced::point_cloud line;  // collinear, evenly spaced: only the ends are salient
  for (int i = 0; i < 50; ++i) line.push_back(i * 0.01f, 0, 0);
  r = ced::detect(line, p, ced::xyz{});
  EXPECT_EQ(r.keypoints, (std::vector<std::uint32_t>{0, 49}));

  p.min_neighbors = 1000;  // larger than the cloud
  EXPECT_TRUE(ced::detect(line, p, ced::xyz{}).keypoints.empty());

  p.min_neighbors = 5;  // a huge radius: everyone is everyone's neighbour, the two ends tie
  p.radius = p.nms_radius = 1e30;
  r = ced::detect(line, p, ced::xyz{0.0});
  EXPECT_EQ(r.neighbor_count[7], 50u);
  EXPECT_EQ(r.keypoints, (std::vector<std::uint32_t>{0, 49}));
}

namespace {
std::vector<std::uint32_t> read_indices(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  std::vector<std::uint32_t> v;
  for (std::uint32_t i; in >> i;) v.push_back(i);
  return v;
}
}  // namespace

// A real Redwood scan, checked index for index against an independent PCL
// implementation of the paper (tests/reference/pcl_ced.cpp; see
// tests/data/SOURCES.md). The paper's code sums in float in FLANN's order, so
// a point sitting exactly on a threshold or tie may flip: at most 0.5 %.

TEST(Detect, MatchesPclReferenceOnRedwoodScan) {
  const auto cloud = ced::io::read_ply(std::string(CED_TEST_DATA_DIR) + "/apartment_mesh_214.ply");
  ASSERT_EQ(cloud.size(), 24574u);
  for (const std::string preset : {"ced6d", "ced3d"}) {
    const auto want =
        read_indices(std::string(CED_TEST_DATA_DIR) + "/apartment_mesh_214." + preset + ".pcl_reference.txt");
    ASSERT_FALSE(want.empty());
    const auto got = ced::detect(cloud, ced::detect_params{}, ced::preset(preset)).keypoints;
    std::vector<std::uint32_t> diff;
    std::set_symmetric_difference(got.begin(), got.end(), want.begin(), want.end(), std::back_inserter(diff));
    EXPECT_LE(double(diff.size()), 0.005 * double(want.size()))
        << preset << ": " << got.size() << " vs " << want.size() << " keypoints";
  }
}

// Many bands (hyperspectral-like): bands(...) with more dimensions than the
// small fixed buffer takes the dimension-outer path; both must match the oracle.
TEST(Detect, ManyBandsMatchOracle) {
  auto c = make_room(1500, 13);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> u(0, 255);
  std::vector<std::string> names;
  for (int b = 0; b < 20; ++b) {
    std::vector<double> v(c.size());
    for (auto& x : v) x = u(rng) / (b % 3 == 0 ? 8 : 1);  // some smooth-ish, some noisy
    names.push_back("b" + std::to_string(b));
    c.add_field(names.back(), ced::scalar_type::uint8, v);
  }
  ced::detect_params p;
  for (std::size_t k : {std::size_t(5), std::size_t(20)}) {
    const std::vector<std::string> use(names.begin(), names.begin() + std::ptrdiff_t(k));
    const auto r = ced::detect(c, p, ced::xyz{}, ced::bands(use, 0.4));
    const auto o = oracle(c, {xyz_channel(c, 0.2, p.radius), field_channel(c, use, 255, 0.4)}, p.radius, p.nms_radius,
                          p.min_neighbors);
    expect_matches_oracle(r, o);
  }
}

// Every point a candidate (random bands), so the NMS keeps every sweep: the
// same result detection after detection, whatever memory they get.
TEST(Detect, RepeatedDetectionsAgreeBitwise) {
  auto c = make_room(20000, 21);
  std::mt19937 rng(5);
  for (const char* name : {"b1", "b2", "b3"}) {
    std::vector<double> v(c.size());
    for (auto& x : v) x = double(rng() % 256);
    c.add_field(name, ced::scalar_type::uint8, std::move(v));
  }
  ced::detect_params p;
  p.threads = 2;
  const std::vector<ced::any_modality> mods = {ced::xyz{}, ced::rgb{}, ced::bands({"b1", "b2", "b3"}, 0.1)};
  const auto first = ced::detect(c, p, mods);
  EXPECT_GT(std::count(first.candidate.begin(), first.candidate.end(), 1), std::ptrdiff_t(c.size() / 2));
  EXPECT_GT(ced::detail::chunk_arena::cached_bytes(), 0u);
  for (int k = 0; k < 3; ++k) {
    const auto again = ced::detect(c, p, mods);
    EXPECT_EQ(again.keypoints, first.keypoints);
    EXPECT_EQ(again.saliency, first.saliency);
  }
  // The cache can be emptied; the next detection starts without it.
  ced::release_cached_memory();
  EXPECT_EQ(ced::detail::chunk_arena::cached_bytes(), 0u);
  const auto after = ced::detect(c, p, mods);
  EXPECT_EQ(after.keypoints, first.keypoints);
  EXPECT_EQ(after.saliency, first.saliency);
}

TEST(Detect, ProgressCanCancelOnAnyThreadCount) {
  const auto c = ced_test::make_room(20000, 9);
  ced::detect_params p;
  const auto expected = ced::detect(c, p, ced::xyz{}, ced::rgb{});
  struct stop {};
  for (unsigned threads : {1u, 2u}) {
    p.threads = threads;
    int reports = 0;
    p.progress = [&](double) {
      if (++reports >= 2) throw stop{};
    };
    EXPECT_THROW(ced::detect(c, p, ced::xyz{}, ced::rgb{}), stop) << threads << " threads";
    EXPECT_GE(reports, 2);
    // Reports come between chunks on one thread too, and a cancelled
    // detection leaves nothing behind: the next one is whole.
    int after = 0;
    p.progress = [&](double) { ++after; };
    const auto again = ced::detect(c, p, {ced::any_modality(ced::xyz{}), ced::any_modality(ced::rgb{})});
    EXPECT_GT(after, 2) << threads << " threads";
    EXPECT_EQ(again.keypoints, expected.keypoints);
    EXPECT_EQ(again.saliency, expected.saliency);
  }
}

TEST(Detect, IntensityOf8BitValuesIn16BitFieldsIsScaledBy255) {
  // LAS files often store 8-bit intensities in their 16-bit field: like rgb,
  // intensity then scales by 255, so the same values in uint8 and uint16
  // give the same saliency, with no range=auto needed.
  ced::point_cloud c = ced_test::make_room(3000, 7, 0.003f);
  std::vector<double> v;
  for (std::size_t i = 0; i < c.size(); ++i) v.push_back(double((i * 37) % 256));
  c.add_field("i8", ced::scalar_type::uint8, v);
  c.add_field("i16", ced::scalar_type::uint16, v);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.06;
  const auto as8 = ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("intensity(i8):0.1")});
  const auto as16 = ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("intensity(i16):0.1")});
  EXPECT_EQ(as16.saliency, as8.saliency);
  EXPECT_EQ(as16.keypoints, as8.keypoints);
  EXPECT_FALSE(as8.keypoints.empty());
  // A range given still wins: the whole 16-bit range.
  const auto wide =
      ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("intensity(i16):0.1,range=0..65535")});
  for (std::size_t i = 0; i < c.size(); i += 101)
    EXPECT_NEAR(wide.saliency[0][i], as8.saliency[0][i] * 255.0 / 65535.0, 1e-6) << i;
}
