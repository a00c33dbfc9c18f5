// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
// An interactive page of a cloud and its keypoints: one self-contained HTML
// file with a small WebGL viewer, no network request, no external script
// (docs/VIEWER.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"

namespace ced {

struct detection_result;

/// One modality's layer on the page: its saliency of every point of the
/// cloud and its threshold (points at or above it are its candidates).
struct html_layer {
  std::string name;
  double threshold = 0;
  std::vector<float> saliency;
};

struct html_options {
  std::string title = "ced keypoints";
  std::string source;  ///< shown under the title (e.g. the input file)
  /// Rows of the page's "Run" table: parameters, counts, times.
  std::vector<std::pair<std::string, std::string>> info;
  /// The most points drawn. A larger cloud is subsampled for display (every
  /// k-th point, plus every keypoint) and the page says so. >= 1.
  std::size_t max_points = 2000000;
  /// Point spacing in the cloud's unit, for the drawn sizes; 0 = estimated.
  double spacing = 0;
  /// Each point's own radius (detection_result::point_radius under a knn or
  /// adaptive neighbourhood), shown in a picked point's panel; empty: none.
  std::vector<float> point_radius;
};

/// The page: the cloud (coloured by its red/green/blue fields when present,
/// by height, by any layer's saliency, or by candidate/keypoint), the
/// keypoints (indices into `cloud`) as markers sized to the scene, a toggle
/// per layer's candidates, and point picking that shows a point's index,
/// absolute coordinates (origin() included) and every layer's saliency.
/// Non-finite points are not drawn. Throws std::invalid_argument for a
/// keypoint out of range, a layer whose saliency (or options.point_radius,
/// when given) is not one value a point, or max_points == 0. Deterministic.
std::string html_page(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                      const std::vector<html_layer>& layers, const html_options& options = {});

/// The layers of a detection (its modalities' names, thresholds, saliencies).
std::vector<html_layer> html_layers(const detection_result& result);

/// html_page() written atomically to `path` (io::io_error when it cannot be).
void write_html(const std::string& path, const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                const std::vector<html_layer>& layers, const html_options& options = {});

}  // namespace ced
