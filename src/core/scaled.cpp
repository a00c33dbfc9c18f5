// SPDX-License-Identifier: MIT
// Modalities at another scale (ced/scaled.hpp).
#include "ced/scaled.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "ced/detect.hpp"
#include "core/detection.hpp"

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
  // Under knn and adaptive, K × each point's own radius: knn:K becomes
  // adaptive:K,scale=K (the ball of K times the k-th distance).
  neighborhood_spec& n = p.neighborhood;
  if (n.kind == neighborhood_kind::knn) {
    n.kind = neighborhood_kind::adaptive;
    n.scale = factor;
  } else if (n.kind == neighborhood_kind::adaptive) {
    n.scale *= factor;
    n.min_radius *= factor;
    n.max_radius *= factor;
  }
  // Its K nearest still reach the k-th distance, its ball factor × r_i.
  if (!n.fixed()) n.reach *= std::max(1.0, factor);
  return p;
}

std::vector<float> centroid_offsets_of(const point_cloud& cloud, const detect_params& params, const any_modality& m) {
  std::vector<float> off(3 * cloud.size(), std::numeric_limits<float>::quiet_NaN());
  detail::detection_context ctx(cloud, params, {m.name()}, {std::numeric_limits<double>::max()});
  {
    const std::unique_ptr<bound_modality> bound = m.bind(cloud, params);
    const channel_source src = bound->channels();
    if (!src.positions)
      throw std::invalid_argument("inner= needs a modality of positions (xyz), not '" + m.name() + "'");
    ctx.without_neighbor_lists();
    // Blocks hold disjoint points: each writes only its own offsets.
    ctx.compute_saliency({src}, [&](const block_view& block, float* const* columns) {
      for (std::size_t k = 0; k < block.size(); ++k) {
        columns[0][block.point(k)] = 0;  // (this pass ranks nothing)
        const std::uint32_t n = block.count(k);
        if (n < params.min_neighbors) continue;
        const double* sum = block.sums(k, 0);  // Σ (p_j − p_i)
        float* o = off.data() + 3 * std::size_t(block.point(k));
        for (std::size_t a = 0; a < 3; ++a) o[a] = static_cast<float>(sum[a] / n);
      }
    });
  }
  ctx.finish();
  return off;
}

std::vector<float> centroid_shift_of(const point_cloud& cloud, const detect_params& params, double factor, double inner,
                                     const any_modality& m) {
  const std::vector<float> outer = centroid_offsets_of(cloud, scaled_params(params, factor), m);
  const std::vector<float> in = centroid_offsets_of(cloud, scaled_params(params, inner), m);
  std::vector<float> s(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) s[i] = detail::centroid_shift_norm(&outer[3 * i], &in[3 * i]);
  return s;
}

namespace {
/// The factors' ranges (docs/MODALITIES.md), for specs, scaled_modality and scaled<M> alike.
void check_scale_factors(double factor, double inner) {
  if (!(factor > 0 && factor <= 16))
    throw std::invalid_argument("scale must be a factor of the radius in (0, 16], got " + std::to_string(factor));
  if (!(inner == 0 || (inner > 0 && inner < factor)))
    throw std::invalid_argument("inner must be a factor of the radius in (0, scale), got " + std::to_string(inner));
}
}  // namespace

precomputed_saliency bind_scaled(const point_cloud& cloud, const detect_params& params, double factor, double inner,
                                 const any_modality& base) {
  check_scale_factors(factor, inner);  // (scaled<M> is built without a check)
  if (inner == 1)                      // the inner centroid is the detection's own
    return precomputed_saliency::centroid_shift(centroid_offsets_of(cloud, scaled_params(params, factor), base));
  if (inner > 0) return precomputed_saliency(centroid_shift_of(cloud, params, factor, inner, base));
  return precomputed_saliency(saliency_of(cloud, scaled_params(params, factor), base));
}

std::string format_scale_factor(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string scale_suffix(double factor, double inner) {
  return ",scale=" + format_scale_factor(factor) + (inner > 0 ? ",inner=" + format_scale_factor(inner) : "");
}

namespace {

struct scaled_any {
  any_modality base;
  double factor;
  double inner;

  std::string name() const { return base.name() + scale_suffix(factor, inner); }
  double threshold(const detect_params& p) const { return base.threshold(scaled_params(p, factor)); }
  bool channels_from_neighborhoods() const { return base.channels_from_neighborhoods(); }
  precomputed_saliency bind(const point_cloud& cloud, const detect_params& p) const {
    return bind_scaled(cloud, p, factor, inner, base);
  }
};
}  // namespace

any_modality scaled_modality(any_modality base, double factor, double inner) {
  check_scale_factors(factor, inner);
  if (!base) throw std::invalid_argument("scaled_modality: no modality");
  return scaled_any{std::move(base), factor, inner};
}

bool reads_neighbourhood_channels(const std::vector<any_modality>& modalities, const detect_params& params) {
  if (params.neighborhood.fixed()) return false;  // normals within r: inside the blocks' part of the halo
  return std::any_of(modalities.begin(), modalities.end(),
                     [](const any_modality& m) { return m.channels_from_neighborhoods(); });
}

detect_params tile_halo_params(const detect_params& params, const std::vector<any_modality>& modalities) {
  detect_params p = scaled_params(params, max_scale_factor(modalities));
  if (reads_neighbourhood_channels(modalities, params)) {
    neighborhood_spec& n = p.neighborhood;
    n.reach *= 2;
    if (n.kind == neighborhood_kind::adaptive) n.max_radius *= 2;
  }
  return p;
}

double tile_check_extra(const detect_params& params, const std::vector<any_modality>& modalities) {
  if (!reads_neighbourhood_channels(modalities, params)) return 0;
  return params.neighborhood.reach * std::max(1.0, max_scale_factor(modalities));
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
