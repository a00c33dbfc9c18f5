// SPDX-License-Identifier: MIT
// Modalities at another scale (ced/scaled.hpp).
#include "ced/scaled.hpp"

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "ced/detect.hpp"

namespace ced {

std::vector<float> saliency_of(const point_cloud& cloud, const detect_params& params, const any_modality& m) {
  // A threshold no saliency reaches: no candidate, so the NMS has no work.
  detail::detection_context ctx(cloud, params, {m.name()}, {std::numeric_limits<double>::max()});
  {
    const std::unique_ptr<bound_modality> bound = m.bind(cloud, params);
    // A measure on sums needs no neighbour lists: the pass skips them.
    const channel_source src = bound->channels();
    if (src.positions || src.values) ctx.without_neighbor_lists();
    ctx.compute_saliency({src}, [&](const block_view& block, float* const* columns) {
      bound->evaluate(block, 0, params.min_neighbors, columns[0]);
    });
  }
  return std::move(ctx.finish().saliency[0]);
}

detect_params scaled_params(const detect_params& params, double factor) {
  detect_params p = params;
  p.radius *= factor;
  p.nms_radius *= factor;
  return p;
}

std::string format_scale_factor(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

namespace {
std::string scale_suffix(double factor) { return ",scale=" + format_scale_factor(factor); }

struct scaled_any {
  any_modality base;
  double factor;

  std::string name() const { return base.name() + scale_suffix(factor); }
  double threshold(const detect_params& p) const { return base.threshold(scaled_params(p, factor)); }
  precomputed_saliency bind(const point_cloud& cloud, const detect_params& p) const {
    return precomputed_saliency(saliency_of(cloud, scaled_params(p, factor), base));
  }
};
}  // namespace

any_modality scaled_modality(any_modality base, double factor) {
  if (!(factor > 0 && factor <= 16))
    throw std::invalid_argument("scale must be a factor of the radius in (0, 16], got " + std::to_string(factor));
  if (!base) throw std::invalid_argument("scaled_modality: no modality");
  return scaled_any{std::move(base), factor};
}

double max_scale_factor(const std::vector<any_modality>& modalities) {
  double k = 1;
  for (const auto& m : modalities) {
    const std::string name = m.name();
    const auto at = name.rfind(",scale=");
    if (at != std::string::npos) k = std::max(k, std::strtod(name.c_str() + at + 7, nullptr));
  }
  return k;
}

}  // namespace ced
