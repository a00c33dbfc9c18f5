// SPDX-License-Identifier: MIT
#include "ced/io/rgbd.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "ced/io/output_file.hpp"
#include "ced/io/transform.hpp"
#include "io/base/scalar_io.hpp"

// stb_image is compiled in with internal linkage (as stb_image_write in
// render.cpp); its warnings are silenced as a system header's (CMake).
#define STB_IMAGE_STATIC
// Only the formats of RGB-D frames: every other stb parser is attack surface
// (its PNM header parser overflows ints, found by fuzz_rgbd).
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
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

/// An image's size from its header alone, so that no image of another size
/// is ever decoded (a forged header cannot make the decoder allocate more
/// than the camera's frame).
void check_size(std::string_view bytes, const std::string& name, int width, int height, const char* what) {
  const auto size = image_size(bytes, name + " (" + what + " image)");
  if (size[0] != width || size[1] != height)
    throw io_error(name + ": " + what + " image is " + size_text(size[0], size[1]) + " but the intrinsics say " +
                   size_text(width, height));
}

bool is_png(std::string_view b) {
  return b.size() >= 8 && b.compare(0, 8, std::string_view("\x89PNG\r\n\x1a\n", 8)) == 0;
}

/// SOI, after any 0xFF fill bytes (stb skips them too); returns its offset + 2, or 0.
std::size_t jpeg_start(std::string_view b) {
  std::size_t pos = 0;
  while (pos + 1 < b.size() && static_cast<unsigned char>(b[pos]) == 0xFF &&
         static_cast<unsigned char>(b[pos + 1]) == 0xFF)
    ++pos;
  if (pos + 1 >= b.size() || static_cast<unsigned char>(b[pos]) != 0xFF ||
      static_cast<unsigned char>(b[pos + 1]) != 0xD8)
    return 0;
  return pos + 2;
}
bool is_jpeg(std::string_view b) { return jpeg_start(b) != 0; }

std::string printable_tag(const std::string& t) {
  std::string out;
  for (char c : t) out += (c >= 32 && c < 127) ? c : '?';
  return out;
}

/// Debian's stb_image (2022-09-08) trusts a JPEG Huffman table's code
/// counts: a DHT segment whose 16 counts sum past 256 makes it write past its
/// tables (stb issues #1289/#1291, fixed upstream later; found here by
/// fuzz_rgbd). So every DHT segment is checked before stb sees the bytes:
/// the markers are walked (entropy-coded data skipped up to the next
/// marker), and a table of more than 256 codes, or one past its segment, is
/// an error.
void check_jpeg_tables(std::string_view b, const std::string& name) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(b[i]); };
  std::size_t pos = jpeg_start(b);
  if (pos == 0) return;  // not a JPEG
  while (pos + 1 < b.size()) {
    if (byte(pos) != 0xFF) {  // entropy-coded data: on to the next marker
      ++pos;
      continue;
    }
    const unsigned m = byte(pos + 1);
    if (m == 0xFF) {  // fill byte
      ++pos;
      continue;
    }
    if (m == 0x00 || m == 0x01 || (m >= 0xD0 && m <= 0xD8)) {  // stuffed byte, TEM, RSTn, SOI: no length
      pos += 2;
      continue;
    }
    if (m == 0xD9) return;  // EOI
    if (pos + 4 > b.size()) return;
    const std::size_t length = std::size_t(byte(pos + 2)) << 8 | byte(pos + 3);
    const std::size_t end = std::min(b.size(), pos + 2 + length);
    if (m == 0xC4)
      for (std::size_t p = pos + 4; p < end;) {
        if (p + 17 > end) throw io_error(name + ": corrupt JPEG: a Huffman table is cut short");
        std::size_t codes = 0;
        for (std::size_t k = 1; k <= 16; ++k) codes += byte(p + k);
        if (codes > 256)
          throw io_error(name + ": corrupt JPEG: a Huffman table declares " + std::to_string(codes) +
                         " codes (at most 256)");
        p += 17 + codes;
        if (p > end) throw io_error(name + ": corrupt JPEG: a Huffman table runs past its segment");
      }
    pos = pos + 2 + length;
  }
}

