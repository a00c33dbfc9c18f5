// SPDX-License-Identifier: MIT
// The spectral angle (ced/modalities/sam.hpp): its arctangent, hand-computed
// spectra, an O(N²) oracle in long double with acos, scale invariance,
// thread counts and tiles.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "ced/modalities/sam.hpp"
#include "test_support.hpp"

namespace {

/// A room with `bands` float bands s00, s01, ...: a smooth spectrum that
/// changes across the room, times a brightness that changes faster (an
/// illumination the angle must not see), plus a little noise.
ced::point_cloud spectral_room(std::size_t n, std::size_t bands, unsigned seed, bool bright = true) {
  ced::point_cloud c = ced_test::make_room(n, seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::vector<double>> v(bands, std::vector<double>(c.size()));
  for (std::size_t i = 0; i < c.size(); ++i) {
    const float* p = c.position(i);
    const double gain = bright ? 0.5 + 0.5 * std::sin(40.0 * p[1]) * std::sin(40.0 * p[1]) : 1.0;
    for (std::size_t b = 0; b < bands; ++b)
      v[b][i] = gain * (1.0 + 0.5 * std::sin(3.0 * p[0] + 0.4 * double(b)) + 0.02 * u(rng));
  }
  for (std::size_t b = 0; b < bands; ++b)
    c.add_field((b < 10 ? "s0" : "s") + std::to_string(b), ced::scalar_type::float32, std::move(v[b]));
  return c;
}

/// The angle by its definition: acos of the normalised dot product, in
/// long double, over brute-force neighbourhoods.
std::vector<double> oracle_angles(const ced::point_cloud& c, const std::vector<std::string>& names, double r,
                                  std::uint32_t min_neighbors) {
  const auto nb = ced_test::brute_neighbors(c, r);
  std::vector<const ced::field*> f;
  for (const auto& n : names) f.push_back(c.find_field(n));
  std::vector<double> out(c.size(), 0.0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (nb[i].size() < min_neighbors) continue;
    long double vv = 0, mm = 0, vm = 0;
    for (const ced::field* b : f) {
      long double m = 0;
      for (auto j : nb[i]) m += static_cast<float>(b->values[j]);
      m /= nb[i].size();
      const long double x = static_cast<float>(b->values[i]);
      vv += x * x, mm += m * m, vm += x * m;
    }
    const long double cosine = std::min(1.0L, std::max(-1.0L, vm / std::sqrt(vv * mm)));
    out[i] = double(std::acos(cosine));
  }
  return out;
}

}  // namespace

TEST(Sam, PortableArctangent) {
  for (double x : {0.0, 1e-300, 1e-12, 1e-6, 0.01, 0.0999, 0.1, 0.5, 0.999, 1.0, 1.001, 2.0, 10.0, 1e6, 1e300})
    EXPECT_NEAR(ced::detail::portable_atan(x), std::atan(x), 4e-16 * std::max(1.0, std::atan(x))) << x;
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(ced::detail::portable_atan(inf), std::atan(inf), 1e-15);
  EXPECT_EQ(ced::detail::portable_atan(-1.0), 0.0);  // not defined here: 0
}

TEST(Sam, HandComputedSpectra) {
  // Four points within one ball: spectra (1, 0), (0, 1), (1, 0), (0, 1).
  // The mean is (0.5, 0.5): every point is 45° from it. Scaling a point's
  // spectrum changes nothing at that point.
  ced::point_cloud c;
  for (int i = 0; i < 4; ++i) c.push_back(0.01f * float(i), 0, 0);
  c.add_field("a", ced::scalar_type::float32, {1, 0, 1, 0});
  c.add_field("b", ced::scalar_type::float32, {0, 1, 0, 1});
  ced::detect_params p;
  p.radius = p.nms_radius = 0.1;
  p.min_neighbors = 1;
  const auto r = ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("sam(a,b):0.5")});
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(r.saliency[0][std::size_t(i)], M_PI / 4, 1e-6) << i;
  EXPECT_EQ(r.names[0], "sam(a,b)");
  // A zero spectrum has no direction: an error naming the point.
  ced::point_cloud z;
  for (int i = 0; i < 4; ++i) z.push_back(0.01f * float(i), 0, 0);
  z.add_field("a", ced::scalar_type::float32, {1, 1, 0, 1});
  z.add_field("b", ced::scalar_type::float32, {2, 2, 0, 2});
  try {
    ced::detect(z, p, std::vector<ced::any_modality>{ced::make_modality("sam(a,b):0.5")});
    ADD_FAILURE() << "a zero spectrum was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("point 2 has every band 0"), std::string::npos) << e.what();
  }
  // A mean spectrum of zero (negative bands that cancel): 0, not an error.
  ced::point_cloud m;
  for (int i = 0; i < 2; ++i) m.push_back(0.01f * float(i), 0, 0);
  m.add_field("a", ced::scalar_type::float32, {1, -1});
  m.add_field("b", ced::scalar_type::float32, {1, -1});
  const auto rm = ced::detect(m, p, std::vector<ced::any_modality>{ced::make_modality("sam(a,b):0.5")});
  for (int i = 0; i < 2; ++i) EXPECT_EQ(rm.saliency[0][std::size_t(i)], 0.0f) << i;
}

