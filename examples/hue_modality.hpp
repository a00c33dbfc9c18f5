// SPDX-License-Identifier: MIT
// A modality with its own saliency measure: hue as an angle.
//
// Hue is circular (350° and 10° are 20° apart), so its centroid must be the
// circular mean: the mean of the unit vectors (cos h, sin h), weighted by
// saturation so that greys (whose hue means nothing) do not vote. The
// saliency of point i is the angle between its hue and that mean, in [0, 1]
// (1 = opposite hues), times the point's own saturation.
#pragma once

#include <ced/ced.hpp>
#include <cmath>

namespace example {

struct hue {
  static constexpr const char* spec_name = "hue";
  double threshold_value = 0.1;

  std::string name() const { return "hue"; }
  double threshold(const ced::detect_params&) const { return threshold_value; }
  std::vector<std::string> fields() const { return ced::rgb_field_names(); }

  struct evaluator {
    std::vector<float> c, s, sat;  // saturation-weighted cos/sin of hue, saturation
    float operator()(const ced::neighborhood& nb) const {
      double mc = 0, ms = 0;
      for (std::uint32_t j : nb) {
        mc += c[j];
        ms += s[j];
      }
      const std::uint32_t i = nb.point;
      if (sat[i] == 0 || (mc == 0 && ms == 0)) return 0.0f;
      const double pi = 3.14159265358979323846;
      double d = std::atan2(s[i], c[i]) - std::atan2(ms, mc);
      d = std::abs(std::remainder(d, 2 * pi));  // wrapped to [0, π]
      return static_cast<float>(d / pi * sat[i]);
    }
  };

  evaluator bind(const ced::point_cloud& cloud, const ced::detect_params&) const {
    const auto f = ced::rgb::fields(cloud);
    const auto scale = ced::rgb::scale(f, std::nullopt);
    evaluator e;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const double r = f[0]->values[i] * scale[0], g = f[1]->values[i] * scale[1], b = f[2]->values[i] * scale[2];
      const double mx = std::max({r, g, b}), mn = std::min({r, g, b});
      const double sat = mx > 0 ? (mx - mn) / mx : 0.0;
      // Hue angle from the hexagonal projection (atan2 form).
      const double h = std::atan2(std::sqrt(3.0) * (g - b), 2 * r - g - b);
      e.c.push_back(static_cast<float>(sat * std::cos(h)));
      e.s.push_back(static_cast<float>(sat * std::sin(h)));
      e.sat.push_back(static_cast<float>(sat));
    }
    return e;
  }

  static hue from_spec(ced::modality_spec& s) { return {s.threshold_or(0.1)}; }
};

}  // namespace example
