// SPDX-License-Identifier: MIT
#include "ced/render.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "ced/io/output_file.hpp"
#include "ced/modalities/rgb.hpp"

// stb is compiled in, with internal linkage so that it cannot clash with a
// copy in the application. Its own warnings are not ours: CMake adds its
// folder as a system include directory, which silences them.
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

namespace ced {

namespace {

constexpr int max_image_size = 16384;

/// Rows: screen right (u), screen up (v), towards the viewer (d).
using basis = std::array<std::array<double, 3>, 3>;

basis view_basis(view_direction view) {
  switch (view) {
    case view_direction::top:
      return {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    case view_direction::front:
      return {{{1, 0, 0}, {0, 0, 1}, {0, -1, 0}}};
    case view_direction::iso:
      break;
  }
  // Rotate about z by 45 degrees, then tilt the camera down by the isometric
  // angle atan(1/sqrt(2)) ~ 35.26 degrees.
  const double c = std::sqrt(0.5), s = std::sqrt(0.5);
  const double tilt = std::atan(std::sqrt(0.5));
  const double st = std::sin(tilt), ct = std::cos(tilt);
  return {{{c, -s, 0}, {st * s, st * c, ct}, {-ct * s, -ct * c, st}}};
}

/// Maps a cloud field to [0,1]: integers by their natural range, floats as
/// they are (or by 255 / 65535 when they obviously hold 8 or 16-bit values).
struct channel {
  const field* f;
  double offset = 0, scale = 1;
  /// `integer_scale`: the scale the rgb modality uses for integer channels
  /// (their range, or 1/255 for 16-bit fields holding 8-bit values).
  channel(const field* fld, double integer_scale) : f(fld) {
    if (is_integer(f->type())) {
      offset = natural_range(f->type())[0];
      scale = integer_scale;
      return;
    }
    double hi = 0;
    for (double v : f->values)
      if (std::isfinite(v)) hi = std::max(hi, v);
    scale = hi > 255.0 ? 1.0 / 65535.0 : hi > 1.0 ? 1.0 / 255.0 : 1.0;
  }
  float operator()(std::size_t i) const {
    const double v = (f->values[i] - offset) * scale;
    return std::isfinite(v) ? static_cast<float>(std::clamp(v, 0.0, 1.0)) : 0.0f;
  }
};

struct projected {
  std::vector<float> u, v, d;  // screen coordinates (model units) and depth towards the viewer
  std::vector<std::uint8_t> ok;
  double umin = 0, umax = 0, vmin = 0, vmax = 0, dmin = 0, dmax = 0;
  std::size_t finite = 0;
};

projected project(const point_cloud& cloud, const basis& b) {
  const std::size_t n = cloud.size();
  projected p;
  p.u.resize(n);
  p.v.resize(n);
  p.d.resize(n);
  p.ok.resize(n);
  constexpr double inf = std::numeric_limits<double>::infinity();
  p.umin = p.vmin = p.dmin = inf;
  p.umax = p.vmax = p.dmax = -inf;
  for (std::size_t i = 0; i < n; ++i) {
    const float* q = cloud.position(i);
    if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) continue;
    double s[3];
    for (int r = 0; r < 3; ++r) s[r] = b[r][0] * q[0] + b[r][1] * q[1] + b[r][2] * q[2];
    if (std::fabs(s[0]) > 1e37 || std::fabs(s[1]) > 1e37 || std::fabs(s[2]) > 1e37) continue;  // float overflow
    p.u[i] = static_cast<float>(s[0]);
    p.v[i] = static_cast<float>(s[1]);
    p.d[i] = static_cast<float>(s[2]);
    p.ok[i] = 1;
    ++p.finite;
    p.umin = std::min(p.umin, s[0]), p.umax = std::max(p.umax, s[0]);
    p.vmin = std::min(p.vmin, s[1]), p.vmax = std::max(p.vmax, s[1]);
    p.dmin = std::min(p.dmin, s[2]), p.dmax = std::max(p.dmax, s[2]);
  }
  return p;
}

/// Model-to-pixel mapping fitting the projected bounds into the image.
struct viewport {
  double scale = 1, cu = 0, cv = 0, cx = 0, cy = 0;
  viewport(const projected& p, int w, int h, double margin) {
    const double aw = std::max(1.0, w - 2 * margin), ah = std::max(1.0, h - 2 * margin);
    const double eu = p.umax - p.umin, ev = p.vmax - p.vmin;
    if (eu > 0 && ev > 0)
      scale = std::min(aw / eu, ah / ev);
    else if (eu > 0 || ev > 0)
      scale = eu > 0 ? aw / eu : ah / ev;
    cu = 0.5 * (p.umin + p.umax), cv = 0.5 * (p.vmin + p.vmax);
    cx = 0.5 * w, cy = 0.5 * h;
  }
  double x(float u) const { return cx + (u - cu) * scale; }
  double y(float v) const { return cy - (v - cv) * scale; }
};

/// Automatic point diameter: the typical spacing of the points on a surface
/// facing the camera. For a surface sampled with spacing s, a cube of side h
/// holds about (h/s)^2 points, so s = h / sqrt(median points per occupied
/// cube), with 8-pixel cubes in view space. Large clouds use a spatial subset
/// of the cubes (which keeps the per-cube counts exact).
float auto_point_size(const projected& p, const viewport& vp, int w, int h) {
  constexpr double cell = 8;
  const auto gw = static_cast<std::uint64_t>(w / cell) + 1, gh = static_cast<std::uint64_t>(h / cell) + 1;
  std::uint64_t stride = 1;
  while (p.finite / stride > 250000) stride *= 2;
  std::vector<std::uint64_t> keys;
  keys.reserve(p.finite / stride + 1024);
  for (std::size_t i = 0; i < p.u.size(); ++i) {
    if (!p.ok[i]) continue;
    const double x = vp.x(p.u[i]) / cell, y = vp.y(p.v[i]) / cell, z = (p.d[i] - p.dmin) * vp.scale / cell;
    if (x < 0 || y < 0 || x >= static_cast<double>(gw) || y >= static_cast<double>(gh) || !(z < 1e9)) continue;
    const std::uint64_t key =
        (static_cast<std::uint64_t>(z) * gh + static_cast<std::uint64_t>(y)) * gw + static_cast<std::uint64_t>(x);
    if ((key * 0x9E3779B97F4A7C15ull >> 40) % stride == 0) keys.push_back(key);
  }
  if (keys.empty()) return 1.0f;
  std::sort(keys.begin(), keys.end());
  std::vector<std::uint32_t> counts;
  for (std::size_t i = 0, j = 0; i < keys.size(); i = j) {
    while (j < keys.size() && keys[j] == keys[i]) ++j;
    counts.push_back(static_cast<std::uint32_t>(j - i));
  }
  const auto mid = counts.begin() + static_cast<std::ptrdiff_t>(counts.size() / 2);
  std::nth_element(counts.begin(), mid, counts.end());
  const double spacing = cell / std::sqrt(static_cast<double>(*mid));
  return static_cast<float>(std::clamp(std::round(spacing * 1.5), 1.0, 10.0));
}

/// Automatic keypoint diameter: 40 % of the typical distance between the
/// keypoints on screen (the area the cloud covers, in cells of the point
/// size, shared among them), at least 4 pixels and at most the default of a
/// sparse set (3 × the point size, at least 5): dense keypoints on a large
/// scene stay apart instead of covering it.
double auto_keypoint_size(const projected& p, const viewport& vp, int w, int h, float point_size,
                          const std::vector<std::uint32_t>& keypoints) {
  const double sparse = std::max(5.0, 3.0 * point_size);
  std::size_t shown = 0;
  for (std::uint32_t k : keypoints) shown += p.ok[k];
  if (shown == 0) return sparse;
  const double cell = std::max(2.0, double(point_size));
  const auto gw = static_cast<std::size_t>(w / cell) + 1, gh = static_cast<std::size_t>(h / cell) + 1;
  std::vector<std::uint8_t> covered(gw * gh, 0);
  std::size_t cells = 0;
  for (std::size_t i = 0; i < p.ok.size(); ++i) {
    if (!p.ok[i]) continue;
    const double x = vp.x(p.u[i]) / cell, y = vp.y(p.v[i]) / cell;
    if (!(x >= 0 && y >= 0 && x < double(gw) && y < double(gh))) continue;
    std::uint8_t& c = covered[static_cast<std::size_t>(y) * gw + static_cast<std::size_t>(x)];
    cells += c == 0;
    c = 1;
  }
  const double spacing = std::sqrt(double(cells) * cell * cell / double(shown));
  return std::clamp(std::round(spacing / 2.5), 4.0, sparse);
}

/// Pixel offsets of a filled disc (a square for diameters below 3).
std::vector<std::array<int, 2>> stamp(int size) {
  std::vector<std::array<int, 2>> offsets;
  const double r = 0.5 * size, c = 0.5 * (size - 1);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double dx = x - c, dy = y - c;
      if (size < 3 || dx * dx + dy * dy <= r * r) offsets.push_back({x - size / 2, y - size / 2});
    }
  return offsets;
}

void draw_keypoint(std::vector<std::uint8_t>& rgb, int w, int h, double cx, double cy, double diameter,
                   const std::array<std::uint8_t, 3>& fill) {
  const std::array<double, 3> outline{30, 30, 30};
  // Small discs get a hairline outline, so that their fill still shows.
  const double r = 0.5 * diameter, border = diameter >= 7 ? std::max(1.0, 0.12 * diameter) : 0.6;
  const int x0 = std::max(0, static_cast<int>(std::floor(cx - r - 1))),
            x1 = std::min(w - 1, static_cast<int>(cx + r + 1));
  const int y0 = std::max(0, static_cast<int>(std::floor(cy - r - 1))),
            y1 = std::min(h - 1, static_cast<int>(cy + r + 1));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dist = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
      const double alpha = std::clamp(r + 0.5 - dist, 0.0, 1.0);  // anti-aliased rim
      if (alpha <= 0) continue;
      const double mix = std::clamp(dist - (r - border) + 0.5, 0.0, 1.0);  // fill -> outline
      std::uint8_t* px =
          &rgb[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x))];
      for (int k = 0; k < 3; ++k) {
        const double c = fill[k] * (1 - mix) + outline[k] * mix;
        px[k] = static_cast<std::uint8_t>(px[k] * (1 - alpha) + c * alpha + 0.5);
      }
    }
}

