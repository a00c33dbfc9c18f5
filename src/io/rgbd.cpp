// SPDX-License-Identifier: MIT
#include "ced/io/rgbd.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "ced/io/output_file.hpp"
#include "ced/io/transform.hpp"

// stb_image is compiled in with internal linkage (as stb_image_write in
// render.cpp); its warnings are silenced as a system header's (CMake).
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb_image.h>

namespace ced::io {

namespace {

struct stbi_deleter {
  void operator()(void* p) const noexcept { stbi_image_free(p); }
};
template <typename T>
using stbi_buffer = std::unique_ptr<T, stbi_deleter>;

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

double positive_number(const nlohmann::json& j, const std::string& path, const std::string& what) {
  if (!j.is_number() || !(j.get<double>() > 0) || !std::isfinite(j.get<double>()))
    throw io_error(path + ": " + what + " must be a positive number");
  return j.get<double>();
}

/// An image width or height: a whole number from 1 to max_image_side.
constexpr double max_image_side = 65535;
int image_side(const nlohmann::json& j, const std::string& path, const std::string& what) {
  const double v = positive_number(j, path, what);
  if (v != std::floor(v) || v > max_image_side)
    throw io_error(path + ": " + what + " must be a whole number of pixels from 1 to 65535");
  return static_cast<int>(v);
}

/// Reads only the header of an image file and checks its size against the
/// intrinsics, so that no image of another size is ever decoded (a forged
/// header cannot make the decoder allocate more than the camera's frame).
void check_image_size(const std::string& path, const camera_intrinsics& k, const char* what) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw io_error(path + ": cannot open the " + what + " image");
  int w = 0, h = 0, c = 0;
  const int ok = stbi_info_from_file(f, &w, &h, &c);
  std::fclose(f);
  if (!ok) throw io_error(path + ": cannot read the " + what + " image: " + stbi_failure_reason());
  if (w != k.width || h != k.height)
    throw io_error(path + ": " + what + " image is " + size_text(w, h) + " but the intrinsics say " +
                   size_text(k.width, k.height));
}

}  // namespace

camera_intrinsics read_intrinsics(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw io_error(path + ": cannot open the intrinsics file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw io_error(path + ": not valid JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("width") || !j.contains("height") || !j.contains("intrinsic_matrix"))
    throw io_error(path + ": expected Open3D camera intrinsics: an object with width, height and intrinsic_matrix");
  const auto& m = j["intrinsic_matrix"];
  if (!m.is_array() || m.size() != 9)
    throw io_error(path + ": intrinsic_matrix must be an array of 9 numbers (column-major 3x3)");
  for (const auto& v : m)
    if (!v.is_number()) throw io_error(path + ": intrinsic_matrix must hold numbers only");
  camera_intrinsics k;
  k.width = image_side(j["width"], path, "width");
  k.height = image_side(j["height"], path, "height");
  k.fx = positive_number(m[0], path, "fx (intrinsic_matrix[0])");
  k.fy = positive_number(m[4], path, "fy (intrinsic_matrix[4])");
  k.cx = m[6].get<double>();
  k.cy = m[7].get<double>();
  return k;
}

point_cloud back_project(const std::uint16_t* depth, const std::uint8_t* rgb, int width, int height,
                         const camera_intrinsics& k, const rgbd_options& options) {
  if (width != k.width || height != k.height)
    throw std::invalid_argument("image size " + size_text(width, height) + " differs from the intrinsics' " +
                                size_text(k.width, k.height));
  if (!(k.fx > 0) || !(k.fy > 0)) throw std::invalid_argument("focal lengths fx and fy must be positive");
  if (!(options.depth_scale > 0) || !(options.depth_max >= 0))
    throw std::invalid_argument("depth scale must be positive and the maximum depth >= 0");
  point_cloud cloud;
  std::vector<double> channel[3];
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const std::size_t pixel = std::size_t(v) * std::size_t(width) + std::size_t(u);
      const double z = depth[pixel] / options.depth_scale;
      if (depth[pixel] == 0 || (options.depth_max > 0 && z > options.depth_max)) continue;
      cloud.push_back(static_cast<float>((u - k.cx) * z / k.fx), static_cast<float>((v - k.cy) * z / k.fy),
                      static_cast<float>(z));
      if (rgb)
        for (std::size_t c = 0; c < 3; ++c) channel[c].push_back(rgb[3 * pixel + c]);
    }
  if (rgb) {
    cloud.add_field("red", scalar_type::uint8, std::move(channel[0]));
    cloud.add_field("green", scalar_type::uint8, std::move(channel[1]));
    cloud.add_field("blue", scalar_type::uint8, std::move(channel[2]));
  }
  return cloud;
}

point_cloud read_rgbd(const std::string& depth_path, const std::string& color_path, const camera_intrinsics& k,
                      const rgbd_options& options) {
  check_image_size(depth_path, k, "depth");
  check_image_size(color_path, k, "colour");
  int dw = 0, dh = 0, dc = 0;
  std::FILE* f = std::fopen(depth_path.c_str(), "rb");
  if (!f) throw io_error(depth_path + ": cannot open the depth image");
  const bool sixteen = stbi_is_16_bit_from_file(f) != 0;
  stbi_buffer<std::uint16_t> depth(sixteen ? stbi_load_from_file_16(f, &dw, &dh, &dc, 0) : nullptr);
  std::fclose(f);
  if (!sixteen) throw io_error(depth_path + ": the depth image must be a 16-bit greyscale PNG");
  if (!depth) throw io_error(depth_path + ": cannot decode the depth image: " + stbi_failure_reason());
  if (dc != 1)
    throw io_error(depth_path + ": the depth image must have one channel (greyscale), it has " + std::to_string(dc));
  int cw = 0, ch = 0, cc = 0;
  stbi_buffer<std::uint8_t> colour(stbi_load(color_path.c_str(), &cw, &ch, &cc, 3));
  if (!colour) throw io_error(color_path + ": cannot read the colour image: " + stbi_failure_reason());
  if (cw != dw || ch != dh)
    throw io_error(color_path + ": colour image is " + size_text(cw, ch) + " but the depth image " + depth_path +
                   " is " + size_text(dw, dh));
  if (dw != k.width || dh != k.height)
    throw io_error(depth_path + ": image is " + size_text(dw, dh) + " but the intrinsics say " +
                   size_text(k.width, k.height));
  return back_project(depth.get(), colour.get(), dw, dh, k, options);
}

std::vector<eval::rigid_transform> read_trajectory_log(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw io_error(path + ": cannot open the trajectory log");
  std::vector<eval::rigid_transform> poses;
  std::string line;
  int line_no = 0;
  auto next_line = [&]() -> bool {
    while (std::getline(in, line)) {
      ++line_no;
      if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
    }
    return false;
  };
  while (next_line()) {
    std::istringstream header(line);
    long a = 0, b = 0, c = 0;
    if (!(header >> a >> b >> c))
      throw io_error(path + ": line " + std::to_string(line_no) + ": expected a frame header 'i j n'");
    std::ostringstream matrix;
    for (int row = 0; row < 4; ++row) {
      if (!next_line())
        throw io_error(path + ": frame at line " + std::to_string(line_no) + " has fewer than 4 matrix rows");
      matrix << line << '\n';
    }
    std::istringstream rows(matrix.str());
    poses.push_back(eval::parse_transform(rows, path + " (matrix ending at line " + std::to_string(line_no) + ")"));
  }
  if (poses.empty()) throw io_error(path + ": no poses in the trajectory log");
  return poses;
}

}  // namespace ced::io
