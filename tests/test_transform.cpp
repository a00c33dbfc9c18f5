// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/eval.hpp"
#include "ced/transform.hpp"
#include "test_support.hpp"

using ced_test::five_points;

namespace {
ced::eval::rigid_transform rotation_z(double degrees, std::array<double, 3> t = {0, 0, 0}) {
  const double a = degrees * 3.14159265358979323846 / 180, c = std::cos(a), s = std::sin(a);
  ced::eval::rigid_transform r;
  r.rotation = {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  r.translation = t;
  return r;
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
