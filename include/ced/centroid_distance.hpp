// SPDX-License-Identifier: MIT
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/neighborhood.hpp"

namespace ced {

/// The norm a centroid distance is measured in.
enum class norm_type { l1, l2, linf };

/// Parses "l1", "l2" or "linf"; throws std::invalid_argument otherwise.
norm_type parse_norm(const std::string& text);

/// The CED saliency of a `Dims`-dimensional per-point value: the distance, in
/// the given norm, from a point's value v_i to the mean of its neighbours'
/// values, with every dimension d scaled by `scale[d]` (the normalisation):
///
///     s_i = || scale ⊙ ( mean_{j ∈ N(i)} v_j − v_i ) ||
///
/// The mean is accumulated as the mean of differences (v_j − v_i) in double,
/// which is exact for integer channels and stable for large coordinates.
/// `Dims` = 0 means the dimension is chosen at run time.
///
/// This is the evaluator most modalities return from `bind()`. The detector
/// does not call it per neighbourhood: it reads `channels()`, sums
/// (v_j − v_i) for all such modalities in one vectorised neighbour pass and
/// calls `from_sums()`. `operator()(neighborhood)` computes the same value
/// from a neighbour list (in double, so it may differ in the last bits).
/// Threading: const, safe to share.
template <int Dims = 0>
class centroid_distance {
 public:
  /// `values` holds N×dims floats (row-major); `scale` has dims entries.
  centroid_distance(std::vector<float> values, std::vector<double> scale, norm_type norm)
      : m_values(std::move(values)), m_scale(std::move(scale)), m_norm(norm), m_dims(m_scale.size()) {
    if (m_dims == 0 || (Dims != 0 && m_dims != std::size_t(Dims)))
      throw std::invalid_argument("centroid_distance: wrong number of dimensions");
    if (m_values.size() % m_dims != 0) throw std::invalid_argument("centroid_distance: values not a multiple of dims");
  }
  /// The distance from a point's position to its neighbours' centroid, L2
  /// scaled by `scale`. Reads the cloud's positions in place: the cloud must
  /// outlive the evaluator.
  centroid_distance(const point_cloud& cloud, std::vector<double> scale)
      : m_positions(cloud.positions().data()), m_scale(std::move(scale)), m_norm(norm_type::l2), m_dims(3) {
    if (m_scale.size() != 3 || (Dims != 0 && Dims != 3))
      throw std::invalid_argument("centroid_distance: positions have 3 dimensions");
  }

  std::size_t dims() const noexcept { return Dims != 0 ? std::size_t(Dims) : m_dims; }
  /// N×dims floats, row-major.
  const float* data() const noexcept { return m_positions ? m_positions : m_values.data(); }

  /// What the neighbour pass sums for this modality.
  channel_source channels() const noexcept {
    return {data(), static_cast<std::uint32_t>(dims()), m_positions != nullptr};
  }
  /// The saliency from Σ_{j ∈ N(i)} (v_j − v_i) (dims values) and |N(i)| = n.
  float from_sums(const double* sums, std::uint32_t n) const noexcept { return finish(sums, dims(), n); }

