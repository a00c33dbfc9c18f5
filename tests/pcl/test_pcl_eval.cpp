// SPDX-License-Identifier: MIT
// ced's PCL component: PCL's detectors as index detectors, and the
// registration pipeline on a small synthetic pair with a known transform.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "pcl_bridge.hpp"
#include "test_support.hpp"

namespace {

namespace pb = ced::pcl_bridge;

/// A room corner with three boxes of different sizes and colours, ~1 cm
/// spacing: distinctive enough that a rigid transform has one answer.
ced::point_cloud scene(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ced::point_cloud c;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  auto plane = [&](std::array<float, 3> o, std::array<float, 3> a, std::array<float, 3> b,
                   std::array<std::uint8_t, 3> col) {
    const float la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]),
                lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    const int n = static_cast<int>(la * lb / 1e-4f);  // one point per cm²
    for (int i = 0; i < n; ++i) {
      const float s = u(rng), t = u(rng);
      c.push_back(o[0] + s * a[0] + t * b[0], o[1] + s * a[1] + t * b[1], o[2] + s * a[2] + t * b[2]);
      const bool stripe = static_cast<int>((s * la + t * lb) / 0.1f) % 2 == 0;
      rgb.push_back(stripe ? col
                           : std::array<std::uint8_t, 3>{std::uint8_t(255 - col[0]), col[1], std::uint8_t(col[2] / 2)});
    }
  };
  auto box = [&](std::array<float, 3> o, std::array<float, 3> d, std::array<std::uint8_t, 3> col) {
    plane({o[0], o[1], o[2] + d[2]}, {d[0], 0, 0}, {0, d[1], 0}, col);  // top
    plane(o, {d[0], 0, 0}, {0, 0, d[2]}, col);
    plane({o[0], o[1] + d[1], o[2]}, {d[0], 0, 0}, {0, 0, d[2]}, col);
    plane(o, {0, d[1], 0}, {0, 0, d[2]}, col);
    plane({o[0] + d[0], o[1], o[2]}, {0, d[1], 0}, {0, 0, d[2]}, col);
  };
  plane({0, 0, 0}, {1.2f, 0, 0}, {0, 1.0f, 0}, {120, 120, 120});  // floor
  plane({0, 0, 0}, {1.2f, 0, 0}, {0, 0, 0.6f}, {200, 180, 40});   // walls
  plane({0, 0, 0}, {0, 1.0f, 0}, {0, 0, 0.6f}, {40, 90, 200});
  box({0.2f, 0.2f, 0}, {0.3f, 0.2f, 0.25f}, {220, 30, 30});
  box({0.7f, 0.5f, 0}, {0.15f, 0.35f, 0.1f}, {30, 200, 60});
  box({0.3f, 0.65f, 0}, {0.2f, 0.2f, 0.4f}, {250, 250, 250});
  c.add_rgb(rgb);
  return c;
}

struct pair_result {
  pb::registration_result r;
  ced::eval::rigid_transform truth;
};

pair_result register_scene(pb::descriptor feature, unsigned seed) {
  const ced::point_cloud p = scene(3);
  std::mt19937_64 rng(11);
  pair_result out;
  out.truth = ced::eval::random_transform(rng, 1.0);
  const ced::point_cloud q = ced::eval::transform(p, out.truth, 0.001, rng);
  ced::detect_params params;  // the paper's: radius 0.05
  const auto kp = ced::detect(p, params, ced::preset("ced6d")).keypoints;
  const auto kq = ced::detect(q, params, ced::preset("ced6d")).keypoints;
  pb::registration_params rp;
  rp.feature = feature;
  rp.seed = seed;
  out.r = pb::register_keypoints(p, kp, {-1, -1, 2}, q, kq, out.truth.apply({-1, -1, 2}), rp);
  return out;
}

}  // namespace

TEST(PclRegistration, RecoversAKnownTransform) {
  // PFHRGB, the paper's descriptor. (FPFH alone confuses this scene's
  // right-angled box corners with each other: geometry only, 34 degrees off.)
  {
    const auto [r, truth] = register_scene(pb::descriptor::pfhrgb, 1);
    EXPECT_TRUE(r.converged);
    EXPECT_GT(r.matches, 10u);
    EXPECT_GE(r.inliers, 3u);
    EXPECT_LE(r.inliers, r.matches);
    EXPECT_LT(ced::eval::rotation_error_deg(r.transform, truth), 5.0);
    EXPECT_LT(ced::eval::translation_error(r.transform, truth), 0.2);
  }
}