/// std::invalid_argument for what render_rgb() cannot draw.
void check_render_input(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                        const render_options& options) {
  if (cloud.empty()) throw std::invalid_argument("cannot render an empty point cloud");
  const int w = options.width, h = options.height;
  if (w < 1 || h < 1 || w > max_image_size || h > max_image_size)
    throw std::invalid_argument("invalid image size " + std::to_string(w) + "x" + std::to_string(h) + " (1 to " +
                                std::to_string(max_image_size) + " pixels per side)");
  for (std::uint32_t k : keypoints)
    if (k >= cloud.size())
      throw std::invalid_argument("keypoint index " + std::to_string(k) + " is out of range for a cloud of " +
                                  std::to_string(cloud.size()) + " points");
  if (!options.point_colors.empty() && options.point_colors.size() != 3 * cloud.size())
    throw std::invalid_argument("point_colors holds " + std::to_string(options.point_colors.size()) +
                                " bytes, not 3 per point (" + std::to_string(cloud.size()) + " points)");
}

/// The nearest point's depth and colour at each pixel.
struct z_buffer {
  static constexpr float empty = -std::numeric_limits<float>::infinity();
  int w, h;
  std::vector<float> depth;
  std::vector<std::uint8_t> colour;
  z_buffer(int width, int height)
      : w(width),
        h(height),
        depth(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), empty),
        colour(3 * depth.size()) {}
  std::size_t at(int x, int y) const noexcept {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
  }
};