  float operator()(const neighborhood& nb) const noexcept {
    if constexpr (Dims != 0) {
      // Two interleaved partial sums halve the add-latency chain; the order
      // is fixed, so the result is still deterministic.
      std::array<double, Dims> a0{}, a1{};
      const float* values = data();
      const float* vi = values + std::size_t(Dims) * nb.point;
      const std::uint32_t* j = nb.indices;
      const std::uint32_t n = nb.size;
      std::uint32_t k = 0;
      for (; k + 1 < n; k += 2) {
        const float* v0 = values + std::size_t(Dims) * j[k];
        const float* v1 = values + std::size_t(Dims) * j[k + 1];
        for (int d = 0; d < Dims; ++d) {
          a0[std::size_t(d)] += static_cast<double>(v0[d] - vi[d]);
          a1[std::size_t(d)] += static_cast<double>(v1[d] - vi[d]);
        }
      }
      if (k < n) {
        const float* v0 = values + std::size_t(Dims) * j[k];
        for (int d = 0; d < Dims; ++d) a0[std::size_t(d)] += static_cast<double>(v0[d] - vi[d]);
      }
      for (int d = 0; d < Dims; ++d) a0[std::size_t(d)] += a1[std::size_t(d)];
      return finish(a0.data(), std::size_t(Dims), nb.size);
    } else {
      const std::size_t dims = m_dims;
      const float* values = data();
      const float* vi = values + dims * nb.point;
      if (dims <= k_small) {  // neighbour-outer, as the fixed-size path
        std::array<double, k_small> acc{};
        for (std::uint32_t j : nb) {
          const float* vj = values + dims * j;
          for (std::size_t d = 0; d < dims; ++d) acc[d] += static_cast<double>(vj[d] - vi[d]);
        }
        return finish(acc.data(), dims, nb.size);
      }
      // Dimension-outer, so that any number of bands needs no buffer; the
      // norm in four chains, as finish() adds many bands.
      double r[4] = {0, 0, 0, 0};
      const double inv_n = 1.0 / nb.size;
      for (std::size_t d = 0; d < dims; ++d) {
        double acc = 0;
        for (std::uint32_t j : nb) acc += static_cast<double>(values[dims * j + d] - vi[d]);
        r[d % 4] = combine(r[d % 4], acc * inv_n * m_scale[d]);
      }
      const double result = join_chains(r, m_norm);
      return static_cast<float>(m_norm == norm_type::l2 ? std::sqrt(result) : result);
    }
  }

 private:
  static constexpr std::size_t k_small = 16;

  /// Adds one scaled mean difference m to the norm's running value.
  template <norm_type N>
  static double combine(double so_far, double m) noexcept {
    if constexpr (N == norm_type::l1)
      return so_far + std::abs(m);
    else if constexpr (N == norm_type::l2)
      return so_far + m * m;
    else
      return std::max(so_far, std::abs(m));
  }
  double combine(double so_far, double m) const noexcept {
    switch (m_norm) {
      case norm_type::l1:
        return combine<norm_type::l1>(so_far, m);
      case norm_type::l2:
        return combine<norm_type::l2>(so_far, m);
      case norm_type::linf:
        return combine<norm_type::linf>(so_far, m);
    }
    return so_far;
  }
  /// The norm's four chains of many bands (band d in chain d mod 4) as one
  /// value, in a fixed order.
  static double join_chains(const double (&r)[4], norm_type norm) noexcept {
    return norm == norm_type::linf ? std::max(std::max(r[0], r[1]), std::max(r[2], r[3]))
                                   : (r[0] + r[1]) + (r[2] + r[3]);
  }
  template <norm_type N>
  float finish(const double* acc, std::size_t dims, double inv_n) const noexcept {
    double result = 0;
    if (dims <= k_small) {  // one chain, in dimension order (the paper's presets)
      for (std::size_t d = 0; d < dims; ++d) result = combine<N>(result, acc[d] * inv_n * m_scale[d]);
    } else {
      // Many bands: dimension d into chain d mod 4, the chains added in a
      // fixed order. Four independent chains of adds instead of one long
      // one; the same bits on every run and thread count.
      double r[4] = {0, 0, 0, 0};
      std::size_t d = 0;
      for (; d + 4 <= dims; d += 4)
        for (std::size_t c = 0; c < 4; ++c) r[c] = combine<N>(r[c], acc[d + c] * inv_n * m_scale[d + c]);
      for (; d < dims; ++d) r[d % 4] = combine<N>(r[d % 4], acc[d] * inv_n * m_scale[d]);
      result = join_chains(r, N);
    }
    return static_cast<float>(N == norm_type::l2 ? std::sqrt(result) : result);
  }
  float finish(const double* acc, std::size_t dims, std::uint32_t n) const noexcept {
    // One division per point: the mean of each dimension is its sum × 1/n.
    // The norm is chosen once, not per dimension.
    const double inv_n = 1.0 / n;
    switch (m_norm) {
      case norm_type::l1:
        return finish<norm_type::l1>(acc, dims, inv_n);
      case norm_type::l2:
        return finish<norm_type::l2>(acc, dims, inv_n);
      case norm_type::linf:
        return finish<norm_type::linf>(acc, dims, inv_n);
    }
    return 0.0f;
  }

  std::vector<float> m_values;
  const float* m_positions = nullptr;  // set: the values are a cloud's positions
  std::vector<double> m_scale;
  norm_type m_norm;
  std::size_t m_dims;
};

}  // namespace ced