TEST(Sam, MatchesTheOracleAndIgnoresBrightness) {
  for (const std::size_t bands : {std::size_t(3), std::size_t(24)}) {
    SCOPED_TRACE(std::to_string(bands) + " bands");
    const auto c = spectral_room(2500, bands, 7);
    std::vector<std::string> names;
    for (std::size_t b = 0; b < bands; ++b) names.push_back((b < 10 ? "s0" : "s") + std::to_string(b));
    ced::detect_params p;
    p.threads = 2;
    const auto got = ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("sam(s*):0.005")});
    const auto want = oracle_angles(c, names, p.radius, p.min_neighbors);
    double biggest = 0;
    for (std::size_t i = 0; i < c.size(); ++i) {
      ASSERT_NEAR(got.saliency[0][i], want[i], 2e-5 + 1e-4 * want[i]) << "point " << i;
      biggest = std::max(biggest, want[i]);
    }
    EXPECT_GT(biggest, 0.01);
    EXPECT_GT(got.keypoints.size(), 3u);
    // The same spectra at constant brightness: the angles barely move,
    // while the bands' distance follows the brightness.
    const auto flat = spectral_room(2500, bands, 7, false);
    const auto angles_flat = ced::detect(flat, p, std::vector<ced::any_modality>{ced::make_modality("sam(s*):0.005")});
    const auto dist =
        ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(s*):0.01,range=0..2")});
    const auto dist_flat =
        ced::detect(flat, p, std::vector<ced::any_modality>{ced::make_modality("bands(s*):0.01,range=0..2")});
    double angle_change = 0, dist_change = 0;
    for (std::size_t i = 0; i < c.size(); ++i) {
      angle_change += std::abs(got.saliency[0][i] - angles_flat.saliency[0][i]);
      dist_change += std::abs(dist.saliency[0][i] - dist_flat.saliency[0][i]) / double(bands);
    }
    EXPECT_LT(angle_change, 0.2 * dist_change) << angle_change << " against " << dist_change;
  }
}

TEST(Sam, AnyThreadCountAndExactTiles) {
  const auto c = spectral_room(6000, 20, 11);
  ced::detect_params p;
  p.threads = 1;
  const std::vector<ced::any_modality> m = {ced::make_modality("sam(s00..s19):0.01")};
  const auto one = ced::detect(c, p, m);
  ASSERT_GT(one.keypoints.size(), 5u);
  for (unsigned t : {2u, 3u}) {
    p.threads = t;
    const auto other = ced::detect(c, p, m);
    EXPECT_EQ(other.saliency, one.saliency) << t;
    EXPECT_EQ(other.keypoints, one.keypoints) << t;
  }
  for (double tile : {0.4, 0.23}) EXPECT_EQ(ced::detect_tiled(c, p, m, tile), one.keypoints) << "tile " << tile;
}

TEST(Sam, ClearErrors) {
  const auto c = spectral_room(200, 3, 3);
  ced::detect_params p;
  auto message = [&](const std::string& spec) {
    try {
      ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality(spec)});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("sam(s00)").find("at least two"), std::string::npos);
  EXPECT_NE(message("sam(swir*)").find("matches no field"), std::string::npos);
  // Bands of different types are in different units.
  auto mixed = c;
  mixed.add_field("dn", ced::scalar_type::uint16, std::vector<double>(mixed.size(), 300.0));
  try {
    ced::detect(mixed, p, std::vector<ced::any_modality>{ced::make_modality("sam(s00,s01,dn)")});
    ADD_FAILURE() << "bands of mixed types were accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("bands of different types ('s00' float32, 'dn' uint16)"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ced::make_modality("sam"), std::invalid_argument);
  EXPECT_EQ(ced::make_modality("sam(s00,s01)").threshold({}), 0.05);
}
