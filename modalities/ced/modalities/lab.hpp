// SPDX-License-Identifier: MIT
// CIELAB colour (the paper's footnote): colours converted from sRGB to
// L*a*b* (D65), saliency = Euclidean distance to the neighbours' mean in
// L*a*b* (ΔE*76) divided by 100, so 0.1 means ΔE 10.
#pragma once

#include <algorithm>

#include "ced/detail/parallel.hpp"
#include "ced/modalities/rgb.hpp"
#include "ced/modality.hpp"

namespace ced {

struct lab {
  static constexpr const char* spec_name = "lab";
  double threshold_value = 0.1;

  lab() = default;
  explicit lab(double threshold) : threshold_value(threshold) {}

  std::string name() const { return "lab"; }
  double threshold(const detect_params&) const { return threshold_value; }
  centroid_distance<3> bind(const point_cloud& cloud, const detect_params& params) const {
    const auto f = rgb::fields(cloud);
    const auto s = rgb::scale(f, std::nullopt);
    const std::size_t n = cloud.size();
    // 8- and 16-bit channels hold few distinct values: linearise each once.
    std::array<std::vector<double>, 3> table;
    for (std::size_t c = 0; c < 3; ++c)
      if (f[c]->type == scalar_type::uint8 || f[c]->type == scalar_type::uint16) {
        table[c].resize(f[c]->type == scalar_type::uint8 ? 256 : 65536);
        for (std::size_t v = 0; v < table[c].size(); ++v)
          table[c][v] = srgb_to_linear(static_cast<float>(double(v) * s[c]));
      }
    auto linear = [&](std::size_t c, std::size_t i) {
      const double v = f[c]->values[i];
      return table[c].empty() ? srgb_to_linear(static_cast<float>(v * s[c])) : table[c][static_cast<std::size_t>(v)];
    };
    std::vector<float> out(3 * n);
    detail::parallel_for(n, params.threads, 1 << 14, [&](std::size_t b, std::size_t e) {
      constexpr std::size_t batch = 256;
      double rgb[3][batch];
      for (std::size_t i = b; i < e; i += batch) {
        const std::size_t m = std::min(batch, e - i);
        for (std::size_t c = 0; c < 3; ++c)
          for (std::size_t k = 0; k < m; ++k) rgb[c][k] = linear(c, i + k);
        linear_srgb_to_lab(rgb[0], rgb[1], rgb[2], m, out.data() + 3 * i);
      }
    });
    return centroid_distance<3>(std::move(out), {0.01, 0.01, 0.01}, norm_type::l2);
  }
  static lab from_spec(modality_spec& s) { return lab(s.threshold_or(0.1)); }
};

}  // namespace ced
