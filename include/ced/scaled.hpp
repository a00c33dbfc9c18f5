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
//
// Centroid shift (`inner=J`, 0 < J < K; positions only): the distance between
// the centroids at two scales, not from the point itself,
//
//     s_i = || mean_{N_{Kr}(i)} p − mean_{N_{Jr}(i)} p ||,  threshold at K·r
//
// (0 with fewer than min_neighbors neighbours at either scale). A point's
// own noise enters both means with weight 1/n only, so a noisier cloud does
// not raise every point's saliency: the robust presets use it (J = 1).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "ced/modality.hpp"

namespace ced {

/// Every point's saliency of `m` alone with `params` (points with fewer than
/// params.min_neighbors neighbours get 0): a neighbour pass without NMS.
/// Deterministic for any thread count.
std::vector<float> saliency_of(const point_cloud& cloud, const detect_params& params, const any_modality& m);

/// Every point's centroid shift (see the top of this file) of positions
/// modality `m` (xyz) between factor × and inner × params.radius; two
/// neighbour passes without NMS. Deterministic for any thread count.
std::vector<float> centroid_shift_of(const point_cloud& cloud, const detect_params& params, double factor, double inner,
                                     const any_modality& m);

namespace detail {
/// || outer − inner || of two centroid offsets (3 floats each), in double;
/// 0 when either is NaN (too few neighbours at its scale).
inline float centroid_shift_norm(const float* outer, const float* inner) noexcept {
  double d2 = 0;
  for (std::size_t a = 0; a < 3; ++a) {
    const double d = double(outer[a]) - double(inner[a]);
    d2 += d * d;
  }
  return std::isfinite(d2) ? static_cast<float>(std::sqrt(d2)) : 0.0f;
}
}  // namespace detail

/// The evaluator of a scaled modality: the saliencies computed at bind time,
/// or (centroid_shift(), inner = 1) each point's centroid offset at K·r,
/// taken against its offset at r from the detection's own pass, which makes
/// those position sums anyway: one neighbour pass fewer.
class precomputed_saliency {
 public:
  explicit precomputed_saliency(std::vector<float> s) : m_saliency(std::move(s)) {}
  /// `outer_offsets`: mean_{N_{Kr}(i)} p − p_i, 3 floats a point (NaN: too
  /// few neighbours), as centroid_shift_of makes them.
  static precomputed_saliency centroid_shift(std::vector<float> outer_offsets) {
    precomputed_saliency e({});
    e.m_outer = std::move(outer_offsets);
    return e;
  }
  void evaluate(const block_view& block, float* out) const {
    if (m_outer.empty()) {
      for (std::size_t k = 0; k < block.size(); ++k) out[k] = m_saliency[block.point(k)];
      return;
    }
    for (std::size_t k = 0; k < block.size(); ++k) {  // (gated at r by the caller)
      const double* sum = block.position_sums(k);
      const double n = double(block.count(k));
      const float inner[3] = {static_cast<float>(sum[0] / n), static_cast<float>(sum[1] / n),
                              static_cast<float>(sum[2] / n)};  // as centroid_offsets_of rounds them
      out[k] = detail::centroid_shift_norm(m_outer.data() + 3 * std::size_t(block.point(k)), inner);
    }
  }

 private:
  std::vector<float> m_saliency;
  std::vector<float> m_outer;
};

/// The centroid offsets mean_{N(i)} p − p_i of positions modality `m` with
/// `params`, 3 floats a point (NaN with fewer than min_neighbors neighbours).
std::vector<float> centroid_offsets_of(const point_cloud& cloud, const detect_params& params, const any_modality& m);

/// The evaluator of `base` at `factor` × radius, or of its centroid shift
/// between inner × and factor × radius when `inner` > 0 (scaled<M> and
/// scaled_modality bind through it).
precomputed_saliency bind_scaled(const point_cloud& cloud, const detect_params& params, double factor, double inner,
                                 const any_modality& base);

/// `params` with the radius K times larger (the NMS radius too); under a
/// knn or adaptive neighbourhood, each point's own radius K times larger
/// (knn:k becomes adaptive:k,scale=K; adaptive's scale, min and max × K).
detect_params scaled_params(const detect_params& params, double factor);
std::string format_scale_factor(double factor);
/// The end of a scaled modality's name: ",scale=K", then ",inner=J" when J > 0.
std::string scale_suffix(double factor, double inner = 0);

/// Modality M measured over K × radius (see the top of this file).
template <class M>
struct scaled {
  M base;
  double factor = 2;  ///< K > 0
  double inner = 0;   ///< J in (0, K): the centroid shift between J·r and K·r (xyz only); 0: none

  std::string name() const { return std::string(base.name()) + scale_suffix(factor, inner); }
  double threshold(const detect_params& p) const { return base.threshold(scaled_params(p, factor)); }
  std::vector<std::string> fields() const {
    if constexpr (detail::declares_fields<M>::value)
      return base.fields();
    else
      return {};
  }
  bool channels_from_neighborhoods() const { return channels_from_neighborhoods_of(base); }
  precomputed_saliency bind(const point_cloud& cloud, const detect_params& p) const {
    return bind_scaled(cloud, p, factor, inner, any_modality(base));
  }
};

/// `base` measured over `factor` × radius, for modalities made at run time
/// (make_modality, plugins); with `inner` > 0, its centroid shift between
/// inner × and factor × radius. Throws std::invalid_argument unless
/// 0 < factor <= 16 and inner is 0 or in (0, factor).
any_modality scaled_modality(any_modality base, double factor, double inner = 0);

/// The largest scale factor among `modalities` (1 when none is scaled): a
/// tile's halo grows with it.
double max_scale_factor(const std::vector<any_modality>& modalities);

/// Whether one of `modalities` reads a channel made over each point's own
/// neighbourhood (any_modality::channels_from_neighborhoods(): normals,
/// estimated) under knn or adaptive: a neighbour's channel then depends on
/// the neighbour's neighbourhood, one hop farther.
bool reads_neighbourhood_channels(const std::vector<any_modality>& modalities, const detect_params& params);

/// What a tile's halo is sized for (exact_halo): `params` at the largest
/// scale among `modalities`, and twice as far reaching under knn or adaptive
/// when reads_neighbourhood_channels().
detect_params tile_halo_params(const detect_params& params, const std::vector<any_modality>& modalities);

/// How much farther than the NMS term tiles check the reach
/// (check_tile_reach): the neighbourhood's scaled reach when
/// reads_neighbourhood_channels(), else 0.
double tile_check_extra(const detect_params& params, const std::vector<any_modality>& modalities);

}  // namespace ced
