// SPDX-License-Identifier: MIT
// Surface normals: how far a point's normal direction is from the mean
// direction of its neighbours' normals, a curvature-like channel that
// composes with colour and bands.
//
// A normal n is taken as an axis (n and −n the same) through its orientation
// tensor T = n nᵀ, so normals need no consistent orientation:
//
//     s_i = || mean_{N(i)} T_j − T_i ||_F   in [0, √2)
//
// (0 on a plane; about 0.71 on the crease of two perpendicular planes).
// Normals come from the fields nx, ny, nz (any case) when the cloud has all
// three, or else from PCL's normal_x, normal_y, normal_z; otherwise they are estimated by PCA over the neighbours
// within `radius=K` × the detection radius (0 < K ≤ 1, default 1): `from=fields` or `from=estimate` forces either. The
// estimate reads at most K·r around a neighbour, so tiled runs stay exact with the usual halo.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/channels.hpp"
#include "ced/modality.hpp"

namespace ced {

struct normals {
  static constexpr const char* spec_name = "normals";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help =
      "surface normals (nx,ny,nz or PCA): orientation-tensor distance; options radius=, from=";
  enum class source { automatic, fields, estimate };
  double threshold_value = 0.2;
  double radius_factor = 1;  ///< estimation radius, × the detection radius, in (0, 1]
  source from = source::automatic;

  normals() = default;
  explicit normals(double threshold, source s = source::automatic, double radius = 1)
      : threshold_value(threshold), radius_factor(radius), from(s) {
    check_radius(radius);
  }

  std::string name() const { return "normals"; }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads (none when it estimates).
  std::vector<std::string> fields() const {
    if (from == source::estimate) return {};
    return {"nx", "ny", "nz", "normal_x", "normal_y", "normal_z"};
  }
  centroid_distance<6> bind(const point_cloud& cloud, const detect_params& params) const {
    const double r2 = std::sqrt(2.0);
    return centroid_distance<6>(normal_tensors(unit_normals(cloud, params)), {1, 1, 1, r2, r2, r2}, norm_type::l2);
  }
  /// Estimated normals come from each point's own neighbourhood (under knn
  /// or adaptive; within K·r of it under the fixed radius): tiles reach one
  /// neighbourhood farther for them. Read ones depend on the point alone.
  bool channels_from_neighborhoods() const { return from != source::fields; }
  /// The normals bind() uses: read or estimated (N×3).
  std::vector<float> unit_normals(const point_cloud& cloud, const detect_params& params) const {
    const auto has = [&](const char* x, const char* y, const char* z) {
      return cloud.find_field_icase(x) && cloud.find_field_icase(y) && cloud.find_field_icase(z);
    };
    const bool pcl_names = !has("nx", "ny", "nz") && has("normal_x", "normal_y", "normal_z");
    if (from == source::fields || (from == source::automatic && (pcl_names || has("nx", "ny", "nz")))) {
      const auto f = pcl_names ? require_fields(cloud, {"normal_x", "normal_y", "normal_z"}, "normals")
                               : require_fields(cloud, {"nx", "ny", "nz"}, "normals");
      return interleave(f, params.threads);
    }
    check_radius(radius_factor);
    return estimate_normals(cloud, params, radius_factor);
  }
  static normals from_spec(modality_spec& s) {
    normals m;
    m.threshold_value = s.threshold_or(0.2);
    if (auto r = s.take("radius")) {
      const double k = parse_number(*r, "radius= of normals in '" + s.text() + "'");
      check_radius(k);
      m.radius_factor = k;
    }
    if (auto f = s.take("from")) {
      if (*f == "auto")
        m.from = source::automatic;
      else if (*f == "fields")
        m.from = source::fields;
      else if (*f == "estimate")
        m.from = source::estimate;
      else
        throw std::invalid_argument("normals: from must be auto, fields or estimate, got '" + *f + "'");
    }
    return m;
  }
  static void check_radius(double k) {
    if (!(k > 0 && k <= 1))
      throw std::invalid_argument("normals: radius is a factor of the detection radius in (0, 1], got " +
                                  std::to_string(k));
  }
};

}  // namespace ced