/// Every point as a disc of `size` pixels: options.point_colors, the cloud's
/// colour, or grey by depth.
z_buffer splat_points(const point_cloud& cloud, const projected& p, const viewport& vp, const render_options& options,
                      int size) {
  z_buffer zb(options.width, options.height);
  const auto rgb_fields = find_rgb_fields(cloud);
  std::vector<channel> channels;
  if (rgb_fields[0] && options.point_colors.empty()) {
    const auto scales = rgb::scale(rgb_fields, std::nullopt);
    for (std::size_t k = 0; k < 3; ++k) channels.emplace_back(rgb_fields[k], scales[k]);
  }
  const double drange = p.dmax > p.dmin ? p.dmax - p.dmin : 1.0;
  const auto offsets = stamp(size);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!p.ok[i]) continue;
    const int x = static_cast<int>(std::floor(vp.x(p.u[i]))), y = static_cast<int>(std::floor(vp.y(p.v[i])));
    std::uint8_t c[3];
    if (!options.point_colors.empty()) {
      for (int k = 0; k < 3; ++k) c[k] = options.point_colors[3 * i + std::size_t(k)];
    } else if (!channels.empty()) {
      for (int k = 0; k < 3; ++k) c[k] = static_cast<std::uint8_t>(channels[k](i) * 255.0f + 0.5f);
    } else {  // grey: near points dark, far points fading towards the background
      const double t = (p.dmax - p.d[i]) / drange;
      c[0] = c[1] = c[2] = static_cast<std::uint8_t>(76.5 + 102 * t);
    }
    for (const auto& o : offsets) {
      const int px = x + o[0], py = y + o[1];
      if (px < 0 || py < 0 || px >= zb.w || py >= zb.h) continue;
      const std::size_t j = zb.at(px, py);
      if (p.d[i] <= zb.depth[j]) continue;
      zb.depth[j] = p.d[i];
      for (int k = 0; k < 3; ++k) zb.colour[3 * j + k] = c[k];
    }
  }
  return zb;
}

