// SPDX-License-Identifier: MIT
// Corner: how far the surface normals around a point spread in all three
// directions. With M the mean orientation tensor n nᵀ of the unit normals of
// the point's neighbours (the point itself included; read or estimated by
// PCA, exactly as the normals modality takes them):
//
//     s_i = det(M)^(1/3)   in [0, 1/3]
//
// It is 0 on a plane and along a crease of two planes (normals in at most two
// directions) and large where three or more surfaces meet: points a keypoint
// can be pinned to, where a point on an edge can slide along it. It is the
// measure of Harris3D (det of the normals' covariance) in ced's
// neighbourhoods, NMS and tiles. The centroid of the tensors comes from the
// same neighbour sums as every centroid distance: M = T_i + Σ(T_j − T_i)/n.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "ced/channels.hpp"
#include "ced/modalities/normals.hpp"
#include "ced/modality.hpp"

namespace ced {

struct corner {
  static constexpr const char* spec_name = "corner";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help =
      "geometry: spread of the neighbours' normals in three directions, det(mean n nT)^(1/3); options radius=, from=";
  double threshold_value = 0.05;
  /// Where the normals come from, as for the normals modality.
  normals normal_source{0, normals::source::automatic, 1};

  corner() = default;
  explicit corner(double threshold, double radius = 1) : threshold_value(threshold) {
    normals::check_radius(radius);
    normal_source.radius_factor = radius;
  }

  std::string name() const { return "corner"; }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads (none when it estimates).
  std::vector<std::string> fields() const { return normal_source.fields(); }
  bool channels_from_neighborhoods() const { return normal_source.channels_from_neighborhoods(); }

  struct evaluator {
    std::vector<float> tensors;  // N×6: xx, yy, zz, xy, xz, yz of each unit normal
    channel_source channels() const { return {tensors.data(), 6, false}; }
    float from_sums(const double* sums, std::uint32_t n, std::uint32_t point) const {
      const float* t = tensors.data() + 6 * std::size_t(point);
      double m[6];
      for (int d = 0; d < 6; ++d) m[d] = t[d] + sums[d] / n;
      // | xx xy xz |
      // | xy yy yz |
      // | xz yz zz |
      const double det =
          m[0] * (m[1] * m[2] - m[5] * m[5]) - m[3] * (m[3] * m[2] - m[5] * m[4]) + m[4] * (m[3] * m[5] - m[1] * m[4]);
      return static_cast<float>(std::cbrt(std::max(0.0, det)));
    }
  };
  evaluator bind(const point_cloud& cloud, const detect_params& params) const {
    return {normal_tensors(normal_source.unit_normals(cloud, params))};
  }
  static corner from_spec(modality_spec& s) {
    corner c;
    c.normal_source = normals::from_spec(s);  // radius=, from=
    c.threshold_value = s.threshold_or(0.05);
    return c;
  }
};

}  // namespace ced
