// SPDX-License-Identifier: MIT
// Geometry: the L2 distance (metres) from a point to the centroid of its
// neighbours. The threshold is a ratio of the radius (paper: 0.2).
#pragma once

#include "ced/modality.hpp"

namespace ced {

struct xyz {
  static constexpr const char* spec_name = "xyz";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help =
      "geometry: L2 distance to the neighbours' centroid; threshold = ratio of the radius";
  /// Candidate when the distance to the centroid is ≥ ratio × radius.
  double ratio = 0.2;

  xyz() = default;
  explicit xyz(double threshold_ratio) : ratio(threshold_ratio) {}

  std::string name() const { return "xyz"; }
  double threshold(const detect_params& p) const { return ratio * p.radius; }
  /// The fields bind() reads.
  std::vector<std::string> fields() const { return {}; }
  centroid_distance<3> bind(const point_cloud& cloud, const detect_params&) const {
    return centroid_distance<3>(cloud, {1.0, 1.0, 1.0});
  }
  static xyz from_spec(modality_spec& s) { return xyz(s.threshold_or(0.2)); }
};

}  // namespace ced
