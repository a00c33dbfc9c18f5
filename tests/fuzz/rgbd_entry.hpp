// SPDX-License-Identifier: MIT
// What fuzz_rgbd feeds one input to (shared with test_fuzz_regressions): the
// stb decoding of user RGB-D images. The header's size stands in for the
// camera's intrinsics, bounded as a camera frame would bound it; the input is
// decoded as a depth image (and back-projected) and as a colour image. Must
// return, or throw io_error / std::invalid_argument.
#pragma once

#include <cstdint>
#include <string_view>

#include "ced/io/output_file.hpp"
#include "ced/io/rgbd.hpp"

namespace ced_fuzz {

inline void rgbd_one(std::string_view bytes) {
  const auto size = ced::io::image_size(bytes, "fuzz.img");
  if (size[0] < 1 || size[1] < 1 || std::uint64_t(size[0]) * std::uint64_t(size[1]) > (std::uint64_t(1) << 22))
    return;  // intrinsics would refuse it before decoding
  ced::io::camera_intrinsics k;
  k.width = size[0];
  k.height = size[1];
  k.fx = k.fy = 500;
  k.cx = 0.5 * size[0];
  k.cy = 0.5 * size[1];
  try {
    const auto depth = ced::io::decode_depth_image(bytes, "fuzz.img", size[0], size[1]);
    (void)ced::io::back_project(depth.data(), nullptr, size[0], size[1], k).size();
  } catch (const ced::io::io_error&) {
  }
  (void)ced::io::decode_colour_image(bytes, "fuzz.img", size[0], size[1]).size();
}

}  // namespace ced_fuzz