/// Eye-dome-style shading into `rgb`: darkens the pixels of `zb` whose
/// neighbours, `radius` pixels away, are closer to the viewer (mean slope
/// towards them, in pixels per pixel).
void shade(const z_buffer& zb, const viewport& vp, int radius, std::vector<std::uint8_t>& rgb) {
  const int dirs[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
  float slope[8];  // depth difference -> slope in pixels per pixel, averaged over the 8 directions
  for (int k = 0; k < 8; ++k)
    slope[k] = static_cast<float>(vp.scale / (radius * std::hypot(dirs[k][0], dirs[k][1])) / 8);
  for (int y = 0; y < zb.h; ++y)
    for (int x = 0; x < zb.w; ++x) {
      const std::size_t j = zb.at(x, y);
      const float dj = zb.depth[j];
      if (dj == z_buffer::empty) continue;
      float response = 0;
      for (int k = 0; k < 8; ++k) {
        const int qx = x + dirs[k][0] * radius, qy = y + dirs[k][1] * radius;
        if (qx < 0 || qy < 0 || qx >= zb.w || qy >= zb.h) continue;
        const float dq = zb.depth[zb.at(qx, qy)];
        if (dq > dj) response += (dq - dj) * slope[k];
      }
      const float s = std::max(0.25f, std::exp(-0.8f * response));
      for (int k = 0; k < 3; ++k) rgb[3 * j + k] = static_cast<std::uint8_t>(zb.colour[3 * j + k] * s + 0.5f);
    }
}

/// The keypoints on top, farthest first so that nearer ones overlap them.
void draw_keypoints(std::vector<std::uint8_t>& rgb, int w, int h, const projected& p, const viewport& vp,
                    const std::vector<std::uint32_t>& keypoints, double diameter,
                    const std::array<std::uint8_t, 3>& fill) {
  std::vector<std::uint32_t> order;
  for (std::uint32_t k : keypoints)
    if (p.ok[k]) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return p.d[a] < p.d[b]; });
  for (std::uint32_t k : order)
    draw_keypoint(rgb, w, h, std::floor(vp.x(p.u[k])) + 0.5, std::floor(vp.y(p.v[k])) + 0.5, diameter, fill);
}

}  // namespace

