// SPDX-License-Identifier: MIT
// The custom-saliency example's modality: circular hue.
#include <gtest/gtest.h>

#include "../examples/hue_modality.hpp"

namespace {
// A 1 cm plane split at x = 0 into two hues (degrees, full saturation).
ced::point_cloud two_hues(double left_deg, double right_deg) {
  ced::point_cloud c;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  auto colour = [](double deg) {  // HSV(deg, 1, 1) to RGB
    const double h = std::fmod(deg + 360.0, 360.0) / 60.0, x = 1 - std::abs(std::fmod(h, 2.0) - 1);
    double r = 0, g = 0, b = 0;
    if (h < 1)
      r = 1, g = x;
    else if (h < 2)
      r = x, g = 1;
    else if (h < 3)
      g = 1, b = x;
    else if (h < 4)
      g = x, b = 1;
    else if (h < 5)
      r = x, b = 1;
    else
      r = 1, b = x;
    return std::array<std::uint8_t, 3>{std::uint8_t(std::lround(r * 255)), std::uint8_t(std::lround(g * 255)),
                                       std::uint8_t(std::lround(b * 255))};
  };
  for (int y = -10; y <= 10; ++y)
    for (int x = -10; x <= 10; ++x) {
      c.push_back(x * 0.01f, y * 0.01f, 0);
      rgb.push_back(colour(x <= 0 ? left_deg : right_deg));
    }
  c.add_rgb(rgb);
  return c;
}
}  // namespace

TEST(Example, CircularHueSeesThroughTheWrapAround) {
  ced::detect_params p;
  p.radius = p.nms_radius = 0.055;
  const std::size_t centre = 10 * 21 + 10;  // (0, 0): last left column
  // 350° | 10°: 20° apart. The circular mean at the edge is near 0°, so the
  // saliency is at most 20°/180° = 0.111. A linear mean of hue angles would
  // put the mean near 180° and call the edge maximally salient.
  const auto wrap = ced::detect(two_hues(350, 10), p, example::hue{0.15});
  EXPECT_LT(wrap.saliency[0][centre], 20.0 / 180.0 + 1e-3);
  EXPECT_GT(wrap.saliency[0][centre], 0.01);
  EXPECT_TRUE(wrap.keypoints.empty());
  // A real hue edge, red | green (120° apart), is salient and found there.
  const auto c = two_hues(0, 120);
  const auto edge = ced::detect(c, p, example::hue{0.15});
  EXPECT_GT(edge.saliency[0][centre], 0.15);
  ASSERT_FALSE(edge.keypoints.empty());
  for (auto k : edge.keypoints) EXPECT_LT(std::abs(c.position(k)[0] - 0.005f), 0.006f);
  // Interior points see one hue: saliency 0.
  EXPECT_EQ(edge.saliency[0][10 * 21 + 2], 0.0f);
}
