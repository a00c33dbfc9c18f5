// SPDX-License-Identifier: MIT
// CIELAB colour (the paper's footnote): colours converted from sRGB to
// L*a*b* (D65), saliency = Euclidean distance to the neighbours' mean in
// L*a*b* (ΔE*76) divided by 100, so 0.1 means ΔE 10.
#pragma once

#include "ced/channels.hpp"
#include "ced/modalities/rgb.hpp"
#include "ced/modality.hpp"

namespace ced {

struct lab {
  static constexpr const char* spec_name = "lab";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help = "colour in CIELAB: dE*76/100 to the neighbours' mean";
  double threshold_value = 0.1;

  lab() = default;
  explicit lab(double threshold) : threshold_value(threshold) {}

  std::string name() const { return "lab"; }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads.
  std::vector<std::string> fields() const { return rgb_field_names(); }
  centroid_distance<3> bind(const point_cloud& cloud, const detect_params& params) const {
    const auto f = rgb::fields(cloud);
    return centroid_distance<3>(lab_values(f, rgb::scale(f, std::nullopt), params.threads), {0.01, 0.01, 0.01},
                                norm_type::l2);
  }
  static lab from_spec(modality_spec& s) { return lab(s.threshold_or(0.1)); }
};

}  // namespace ced
