// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <utility>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "test_support.hpp"

using ced_test::five_points;

TEST(Eval, KnownTransformAndMatches) {
  const auto p = five_points();
  ced::eval::rigid_transform t;  // 90° about z, then a shift
  t.rotation = {{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}};
  t.translation = {10, 20, 30};
  std::mt19937_64 rng(1);
  const auto q = ced::eval::transform(p, t, 0.0, rng);
  EXPECT_FLOAT_EQ(q.position(1)[0], 10.0f);  // (1,0,0) -> (0,1,0) + t
  EXPECT_FLOAT_EQ(q.position(1)[1], 21.0f);
  EXPECT_FLOAT_EQ(q.position(2)[0], 8.0f);  // (0,2,0) -> (-2,0,0) + t
  // P's keypoints {0,1,2,4}; Q's {0,2,3}: the images of 0 and 2 have a match,
  // 1 and 4 do not.
  auto r = ced::eval::measure(p, {0, 1, 2, 4}, q, {0, 2, 3}, t, 0.01);
  EXPECT_EQ(r.source_keypoints, 4u);
  EXPECT_EQ(r.target_keypoints, 3u);
  EXPECT_EQ(r.repeated, 2u);
  EXPECT_DOUBLE_EQ(r.relative(), 0.5);
  // With the identity instead of t, nothing matches.
  EXPECT_EQ(ced::eval::measure(p, {0, 1, 2, 4}, q, {0, 2, 3}, ced::eval::rigid_transform{}, 0.01).repeated, 0u);
  // Epsilon is inclusive: Q's keypoint moved exactly 0.5 away still matches at 0.5.
  ced::point_cloud q2 = q;
  q2.positions()[3 * 0 + 2] += 0.5f;
  EXPECT_EQ(ced::eval::measure(p, {0}, q2, {0}, t, 0.5).repeated, 1u);
  EXPECT_EQ(ced::eval::measure(p, {0}, q2, {0}, t, 0.49).repeated, 0u);
  EXPECT_EQ(ced::eval::measure(p, {}, q, {0}, t, 1).relative(), 0.0);
}

TEST(Eval, RandomTransformIsARotation) {
  std::mt19937_64 rng(42);
  for (int k = 0; k < 20; ++k) {
    const auto t = ced::eval::random_transform(rng, 2.0);
    const auto& R = t.rotation;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double dot = 0;
        for (int m = 0; m < 3; ++m) dot += R[std::size_t(i)][std::size_t(m)] * R[std::size_t(j)][std::size_t(m)];
        EXPECT_NEAR(dot, i == j ? 1.0 : 0.0, 1e-12);
      }
    const double det = R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) -
                       R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0]) +
                       R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]);
    EXPECT_NEAR(det, 1.0, 1e-12);
    for (double c : t.translation) EXPECT_LE(std::abs(c), 2.0);
  }
}

TEST(Eval, DeterministicForASeed) {
  const auto p = ced_test::make_room(3000, 3);
  auto run = [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const auto t = ced::eval::random_transform(rng, 1.0);
    const auto q = ced::eval::transform(p, t, 0.002, rng);
    const ced::detect_params params;
    const auto kp = ced::detect(p, params, ced::preset("ced6d")).keypoints;
    const auto kq = ced::detect(q, params, ced::preset("ced6d")).keypoints;
    return std::make_pair(q.positions(), ced::eval::measure(p, kp, q, kq, t, 0.02).repeated);
  };
  const auto a = run(7), b = run(7), c = run(8);
  EXPECT_EQ(a.first, b.first);
  EXPECT_EQ(a.second, b.second);
  EXPECT_NE(a.first, c.first);
}

TEST(Eval, RandomKeypoints) {
  std::mt19937_64 rng(5);
  const auto k = ced::eval::random_keypoints(100, 30, rng);
  ASSERT_EQ(k.size(), 30u);
  for (std::size_t i = 1; i < k.size(); ++i) EXPECT_LT(k[i - 1], k[i]);
  EXPECT_LT(k.back(), 100u);
  EXPECT_EQ(ced::eval::random_keypoints(10, 50, rng).size(), 10u);
}

