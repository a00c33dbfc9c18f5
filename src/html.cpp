// SPDX-License-Identifier: MIT
// The interactive page (ced/html.hpp): the viewer (src/html/viewer.html,
// embedded at build time) with the cloud's data inlined as base64.
#include "ced/html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/detect.hpp"
#include "ced/io/output_file.hpp"
#include "ced/modalities/rgb.hpp"
#include "ced/preprocess.hpp"
#include "core/text.hpp"
#include "html_viewer.hpp"  // generated: ced::detail::viewer_html

namespace ced {

namespace {

template <class T>
std::string base64_of(const std::vector<T>& v) {
  std::string s;
  detail::base64_append(v.data(), v.size() * sizeof(T), s);
  return s;
}

}  // namespace

std::vector<html_layer> html_layers(const detection_result& r) {
  std::vector<html_layer> layers;
  for (std::size_t m = 0; m < r.names.size(); ++m) layers.push_back({r.names[m], r.thresholds[m], r.saliency[m]});
  return layers;
}

namespace {

/// std::invalid_argument for what html_page() cannot show.
void check_html_input(std::size_t n, const std::vector<std::uint32_t>& keypoints, const std::vector<html_layer>& layers,
                      const html_options& options) {
  if (options.max_points == 0) throw std::invalid_argument("html: the display limit must be at least 1 point");
  for (std::uint32_t k : keypoints)
    if (k >= n)
      throw std::invalid_argument("html: keypoint " + std::to_string(k) + " is out of range (" + std::to_string(n) +
                                  " points)");
  for (const auto& l : layers)
    if (l.saliency.size() != n)
      throw std::invalid_argument("html: layer '" + l.name + "' has " + std::to_string(l.saliency.size()) +
                                  " saliencies for " + std::to_string(n) + " points");
  if (!options.point_radius.empty() && options.point_radius.size() != n)
    throw std::invalid_argument("html: " + std::to_string(options.point_radius.size()) + " point radii for " +
                                std::to_string(n) + " points");
}

/// The points the page draws: all finite ones, or every stride-th and the keypoints.
struct display_set {
  std::size_t n_finite = 0, stride = 1;
  std::vector<std::uint32_t> shown;      ///< the drawn points' indices in the cloud, ascending
  bool subset = false;                   ///< not every point of the cloud is drawn
  std::vector<std::uint32_t> keypoints;  ///< the keypoints' indices among the drawn points
};

display_set choose_display(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                           std::size_t max_points) {
  const std::size_t n = cloud.size();
  const float* xyz = cloud.positions().data();
  const auto finite = [&](std::size_t i) {
    return std::isfinite(xyz[3 * i]) && std::isfinite(xyz[3 * i + 1]) && std::isfinite(xyz[3 * i + 2]);
  };
  display_set d;
  for (std::size_t i = 0; i < n; ++i) d.n_finite += finite(i);
  std::vector<std::uint8_t> is_kp(n, 0);
  for (std::uint32_t k : keypoints) is_kp[k] = 1;
  d.stride = d.n_finite <= max_points ? 1 : (d.n_finite + max_points - 1) / max_points;
  for (std::size_t i = 0, f = 0; i < n; ++i) {
    if (!finite(i)) continue;
    if (f++ % d.stride == 0 || is_kp[i]) d.shown.push_back(static_cast<std::uint32_t>(i));
  }
  d.subset = d.shown.size() != n;
  std::vector<std::uint32_t> display_of(d.subset ? n : 0, UINT32_MAX);
  if (d.subset)
    for (std::size_t s = 0; s < d.shown.size(); ++s) display_of[d.shown[s]] = static_cast<std::uint32_t>(s);
  for (std::uint32_t k : keypoints)
    if (!d.subset || display_of[k] != UINT32_MAX) d.keypoints.push_back(d.subset ? display_of[k] : k);
  return d;
}

/// The drawn points' spacing: `spacing` when it is > 0 or there are fewer
/// than two finite points; else estimated on the drawn points.
double display_spacing(const point_cloud& cloud, const display_set& d, double spacing) {
  if (spacing > 0 || d.n_finite <= 1) return spacing;
  const float* xyz = cloud.positions().data();
  point_cloud sample;
  for (std::uint32_t i : d.shown) sample.push_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return estimate_resolution(sample) * double(d.stride > 1 ? std::sqrt(double(d.stride)) : 1.0);
}

/// The drawn points' colours, 3 bytes each; nothing when the cloud has none.
std::optional<std::vector<std::uint8_t>> display_colours(const point_cloud& cloud,
                                                         const std::vector<std::uint32_t>& shown) {
  const auto f = find_rgb_fields(cloud);
  if (!f[0]) return std::nullopt;
  const auto s = rgb::scale(f, std::nullopt);
  std::vector<std::uint8_t> colours(3 * shown.size());
  for (std::size_t d = 0; d < shown.size(); ++d)
    for (std::size_t c = 0; c < 3; ++c) {
      const double v = f[c]->values[shown[d]] * s[c] * 255.0 + 0.5;
      colours[3 * d + c] = static_cast<std::uint8_t>(std::isfinite(v) ? std::clamp(v, 0.0, 255.0) : 0.0);
    }
  return colours;
}

/// `j` as the script statement "const CED_DATA = ...;". '<', '>' and '&'
/// occur only inside strings: escaped, no text can close the script.
/// Invalid UTF-8 (a file name) becomes U+FFFD.
std::string script_data(const nlohmann::json& j) {
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
  return data;
}

}  // namespace

std::string html_page(const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                      const std::vector<html_layer>& layers, const html_options& options) {
  check_html_input(cloud.size(), keypoints, layers, options);
  const display_set d = choose_display(cloud, keypoints, options.max_points);
  const float* xyz = cloud.positions().data();
  std::vector<float> pos(3 * d.shown.size());
  for (std::size_t s = 0; s < d.shown.size(); ++s) std::memcpy(&pos[3 * s], xyz + 3 * std::size_t(d.shown[s]), 12);
  const double spacing = display_spacing(cloud, d, options.spacing);
  int decimals = 3;
  if (spacing > 0) decimals = std::clamp(int(std::ceil(-std::log10(spacing))) + 1, 2, 6);

  nlohmann::json j;
  j["title"] = options.title;
  j["source"] = options.source;
  j["total_points"] = d.n_finite;
  j["max_points"] = options.max_points;
  j["stride"] = d.stride;
  j["spacing"] = spacing;  // NaN becomes null
  j["decimals"] = decimals;
  j["origin"] = cloud.origin();
  j["info"] = nlohmann::json::array();
  for (const auto& [k, v] : options.info) j["info"].push_back({k, v});
  j["positions"] = base64_of(pos);
  if (const auto colours = display_colours(cloud, d.shown)) j["rgb"] = base64_of(*colours);
  if (d.subset) j["index"] = base64_of(d.shown);
  j["keypoints"] = base64_of(d.keypoints);
  if (!options.point_radius.empty()) {
    std::vector<float> radius(d.shown.size());
    for (std::size_t s = 0; s < d.shown.size(); ++s) radius[s] = options.point_radius[d.shown[s]];
    j["radius"] = base64_of(radius);
  }
  j["modalities"] = nlohmann::json::array();
  for (const auto& layer : layers) {
    std::vector<float> sal(d.shown.size());
    for (std::size_t s = 0; s < d.shown.size(); ++s) sal[s] = layer.saliency[d.shown[s]];
    j["modalities"].push_back({{"name", layer.name}, {"threshold", layer.threshold}, {"saliency", base64_of(sal)}});
  }

  const std::string page = detail::viewer_html;
  const std::string mark = "/*CED_DATA*/";
  const auto at = page.find(mark);
  if (at == std::string::npos) throw std::logic_error("html: the viewer template has no data mark");
  return page.substr(0, at) + script_data(j) + page.substr(at + mark.size());
}

void write_html(const std::string& path, const point_cloud& cloud, const std::vector<std::uint32_t>& keypoints,
                const std::vector<html_layer>& layers, const html_options& options) {
  io::write_text_file_atomic(path, html_page(cloud, keypoints, layers, options));
}

}  // namespace ced
