// SPDX-License-Identifier: MIT
// The custom-saliency example's modality: circular hue.
#include <gtest/gtest.h>

#include "../examples/hue_modality.hpp"
#include "../examples/ndvi_modality.hpp"
#include "test_support.hpp"

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

TEST(Example, NdviOnTheFastPathHandComputed) {
  // NDVI 0.2 for x <= 0 and 0.6 for x > 0; names match ignoring case.
  const ced::point_cloud c = ced_test::ndvi_edge(ced::scalar_type::uint16, "NIR", "Red");
  static_assert(ced::sums_neighbors_v<ced::evaluator_t<example::ndvi>>, "the fast path");
  static_assert(!ced::reads_neighbors_v<ced::evaluator_t<example::ndvi>>, "sums only");
  ced::detect_params p;
  p.radius = p.nms_radius = 0.035;
  const auto r = ced::detect(c, p, example::ndvi{0.05});
  // At (0, 0), the last column of the left half: 37 neighbours within
  // 3.5 cm, 15 of them to the right. Saliency = |15 (0.6 - 0.2) / 37| / 2.
  const std::size_t edge = 10 * 21 + 10;
  EXPECT_EQ(r.neighbor_count[edge], 37u);
  EXPECT_NEAR(r.saliency[0][edge], 15 * 0.4 / 37 / 2, 1e-6);
  // One column to the right: 15 neighbours on the left, at -0.4.
  EXPECT_NEAR(r.saliency[0][edge + 1], 15 * 0.4 / 37 / 2, 1e-6);
  EXPECT_EQ(r.saliency[0][10 * 21 + 2], 0.0f);  // interior: one NDVI
  // The same by name once registered, and the fields it declares.
  ced::register_modality<example::ndvi>("NDVI");
  const auto by_name = ced::detect(c, p, {ced::make_modality("ndvi(NIR,Red):0.05")});
  EXPECT_EQ(by_name.saliency, r.saliency);
  EXPECT_EQ(ced::make_modality("ndvi").fields(), (std::vector<std::string>{"nir", "red"}));
  EXPECT_THROW(ced::make_modality("ndvi(a,b,c)"), std::invalid_argument);
  // A missing field is a clear error naming it.
  ced::point_cloud bare;
  for (int i = 0; i < 10; ++i) bare.push_back(i * 0.01f, 0, 0);
  try {
    ced::detect(bare, p, example::ndvi{});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("needs field 'nir'"), std::string::npos) << e.what();
  }
}
