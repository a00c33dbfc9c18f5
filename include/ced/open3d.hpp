// SPDX-License-Identifier: MIT
// Open3D point clouds in and out of ced's detector: the optional, header-only
// component `open3d` (find_package(ced COMPONENTS open3d), target
// ced::open3d, which brings Open3D; nothing else in ced includes Open3D).
//
//     open3d::geometry::PointCloud pcd;  open3d::io::ReadPointCloud("scan.ply", pcd);
//     ced::detection_result r = ced::detect(pcd, ced::detect_params{}, ced::preset("ced6d"));
//     std::shared_ptr<open3d::geometry::PointCloud> keypoints = ced::keypoint_cloud(pcd, r);
//
// Fields (ced::from_open3d), as ced's Python module maps an Open3D cloud:
// - points_ are the positions (double: float offsets from an origin, as the
//   file readers store them);
// - colors_ become red, green, blue: uint8 when every value is an exact
//   multiple of 1/255 (colours read from 8-bit files: then results equal the
//   file's), else float64 in [0, 1];
// - normals_ become nx, ny, nz (the normals modality reads them: from=file).
// Every field is copied: Open3D keeps each point's three values together.
#pragma once

#include <open3d/geometry/PointCloud.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "ced/core.hpp"

namespace ced {

namespace detail {
/// Open3D's colours as uint8 red, green, blue columns when every value is an
/// exact multiple of 1/255 in [0, 1] (checked while converting); false, with
/// `out` unfilled, at the first that is not.
inline bool open3d_colours_as_8bit(const std::vector<Eigen::Vector3d>& colours, column out[3]) {
  const std::size_t n = colours.size();
  std::uint8_t* v[3];
  for (int k = 0; k < 3; ++k) {
    out[k] = column(scalar_type::uint8, n);
    v[k] = out[k].data<std::uint8_t>();
  }
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      const double c = colours[i][k], r = std::rint(c * 255.0);
      if (!(r >= 0 && r <= 255 && r / 255.0 == c)) return false;
      v[k][i] = std::uint8_t(r);
    }
  return true;
}
}  // namespace detail

/// A ced cloud from an Open3D cloud (see the top of this header). Point i of
/// the result is point i of `in`. Throws std::invalid_argument naming the
/// point when a coordinate is NaN or infinite (pcd.RemoveNonFinitePoints()
/// removes them), or when colours or normals are present but not one per
/// point.
inline point_cloud from_open3d(const open3d::geometry::PointCloud& in) {
  const std::size_t n = in.points_.size();
  point_cloud cloud;
  const double* p = n ? in.points_.front().data() : nullptr;
  set_positions(cloud, scalar_type::float64, p, p + 1, p + 2, std::ptrdiff_t(sizeof(Eigen::Vector3d)), n,
                "Open3D cloud");
  const auto add = [&](const std::vector<Eigen::Vector3d>& values, const char* what, const char* const names[3],
                       bool may_be_8bit) {
    if (values.empty()) return;
    if (values.size() != n)
      throw std::invalid_argument(std::string("Open3D cloud: ") + std::to_string(values.size()) + " " + what + " for " +
                                  std::to_string(n) + " points");
    column as8[3];
    const bool is_8bit = may_be_8bit && detail::open3d_colours_as_8bit(values, as8);
    for (int k = 0; k < 3; ++k)
      cloud.add_field(names[k], is_8bit ? std::move(as8[k])
                                        : copy_strided(scalar_type::float64, values.front().data() + k,
                                                       std::ptrdiff_t(sizeof(Eigen::Vector3d)), n));
  };
  static const char* const colour_names[3] = {"red", "green", "blue"};
  static const char* const normal_names[3] = {"nx", "ny", "nz"};
  add(in.colors_, "colours", colour_names, true);
  add(in.normals_, "normals", normal_names, false);
  return cloud;
}

/// ced::detect on an Open3D cloud (see from_open3d()), modalities fixed at compile time.
template <class... M, class = std::enable_if_t<(sizeof...(M) > 0) && (is_modality_v<M> && ...)>>
detection_result detect(const open3d::geometry::PointCloud& cloud, const detect_params& params,
                        const M&... modalities) {
  return detect(from_open3d(cloud), params, modalities...);
}
/// ced::detect on an Open3D cloud, modalities chosen at run time (ced::preset, ced::make_modality).
inline detection_result detect(const open3d::geometry::PointCloud& cloud, const detect_params& params,
                               const std::vector<any_modality>& modalities) {
  return detect(from_open3d(cloud), params, modalities);
}

/// The keypoints' indices as Open3D takes them (SelectByIndex, ...).
inline std::vector<std::size_t> to_open3d_indices(const detection_result& result) {
  return std::vector<std::size_t>(result.keypoints.begin(), result.keypoints.end());
}

/// The keypoints of `cloud` as a new Open3D cloud (points, colours and
/// normals): cloud.SelectByIndex(to_open3d_indices(result)).
inline std::shared_ptr<open3d::geometry::PointCloud> keypoint_cloud(const open3d::geometry::PointCloud& cloud,
                                                                    const detection_result& result) {
  return cloud.SelectByIndex(to_open3d_indices(result));
}

}  // namespace ced