/// stb_image grows its buffer for a PNG's image data to what an IDAT chunk
/// claims before reading it, so a 400-byte file claiming 2 GB makes it
/// allocate 2 GB (found by fuzz_rgbd). Every chunk must fit in the file.
void check_png_chunks(std::string_view b, const std::string& name) {
  if (!is_png(b)) return;
  std::size_t pos = 8;
  bool data = false;
  while (pos + 8 <= b.size()) {
    std::uint64_t length = 0;
    for (std::size_t k = 0; k < 4; ++k) length = length << 8 | static_cast<unsigned char>(b[pos + k]);
    const std::string type(b.substr(pos + 4, 4));
    if (length + 12 > b.size() - pos)
      throw io_error(name + ": corrupt PNG: chunk '" + printable_tag(type) + "' claims " + std::to_string(length) +
                     " bytes, the file has " + std::to_string(b.size() - pos) + " left");
    // An empty IDAT before any image data makes stb memcpy to a null buffer
    // (undefined behaviour, found by fuzz_rgbd); no camera writes one.
    if (type == "IDAT" && length == 0 && !data)
      throw io_error(name + ": corrupt PNG: an empty IDAT chunk before any image data");
    data = data || type == "IDAT";
    pos += 12 + length;
    if (type == "IEND") return;
  }
}

int stb_length(std::string_view bytes, const std::string& name) {
  if (bytes.size() > std::size_t(std::numeric_limits<int>::max()))
    throw io_error(name + ": the image file is too large (" + std::to_string(bytes.size()) + " bytes)");
  return static_cast<int>(bytes.size());
}

const stbi_uc* stb_bytes(std::string_view bytes) { return reinterpret_cast<const stbi_uc*>(bytes.data()); }

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

std::array<int, 2> image_size(std::string_view bytes, const std::string& name) {
  if (!is_png(bytes) && !is_jpeg(bytes)) throw io_error(name + ": not a PNG or JPEG image");
  check_jpeg_tables(bytes, name);  // stb reads the tables before SOF for the header too
  check_png_chunks(bytes, name);
  int w = 0, h = 0, c = 0;
  if (!stbi_info_from_memory(stb_bytes(bytes), stb_length(bytes, name), &w, &h, &c))
    throw io_error(name + ": not an image stb can read: " + stbi_failure_reason());
  return {w, h};
}

std::vector<std::uint16_t> decode_depth_image(std::string_view bytes, const std::string& name, int width, int height) {
  check_size(bytes, name, width, height, "depth");
  check_jpeg_tables(bytes, name);
  const int n = stb_length(bytes, name);
  if (!stbi_is_16_bit_from_memory(stb_bytes(bytes), n))
    throw io_error(name + ": the depth image must be a 16-bit greyscale PNG");
  int w = 0, h = 0, c = 0;
  const stbi_buffer<std::uint16_t> depth(stbi_load_16_from_memory(stb_bytes(bytes), n, &w, &h, &c, 0));
  if (!depth) throw io_error(name + ": cannot decode the depth image: " + stbi_failure_reason());
  if (c != 1) throw io_error(name + ": the depth image must have one channel (greyscale), it has " + std::to_string(c));
  if (w != width || h != height)
    throw io_error(name + ": the depth image decodes to " + size_text(w, h) + ", its header said " +
                   size_text(width, height));
  return std::vector<std::uint16_t>(depth.get(), depth.get() + std::size_t(w) * std::size_t(h));
}

std::vector<std::uint8_t> decode_colour_image(std::string_view bytes, const std::string& name, int width, int height) {
  check_size(bytes, name, width, height, "colour");
  check_jpeg_tables(bytes, name);
  int w = 0, h = 0, c = 0;
  const stbi_buffer<std::uint8_t> colour(
      stbi_load_from_memory(stb_bytes(bytes), stb_length(bytes, name), &w, &h, &c, 3));
  if (!colour) throw io_error(name + ": cannot read the colour image: " + stbi_failure_reason());
  if (w != width || h != height)
    throw io_error(name + ": the colour image decodes to " + size_text(w, h) + ", its header said " +
                   size_text(width, height));
  return std::vector<std::uint8_t>(colour.get(), colour.get() + 3 * std::size_t(w) * std::size_t(h));
}

point_cloud read_rgbd(const std::string& depth_path, const std::string& color_path, const camera_intrinsics& k,
                      const rgbd_options& options) {
  const std::string depth_bytes = detail::read_whole_file(depth_path);
  const std::string colour_bytes = detail::read_whole_file(color_path);
  // Both sizes are checked against the intrinsics before either is decoded.
  check_size(depth_bytes, depth_path, k.width, k.height, "depth");
  check_size(colour_bytes, color_path, k.width, k.height, "colour");
  const auto depth = decode_depth_image(depth_bytes, depth_path, k.width, k.height);
  const auto colour = decode_colour_image(colour_bytes, color_path, k.width, k.height);
  return back_project(depth.data(), colour.data(), k.width, k.height, k, options);
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
