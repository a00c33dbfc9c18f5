// SPDX-License-Identifier: MIT
// The interactive page (ced/html.hpp): the viewer (src/html/viewer.html,
// embedded at build time) with the cloud's data inlined as base64.
#include "ced/html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/detect.hpp"
#include "ced/io/output_file.hpp"
#include "ced/modalities/rgb.hpp"
#include "ced/preprocess.hpp"
#include "html_viewer.hpp"  // generated: ced::detail::viewer_html

namespace ced {

namespace {

void base64(const void* data, std::size_t size, std::string& out) {
  static const char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  out.reserve(out.size() + (size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const unsigned v = (unsigned(p[i]) << 16) | (unsigned(p[i + 1]) << 8) | p[i + 2];
    out += table[v >> 18];
    out += table[(v >> 12) & 63];
    out += table[(v >> 6) & 63];
    out += table[v & 63];
  }
  if (i < size) {
    const unsigned v = (unsigned(p[i]) << 16) | (i + 1 < size ? unsigned(p[i + 1]) << 8 : 0u);
    out += table[v >> 18];
    out += table[(v >> 12) & 63];
    out += i + 1 < size ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
}

template <class T>
std::string base64_of(const std::vector<T>& v) {
  std::string s;
  base64(v.data(), v.size() * sizeof(T), s);
  return s;
}

}  // namespace

std::vector<html_layer> html_layers(const detection_result& r) {
  std::vector<html_layer> layers;
  for (std::size_t m = 0; m < r.names.size(); ++m) layers.push_back({r.names[m], r.thresholds[m], r.saliency[m]});
  return layers;
}

std::string html_page(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                      const std::vector<html_layer>& layers, const html_options& options) {
  const std::size_t n = cloud.size();
  if (options.max_points == 0) throw std::invalid_argument("html: the display limit must be at least 1 point");
  for (std::uint32_t k : keypoints)
    if (k >= n)
      throw std::invalid_argument("html: keypoint " + std::to_string(k) + " is out of range (" + std::to_string(n) +
                                  " points)");
  for (const auto& l : layers)
    if (l.saliency.size() != n)
      throw std::invalid_argument("html: layer '" + l.name + "' has " + std::to_string(l.saliency.size()) +
                                  " saliencies for " + std::to_string(n) + " points");
  const float* xyz = cloud.positions().data();
  const auto finite = [&](std::size_t i) {
    return std::isfinite(xyz[3 * i]) && std::isfinite(xyz[3 * i + 1]) && std::isfinite(xyz[3 * i + 2]);
  };
  std::size_t n_finite = 0;
  for (std::size_t i = 0; i < n; ++i) n_finite += finite(i);

  // The drawn points: all finite ones, or every stride-th and the keypoints.
  std::vector<std::uint8_t> is_kp(n, 0);
  for (std::uint32_t k : keypoints) is_kp[k] = 1;
  const std::size_t stride =
      n_finite <= options.max_points ? 1 : (n_finite + options.max_points - 1) / options.max_points;
  std::vector<std::uint32_t> shown;
  for (std::size_t i = 0, f = 0; i < n; ++i) {
    if (!finite(i)) continue;
    if (f++ % stride == 0 || is_kp[i]) shown.push_back(static_cast<std::uint32_t>(i));
  }
  const bool subset = shown.size() != n;
  std::vector<std::uint32_t> display_of(subset ? n : 0, UINT32_MAX);
  if (subset)
    for (std::size_t d = 0; d < shown.size(); ++d) display_of[shown[d]] = static_cast<std::uint32_t>(d);

  std::vector<float> pos(3 * shown.size());
  for (std::size_t d = 0; d < shown.size(); ++d) std::memcpy(&pos[3 * d], xyz + 3 * std::size_t(shown[d]), 12);
  std::vector<std::uint32_t> kp;
  for (std::uint32_t k : keypoints)
    if (!subset || display_of[k] != UINT32_MAX) kp.push_back(subset ? display_of[k] : k);

  double spacing = options.spacing;
  if (!(spacing > 0) && n_finite > 1) {
    point_cloud sample;
    for (std::uint32_t i : shown) sample.push_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    spacing = estimate_resolution(sample) * double(stride > 1 ? std::sqrt(double(stride)) : 1.0);
  }
  int decimals = 3;
  if (spacing > 0) decimals = std::clamp(int(std::ceil(-std::log10(spacing))) + 1, 2, 6);

  nlohmann::json j;
  j["title"] = options.title;
  j["source"] = options.source;
  j["total_points"] = n_finite;
  j["max_points"] = options.max_points;
  j["stride"] = stride;
  j["spacing"] = spacing;  // NaN becomes null
  j["decimals"] = decimals;
  j["origin"] = cloud.origin();
  j["info"] = nlohmann::json::array();
  for (const auto& [k, v] : options.info) j["info"].push_back({k, v});
  j["positions"] = base64_of(pos);
  const auto f = find_rgb_fields(cloud);
  if (f[0]) {
    const auto s = rgb::scale(f, std::nullopt);
    std::vector<std::uint8_t> colours(3 * shown.size());
    for (std::size_t d = 0; d < shown.size(); ++d)
      for (std::size_t c = 0; c < 3; ++c) {
        const double v = f[c]->values[shown[d]] * s[c] * 255.0 + 0.5;
        colours[3 * d + c] = static_cast<std::uint8_t>(std::isfinite(v) ? std::clamp(v, 0.0, 255.0) : 0.0);
      }
    j["rgb"] = base64_of(colours);
  }
  if (subset) j["index"] = base64_of(shown);
  j["keypoints"] = base64_of(kp);
  j["modalities"] = nlohmann::json::array();
  for (const auto& layer : layers) {
    std::vector<float> s(shown.size());
    for (std::size_t d = 0; d < shown.size(); ++d) s[d] = layer.saliency[shown[d]];
    j["modalities"].push_back({{"name", layer.name}, {"threshold", layer.threshold}, {"saliency", base64_of(s)}});
  }
  // '<', '>' and '&' occur only inside strings: escaped, no text can close
  // the script. Invalid UTF-8 (a file name) becomes U+FFFD.
  std::string data = "const CED_DATA = ";
  for (char c : j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)) {
    if (c == '<')
      data += "\\u003c";
    else if (c == '>')
      data += "\\u003e";
    else if (c == '&')
      data += "\\u0026";
    else
      data += c;
  }
  data += ";";

  const std::string page = detail::viewer_html;
  const std::string mark = "/*CED_DATA*/";
  const auto at = page.find(mark);
  if (at == std::string::npos) throw std::logic_error("html: the viewer template has no data mark");
  return page.substr(0, at) + data + page.substr(at + mark.size());
}

void write_html(const std::string& path, const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                const std::vector<html_layer>& layers, const html_options& options) {
  io::write_text_file_atomic(path, html_page(cloud, keypoints, layers, options));
}

}  // namespace ced
