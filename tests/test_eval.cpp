// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/output_file.hpp"
#include "test_support.hpp"

namespace {
ced::point_cloud five_points() {
  ced::point_cloud c;
  c.push_back(0, 0, 0);
  c.push_back(1, 0, 0);
  c.push_back(0, 2, 0);
  c.push_back(0, 0, 3);
  c.push_back(4, 4, 4);
  return c;
}
}  // namespace

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
ced::eval::rigid_transform rotation_z(double degrees, std::array<double, 3> t = {0, 0, 0}) {
  const double a = degrees * 3.14159265358979323846 / 180, c = std::cos(a), s = std::sin(a);
  ced::eval::rigid_transform r;
  r.rotation = {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  r.translation = t;
  return r;
}

std::string transform_error_of(const std::string& text) {
  std::istringstream in(text);
  try {
    ced::eval::parse_transform(in, "T.txt");
  } catch (const ced::io::io_error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Eval, ComposeAndInverse) {
  const auto a = rotation_z(30, {1, 2, 3});
  const auto b = rotation_z(-75, {-4, 0.5, 2});
  const std::array<double, 3> x{0.3, -1.2, 2.5};
  const auto ab = ced::eval::compose(a, b).apply(x), expected = a.apply(b.apply(x));
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(ab[k], expected[k], 1e-12);
  const auto back = ced::eval::compose(ced::eval::inverse(a), a).apply(x);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(back[k], x[k], 1e-12);
}

TEST(Eval, TransformComposesWithBothOrigins) {
  // P stored relative to a georeferenced origin, Q = T(P) stored relative to
  // another: the map between the stored (local) positions is not T.
  ced::point_cloud p = five_points();
  p.set_origin({500000.0, 4000000.0, 100.0});
  const auto t = rotation_z(90, {10, -20, 5});
  const std::array<double, 3> q_origin{-3999990.0, 500025.0, 104.0};  // T(P)'s absolute coordinates lie near here
  ced::point_cloud q;
  q.set_origin(q_origin);
  for (std::size_t i = 0; i < p.size(); ++i) {
    std::array<double, 3> abs{};
    for (std::size_t k = 0; k < 3; ++k) abs[k] = p.origin()[k] + p.position(i)[k];
    const auto image = t.apply(abs);
    q.push_back(float(image[0] - q_origin[0]), float(image[1] - q_origin[1]), float(image[2] - q_origin[2]));
  }
  const auto local = ced::eval::to_local(t, p.origin(), q.origin());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const float* s = p.position(i);
    const auto m = local.apply({s[0], s[1], s[2]});
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(m[k], q.position(i)[k], 1e-5) << "point " << i << " axis " << k;
  }
  const std::vector<std::uint32_t> all{0, 1, 2, 3, 4};
  EXPECT_EQ(ced::eval::measure(p, all, q, all, local, 0.01).repeated, 5u);
  EXPECT_EQ(ced::eval::measure(p, all, q, all, t, 0.01).repeated, 0u);  // T on local positions is wrong
  // to_absolute undoes to_local.
  const auto again = ced::eval::to_absolute(local, p.origin(), q.origin());
  EXPECT_NEAR(ced::eval::rotation_error_deg(again, t), 0.0, 1e-6);
  EXPECT_NEAR(ced::eval::translation_error(again, t), 0.0, 1e-6);
  // With zero origins the two frames agree.
  const auto same = ced::eval::to_local(t, {0, 0, 0}, {0, 0, 0});
  EXPECT_NEAR(ced::eval::translation_error(same, t), 0.0, 1e-12);
}

TEST(Eval, RotationAndTranslationErrors) {
  const auto truth = rotation_z(30, {1, 2, 3});
  EXPECT_NEAR(ced::eval::rotation_error_deg(truth, truth), 0.0, 1e-6);
  EXPECT_NEAR(ced::eval::rotation_error_deg(rotation_z(33, {1, 2, 3}), truth), 3.0, 1e-9);
  EXPECT_NEAR(ced::eval::rotation_error_deg(rotation_z(-150), truth), 180.0, 1e-6);
  // A rotation about x by 4 degrees composed with the truth: 4 degrees off.
  ced::eval::rigid_transform rx;
  const double a = 4 * 3.14159265358979323846 / 180;
  rx.rotation = {{{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}}};
  EXPECT_NEAR(ced::eval::rotation_error_deg(ced::eval::compose(rx, truth), truth), 4.0, 1e-9);
  EXPECT_DOUBLE_EQ(ced::eval::translation_error(rotation_z(30, {1, 2, 3.5}), truth), 0.5);
  EXPECT_DOUBLE_EQ(ced::eval::translation_error(rotation_z(30, {4, 6, 3}), truth), 5.0);
}

TEST(Eval, ParsesATransformFile) {
  std::istringstream in(
      "# P -> Q\n"
      "0 -1 0 10\n"
      "1, 0, 0, 20   # commas are fine\n"
      "0 0 1 30\n"
      "0 0 0 1\n");
  const auto t = ced::eval::parse_transform(in, "T.txt");
  EXPECT_EQ(t.rotation[0][1], -1.0);
  EXPECT_EQ(t.rotation[1][0], 1.0);
  EXPECT_EQ(t.translation[0], 10.0);
  EXPECT_EQ(t.translation[1], 20.0);
  EXPECT_EQ(t.translation[2], 30.0);
  std::istringstream one_line("1 0 0 0.5 0 1 0 0 0 0 1 0 0 0 0 1");
  EXPECT_EQ(ced::eval::parse_transform(one_line, "x").translation[0], 0.5);
}

TEST(Eval, RejectsBadTransformFiles) {
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n").find("found 12"), std::string::npos);
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1 7\n").find("found 17"), std::string::npos);
  EXPECT_NE(transform_error_of("").find("found 0"), std::string::npos);
  const auto bad_word = transform_error_of("1 0 0 0\n0 one 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_NE(bad_word.find("line 2"), std::string::npos) << bad_word;
  EXPECT_NE(bad_word.find("'one'"), std::string::npos) << bad_word;
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 nan\n0 0 0 1\n").find("not a finite number"),
            std::string::npos);
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n").find("last row"), std::string::npos);
  EXPECT_NE(transform_error_of("2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n").find("not a rotation"), std::string::npos);
  EXPECT_NE(transform_error_of("-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n").find("not a rotation"),  // a reflection
            std::string::npos);
  EXPECT_EQ(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"), "");
  try {
    ced::eval::read_transform("/nonexistent/dir/T.txt");
    FAIL() << "expected an io_error";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/T.txt"), std::string::npos);
  }
}
