// SPDX-License-Identifier: MIT
// The interactive page (ced/html.hpp): the viewer (src/html/viewer.html,
// embedded at build time) with the cloud's data inlined as base64.
#include "ced/html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
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

/// A JSON string; '<' escaped too, so that no text can close the script.
std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += char(c);
    } else if (c < 0x20 || c == '<' || c == '>' || c == '&') {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += char(c);
    }
  }
  return out + "\"";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

template <class T>
std::string json_base64(const std::vector<T>& v) {
  std::string s = "\"";
  base64(v.data(), v.size() * sizeof(T), s);
  return s + "\"";
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

  std::string data = "const CED_DATA = {";
  data += "\"title\":" + json_string(options.title);
  data += ",\"source\":" + json_string(options.source);
  data += ",\"total_points\":" + std::to_string(n_finite);
  data += ",\"max_points\":" + std::to_string(options.max_points);
  data += ",\"stride\":" + std::to_string(stride);
  data += ",\"spacing\":" + json_number(spacing);
  data += ",\"decimals\":" + std::to_string(decimals);
  data += ",\"origin\":[" + json_number(cloud.origin()[0]) + "," + json_number(cloud.origin()[1]) + "," +
          json_number(cloud.origin()[2]) + "]";
  data += ",\"info\":[";
  for (std::size_t k = 0; k < options.info.size(); ++k)
    data += (k ? ",[" : "[") + json_string(options.info[k].first) + "," + json_string(options.info[k].second) + "]";
  data += "]";
  data += ",\"positions\":" + json_base64(pos);
  const auto f = find_rgb_fields(cloud);
  if (f[0]) {
    const auto s = rgb::scale(f, std::nullopt);
    std::vector<std::uint8_t> colours(3 * shown.size());
    for (std::size_t d = 0; d < shown.size(); ++d)
      for (std::size_t c = 0; c < 3; ++c) {
        const double v = f[c]->values[shown[d]] * s[c] * 255.0 + 0.5;
        colours[3 * d + c] = static_cast<std::uint8_t>(std::isfinite(v) ? std::clamp(v, 0.0, 255.0) : 0.0);
      }
    data += ",\"rgb\":" + json_base64(colours);
  }
  if (subset) data += ",\"index\":" + json_base64(shown);
  data += ",\"keypoints\":" + json_base64(kp);
  data += ",\"modalities\":[";
  for (std::size_t m = 0; m < layers.size(); ++m) {
    std::vector<float> s(shown.size());
    for (std::size_t d = 0; d < shown.size(); ++d) s[d] = layers[m].saliency[shown[d]];
    data += (m ? ",{" : "{") + std::string("\"name\":") + json_string(layers[m].name) +
            ",\"threshold\":" + json_number(layers[m].threshold) + ",\"saliency\":" + json_base64(s) + "}";
  }
  data += "]};";

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
