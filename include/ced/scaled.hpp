// SPDX-License-Identifier: MIT
// A centroid distance at another scale: measured over the neighbours within
// K × radius, while the detection (its minimum-neighbour gate, its NMS, the
// other modalities) stays at the radius.
//
//     s_i = || scale ⊙ ( mean_{N_{Kr}(i)} v − v_i ) ||,  threshold at K·r
//
// At a larger scale the signal of a corner or an edge grows with the radius
// while a point's own noise does not, so the measure holds up under noise
// (docs/MODALITIES.md has the evaluation). Any modality takes it:
// `scaled<xyz>{xyz(0.2), 2}` at compile time, `scaled_modality(m, 2)` or the
// spec option `scale=2` (`xyz:0.2,scale=2`) at run time. Its threshold is the
// base's at K × radius (xyz: ratio × K × radius). The saliencies come from a
// neighbour pass of their own at K × radius, made when the modality is bound.
#pragma once

#include <string>
#include <vector>

#include "ced/modality.hpp"

namespace ced {

/// Every point's saliency of `m` alone with `params` (points with fewer than
/// params.min_neighbors neighbours get 0): a neighbour pass without NMS.
/// Deterministic for any thread count.
std::vector<float> saliency_of(const point_cloud& cloud, const detect_params& params, const any_modality& m);

/// The evaluator of a scaled modality: the saliencies computed at bind time.
class precomputed_saliency {
 public:
  explicit precomputed_saliency(std::vector<float> s) : m_saliency(std::move(s)) {}
  void evaluate(const block_view& block, float* out) const {
    for (std::size_t k = 0; k < block.size(); ++k) out[k] = m_saliency[block.point(k)];
  }

 private:
  std::vector<float> m_saliency;
};

/// `params` with the radius K times larger (the NMS radius too).
detect_params scaled_params(const detect_params& params, double factor);
std::string format_scale_factor(double factor);

/// Modality M measured over K × radius (see the top of this file).
template <class M>
struct scaled {
  M base;
  double factor = 2;  ///< K > 0

  std::string name() const { return std::string(base.name()) + ",scale=" + format_scale_factor(factor); }
  double threshold(const detect_params& p) const { return base.threshold(scaled_params(p, factor)); }
  std::vector<std::string> fields() const {
    if constexpr (detail::declares_fields<M>::value)
      return base.fields();
    else
      return {};
  }
  precomputed_saliency bind(const point_cloud& cloud, const detect_params& p) const {
    return precomputed_saliency(saliency_of(cloud, scaled_params(p, factor), any_modality(base)));
  }
};

/// `base` measured over `factor` × radius, for modalities made at run time
/// (make_modality, plugins). Throws std::invalid_argument unless
/// 0 < factor <= 16.
any_modality scaled_modality(any_modality base, double factor);

/// The largest scale factor among `modalities` (1 when none is scaled): a
/// tile's halo grows with it.
double max_scale_factor(const std::vector<any_modality>& modalities);

}  // namespace ced