std::vector<std::uint8_t> render_rgb(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                                     const render_options& options, int& width, int& height) {
  check_render_input(cloud, keypoints, options);
  const int w = options.width, h = options.height;
  width = w;
  height = h;
  const std::size_t npix = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  std::vector<std::uint8_t> rgb(3 * npix);
  for (std::size_t i = 0; i < npix; ++i)
    for (int k = 0; k < 3; ++k) rgb[3 * i + k] = options.background[k];

  const projected p = project(cloud, view_basis(options.view));
  if (p.finite == 0) return rgb;
  // Sizes: the margin depends on the keypoint size, which depends on the point size.
  const double base_margin = 0.04 * std::min(w, h);
  const float point_size = options.point_size_px > 0 ? std::clamp(options.point_size_px, 1.0f, 64.0f)
                                                     : auto_point_size(p, viewport(p, w, h, base_margin), w, h);
  const double kp_size = options.keypoint_size_px > 0
                             ? std::min(options.keypoint_size_px, 256.0f)
                             : auto_keypoint_size(p, viewport(p, w, h, base_margin), w, h, point_size, keypoints);
  const viewport vp(p, w, h, std::max(base_margin, 0.5 * kp_size + 2));
  const int size = static_cast<int>(std::lround(point_size));
  const z_buffer zb = splat_points(cloud, p, vp, options, size);
  shade(zb, vp, std::max(1, size / 2), rgb);
  draw_keypoints(rgb, w, h, p, vp, keypoints, kp_size, options.keypoint_color);
  return rgb;
}

std::vector<std::uint8_t> colour_map(const std::vector<float>& values, double lo, double hi) {
  // viridis, five stops, linear in between
  static const double stops[5][3] = {{0.267, 0.005, 0.329},
                                     {0.229, 0.322, 0.546},
                                     {0.128, 0.567, 0.551},
                                     {0.369, 0.789, 0.383},
                                     {0.993, 0.906, 0.144}};
  std::vector<std::uint8_t> out(3 * values.size());
  const double span = hi > lo ? hi - lo : 1.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    double t = std::isfinite(values[i]) ? std::clamp((values[i] - lo) / span, 0.0, 1.0) * 4 : 0.0;
    const int a = std::min(3, static_cast<int>(t));
    t -= a;
    for (int k = 0; k < 3; ++k)
      out[3 * i + std::size_t(k)] =
          static_cast<std::uint8_t>(255.0 * (stops[a][k] + t * (stops[a + 1][k] - stops[a][k])) + 0.5);
  }
  return out;
}

std::vector<std::uint8_t> side_by_side(const std::vector<std::uint8_t>& a, int wa, const std::vector<std::uint8_t>& b,
                                       int wb, int h) {
  if (a.size() != std::size_t(wa) * std::size_t(h) * 3 || b.size() != std::size_t(wb) * std::size_t(h) * 3)
    throw std::invalid_argument("side_by_side: the images do not match their sizes");
  std::vector<std::uint8_t> out;
  out.reserve(a.size() + b.size());
  for (int y = 0; y < h; ++y) {
    out.insert(out.end(), a.begin() + 3 * std::ptrdiff_t(y) * wa, a.begin() + 3 * std::ptrdiff_t(y + 1) * wa);
    out.insert(out.end(), b.begin() + 3 * std::ptrdiff_t(y) * wb, b.begin() + 3 * std::ptrdiff_t(y + 1) * wb);
  }
  return out;
}

std::string encode_png(const std::vector<std::uint8_t>& rgb, int w, int h) {
  if (w <= 0 || h <= 0 || rgb.size() != std::size_t(w) * std::size_t(h) * 3)
    throw std::invalid_argument("encode_png: the image size does not match its data");
  std::string png;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &png, w, h, 3, rgb.data(), 3 * w))
    throw std::runtime_error("cannot encode the PNG image");
  return png;
}

void render_png(const std::string& path, const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                const render_options& options) {
  int w = 0, h = 0;
  const std::vector<std::uint8_t> rgb = render_rgb(cloud, keypoints, options, w, h);
  io::write_text_file_atomic(path, encode_png(rgb, w, h));
}

}  // namespace ced
