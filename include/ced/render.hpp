// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ced/cloud.hpp"

namespace ced {

/// Where the (orthographic) camera looks from.
enum class view_direction {
  top,    ///< looking down -z: x right, y up
  front,  ///< looking along +y: x right, z up
  iso     ///< rotated 45 degrees about z, then tilted ~35 degrees down
};

struct render_options {
  int width = 1280;  ///< image size in pixels, 1..16384
  int height = 960;
  view_direction view = view_direction::iso;
  float point_size_px = 0;  ///< point diameter; 0 = automatic from the projected density
  /// Keypoint disc diameter; 0 = automatic: 40 % of the keypoints' typical
  /// distance on screen, from 4 pixels up to 3 × the point size (at least
  /// 5), so that dense keypoints on a large scene stay apart.
  float keypoint_size_px = 0;
  /// Colours of the points (3 bytes a point, e.g. from colour_map()) in
  /// place of the cloud's; empty = the cloud's colour fields, or grey.
  std::vector<std::uint8_t> point_colors;
  std::array<std::uint8_t, 3> background{255, 255, 255};
  std::array<std::uint8_t, 3> keypoint_color{230, 20, 20};
};

/// Renders `cloud` orthographically with a software z-buffer, fitting its
/// bounds into the image with a margin; non-finite points are ignored (a cloud
/// without finite points gives a blank image). Points are coloured by the
/// cloud's red/green/blue fields (integers scaled by their type's range, floats
/// taken in [0,1], or in [0,255] / [0,65535] when their maximum exceeds 1 / 255)
/// or, without colour, grey by depth (near dark, far light); eye-dome-style
/// shading brings out the shapes. Keypoints (indices into the cloud) are drawn
/// last, on top of everything, as discs of `keypoint_color` with a thin dark
/// outline; non-finite keypoints are skipped.
///
/// Returns the RGB8 image, row-major from the top row, and sets width/height.
/// Throws std::invalid_argument for an empty cloud, a bad image size or a
/// keypoint index out of range. Threading: reentrant.
std::vector<std::uint8_t> render_rgb(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                                     const render_options& options, int& width, int& height);

/// 3 bytes a value: `values` mapped from [lo, hi] (clamped) to the viridis
/// colour map, for render_options::point_colors. NaN maps to lo.
std::vector<std::uint8_t> colour_map(const std::vector<float>& values, double lo, double hi);

/// Two RGB8 images of the same height, side by side (a left, b right).
std::vector<std::uint8_t> side_by_side(const std::vector<std::uint8_t>& a, int width_a,
                                       const std::vector<std::uint8_t>& b, int width_b, int height);

/// Encodes an RGB8 image (row-major, top row first) as PNG bytes.
std::string encode_png(const std::vector<std::uint8_t>& rgb, int width, int height);

/// render_rgb() written as a PNG file, atomically (see io::atomic_output_file).
/// Throws io::io_error when the file cannot be written.
void render_png(const std::string& path, const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                const render_options& options = {});

}  // namespace ced