namespace {
/// A 10 x 10 grid of points 1 apart at z = 0, x from `x0`.
ced::point_cloud grid(float x0) {
  ced::point_cloud c;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) c.push_back(x0 + float(i), float(j), 0.0f);
  return c;
}
}  // namespace

// A hand-built real pair: Q is P shifted by 5 in x (columns 5..14), given
// in Q's frame moved by +100 in y, so only the transform lines them up.
TEST(RealPair, OverlapDenominatorAndRandomBaseline) {
  const ced::point_cloud p = grid(0);
  ced::point_cloud q = grid(5);
  for (std::size_t i = 0; i < q.size(); ++i) q.positions()[3 * i + 1] += 100.0f;
  ced::eval::rigid_transform t;
  t.translation = {0, 100, 0};
  const ced::eval::real_pair pair(p, q, t, 0.25);
  EXPECT_EQ(pair.overlap_points(), 50u);  // P's columns 5..9
  EXPECT_FALSE(pair.in_overlap(0));       // (0, 0)
  EXPECT_TRUE(pair.in_overlap(50));       // (5, 0)
  // P's keypoints: (0,0) and (1,3) outside the overlap, (6,2), (7,7), (9,9) inside;
  // Q's keypoints at the images of (6,2) and (9,9) (Q's column 1 and 4), and one elsewhere.
  const std::vector<std::uint32_t> kp = {0, 13, 62, 77, 99};
  const std::vector<std::uint32_t> kq = {12, 49, 0};
  const auto r = pair.measure(kp, kq);
  EXPECT_EQ(r.source_keypoints, 5u);
  EXPECT_EQ(r.target_keypoints, 3u);
  EXPECT_EQ(r.overlap_keypoints, 3u);  // not 5: (0,0) and (1,3) cannot repeat
  EXPECT_EQ(r.repeated, 2u);
  EXPECT_DOUBLE_EQ(r.relative(), 2.0 / 3.0);
  // The whole-cloud measure divides by all five.
  EXPECT_DOUBLE_EQ(ced::eval::measure(p, kp, q, kq, t, 0.25).relative(), 2.0 / 5.0);
  // Epsilon is inclusive for the overlap too: P's column 4 is exactly 1 from Q's first.
  EXPECT_EQ(ced::eval::real_pair(p, q, t, 0.999).overlap_points(), 50u);
  EXPECT_EQ(ced::eval::real_pair(p, q, t, 1.0).overlap_points(), 60u);
  // No keypoint of Q: the overlap still counts, nothing repeats.
  EXPECT_EQ(pair.measure(kp, {}).overlap_keypoints, 3u);
  EXPECT_EQ(pair.measure(kp, {}).repeated, 0u);
  EXPECT_EQ(pair.measure({0, 13}, kq).relative(), 0.0);  // none in the overlap
  EXPECT_THROW(pair.measure({100}, kq), std::out_of_range);
  EXPECT_THROW(ced::eval::real_pair(p, q, t, 0), std::invalid_argument);

  // Random baseline, pooled over the draws (repeated / overlap keypoints):
  // all points of both clouds repeat exactly; one point of each repeats
  // when Q's point is the one P's (overlapping) point lands on, 1 in 100.
  std::mt19937_64 rng(3);
  EXPECT_DOUBLE_EQ(pair.random_relative(100, 100, 10, rng), 1.0);
  const double one = pair.random_relative(1, 1, 20000, rng);
  EXPECT_NEAR(one, 1.0 / 100.0, 0.004);
  std::mt19937_64 a(7), b(7);
  EXPECT_EQ(pair.random_relative(10, 10, 50, a), pair.random_relative(10, 10, 50, b));  // deterministic for a seed
}
