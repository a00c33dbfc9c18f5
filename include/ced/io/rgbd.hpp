// SPDX-License-Identifier: MIT
// RGB-D frames as coloured point clouds: a 16-bit depth image and a colour
// image back-projected through pinhole intrinsics (Open3D's conventions), and
// the camera poses of an Open3D trajectory log.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/error.hpp"
#include "ced/transform.hpp"

namespace ced::io {

/// Pinhole camera: pixel (u, v) with depth z is the point
/// ((u − cx) z / fx, (v − cy) z / fy, z) in the camera frame (x right, y down, z forward).
struct camera_intrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

/// How depth values become metres, and which are kept.
struct rgbd_options {
  double depth_scale = 1000.0;  ///< depth value / depth_scale = metres (1000: millimetres)
  double depth_max = 3.0;       ///< points farther than this (metres) are dropped; 0 = keep all
};

/// Reads Open3D's camera JSON: {"width": W, "height": H, "intrinsic_matrix": [9
/// numbers, column-major]}. Throws io_error naming the file and the problem.
camera_intrinsics read_intrinsics(const std::string& path);

/// Back-projects a depth image (`width`×`height` 16-bit values, row-major; 0 =
/// no measurement) with its colour image (same size, 3 bytes per pixel, RGB)
/// into a cloud with uchar red/green/blue fields, in pixel order (row by row),
/// one point per valid pixel. `rgb` may be null (no colour fields). Throws
/// std::invalid_argument when the sizes disagree with the intrinsics or a
/// parameter is not positive.
point_cloud back_project(const std::uint16_t* depth, const std::uint8_t* rgb, int width, int height,
                         const camera_intrinsics& k, const rgbd_options& options = {});

/// Reads a 16-bit single-channel depth PNG and a colour image (PNG/JPEG/...)
/// and back-projects them. Throws io_error naming the file when one cannot be
/// read, the depth image is not 16-bit greyscale, or the image sizes differ
/// from each other or from the intrinsics.
point_cloud read_rgbd(const std::string& depth_path, const std::string& color_path, const camera_intrinsics& k,
                      const rgbd_options& options = {});

/// The width and height of an encoded image (PNG, JPEG, BMP, ...) from its
/// header alone. Throws io_error naming `name` when stb cannot read it.
std::array<int, 2> image_size(std::string_view bytes, const std::string& name);
/// Decodes a 16-bit single-channel depth image (PNG) of `width`×`height`
/// pixels: the header's size is checked before anything is decoded, so a
/// forged header cannot make it allocate more. Throws io_error naming
/// `name` for any other size, channel count or depth, or undecodable data.
std::vector<std::uint16_t> decode_depth_image(std::string_view bytes, const std::string& name, int width, int height);
/// Decodes a colour image to width×height×3 bytes (RGB), the size checked
/// first in the same way. Throws io_error naming `name`.
std::vector<std::uint8_t> decode_colour_image(std::string_view bytes, const std::string& name, int width, int height);

/// Reads an Open3D trajectory log: per frame a line "i j n" followed by the 4
/// rows of its camera-to-world matrix. Returns the poses in file order.
/// Throws io_error naming the file and line on malformed input.
std::vector<eval::rigid_transform> read_trajectory_log(const std::string& path);

}  // namespace ced::io
