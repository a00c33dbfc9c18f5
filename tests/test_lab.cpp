// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

#include "ced/channels.hpp"

TEST(Lab, MatchesTheCieFormulaWithStdCbrt) {
  // linear_srgb_to_lab takes its cube roots by iteration: the result must
  // be the CIE formula's (here with std::cbrt) to a float's last bit, on a
  // grid of 8-bit colours that spans both branches of f(t).
  auto reference = [](double R, double G, double B) {
    const double X = (0.4124564 * R + 0.3575761 * G + 0.1804375 * B) / 0.95047;
    const double Y = 0.2126729 * R + 0.7151522 * G + 0.0721750 * B;
    const double Z = (0.0193339 * R + 0.1191920 * G + 0.9503041 * B) / 1.08883;
    auto f = [](double t) { return t > 216.0 / 24389.0 ? std::cbrt(t) : (24389.0 / 27.0 * t + 16.0) / 116.0; };
    return std::array<double, 3>{116.0 * f(Y) - 16.0, 500.0 * (f(X) - f(Y)), 200.0 * (f(Y) - f(Z))};
  };
  std::size_t same = 0, total = 0;
  for (int r = 0; r < 256; r += 3)
    for (int g = 0; g < 256; g += 3)
      for (int b = 0; b < 256; b += 3) {
        const double R = ced::srgb_to_linear(float(r / 255.0)), G = ced::srgb_to_linear(float(g / 255.0)),
                     B = ced::srgb_to_linear(float(b / 255.0));
        const auto got = ced::linear_srgb_to_lab(R, G, B);
        const auto want = reference(R, G, B);
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(got[k], want[k], 1e-5 * (1.0 + std::fabs(want[k]))) << r << "," << g << "," << b;
          same += got[k] == static_cast<float>(want[k]);
          ++total;
        }
      }
  EXPECT_GE(double(same), 0.9999 * double(total));
}

TEST(Lab, BatchConversionMatchesOneByOneBitwise) {
  // The batch form computes several colours per instruction; every value must
  // be the one-colour function's, whatever the count (tails included).
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> u(0, 255);
  for (std::size_t n : {std::size_t(1), std::size_t(7), std::size_t(8), std::size_t(9), std::size_t(1000)}) {
    std::vector<double> r(n), g(n), b(n);
    for (std::size_t i = 0; i < n; ++i) {
      r[i] = ced::srgb_to_linear(float(u(rng) / 255.0));
      g[i] = ced::srgb_to_linear(float(u(rng) / 255.0));
      b[i] = ced::srgb_to_linear(float(i % 5 == 0 ? 0 : u(rng) / 255.0));  // some dark: the linear branch
    }
    std::vector<float> lab(3 * n + 1, -1.0f);
    ced::linear_srgb_to_lab(r.data(), g.data(), b.data(), n, lab.data());
    for (std::size_t i = 0; i < n; ++i) {
      const auto one = ced::linear_srgb_to_lab(r[i], g[i], b[i]);
      for (std::size_t k = 0; k < 3; ++k) ASSERT_EQ(lab[3 * i + k], one[k]) << n << " colours, colour " << i;
    }
    EXPECT_EQ(lab[3 * n], -1.0f) << "wrote past the end";
  }
}