TEST(PclRegistration, SameSeedSameResult) {
  const auto a = register_scene(pb::descriptor::fpfh, 7), b = register_scene(pb::descriptor::fpfh, 7);
  EXPECT_EQ(a.r.matches, b.r.matches);
  EXPECT_EQ(a.r.inliers, b.r.inliers);
  EXPECT_EQ(a.r.converged, b.r.converged);
  EXPECT_EQ(a.r.transform.rotation, b.r.transform.rotation);
  EXPECT_EQ(a.r.transform.translation, b.r.transform.translation);
}

TEST(PclRegistration, RejectsBadInput) {
  ced::point_cloud grey = scene(3);
  grey.fields().clear();
  pb::registration_params rp;
  rp.feature = pb::descriptor::pfhrgb;
  EXPECT_THROW(pb::register_keypoints(grey, {0}, {0, 0, 0}, grey, {0}, {0, 0, 0}, rp), std::invalid_argument);
  rp.feature = pb::descriptor::fpfh;
  EXPECT_THROW(pb::register_keypoints(grey, {std::uint32_t(grey.size())}, {0, 0, 0}, grey, {0}, {0, 0, 0}, rp),
               std::out_of_range);
  rp.normal_radius = 0;
  EXPECT_THROW(pb::register_keypoints(grey, {0}, {0, 0, 0}, grey, {0}, {0, 0, 0}, rp), std::invalid_argument);
  // Too few keypoints: no hypothesis, not converged.
  rp.normal_radius = 0.03;
  EXPECT_FALSE(pb::register_keypoints(grey, {0, 1}, {0, 0, 0}, grey, {0, 1}, {0, 0, 0}, rp).converged);
}

// max_keypoints ranks Harris by its response: a subset of the natural
// keypoints of that size, nested as N grows; ISS3D and SIFT keep their count.
TEST(PclDetectors, MaxKeypointsRanksHarrisByResponse) {
  const ced::point_cloud c = scene(5);
  for (const auto d : {pb::detector::harris3d, pb::detector::harris6d}) {
    ASSERT_TRUE(pb::ranks_by_response(d));
    const auto all = pb::detect(c, d, pb::detector_params{});
    ASSERT_GT(all.size(), 8u);
    std::vector<std::uint32_t> previous;
    for (std::size_t n : {std::size_t(2), std::size_t(5), all.size() - 1, all.size() + 10}) {
      pb::detector_params p;
      p.max_keypoints = n;
      const auto k = pb::detect(c, d, p);
      EXPECT_EQ(k.size(), std::min(n, all.size()));
      EXPECT_TRUE(std::includes(all.begin(), all.end(), k.begin(), k.end()));
      EXPECT_TRUE(std::includes(k.begin(), k.end(), previous.begin(), previous.end()));  // the strongest stay
      previous = k;
    }
  }
  for (const auto d : {pb::detector::iss3d, pb::detector::sift}) {
    EXPECT_FALSE(pb::ranks_by_response(d));
    pb::detector_params p;
    p.max_keypoints = 2;
    EXPECT_EQ(pb::detect(c, d, p), pb::detect(c, d, pb::detector_params{}));
  }
}

TEST(PclDetectors, ReturnIndicesIntoTheCloud) {
  const ced::point_cloud c = scene(5);
  for (const char* name : {"iss3d", "harris3d", "harris6d", "sift"}) {
    SCOPED_TRACE(name);
    const auto d = pb::parse_detector(name);
    ASSERT_TRUE(d.has_value());
    const auto k = pb::detect(c, *d, pb::detector_params{});
    EXPECT_FALSE(k.empty());
    for (std::size_t i = 0; i < k.size(); ++i) {
      EXPECT_LT(k[i], c.size());
      if (i > 0) {
        EXPECT_LT(k[i - 1], k[i]);  // ascending, distinct
      }
    }
    EXPECT_EQ(pb::detect(c, *d, pb::detector_params{}), k);  // deterministic
  }
  EXPECT_FALSE(pb::parse_detector("ced6d").has_value());
  ced::point_cloud grey = c;
  grey.fields().clear();
  EXPECT_THROW(pb::detect(grey, pb::detector::harris6d, {}), std::invalid_argument);
  EXPECT_THROW(pb::detect(grey, pb::detector::sift, {}), std::invalid_argument);
  EXPECT_FALSE(pb::detect(grey, pb::detector::iss3d, {}).empty());
}
