// SPDX-License-Identifier: MIT
// What a saliency measure sees of the detector's neighbour pass: one point's
// neighbourhood as a list, the channels it asks the pass to sum, and a block
// of points with their neighbour counts and sums.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ced {

/// The neighbourhood of one point, as a saliency measure sees it: the point's
/// index and the indices of all points within the radius (itself included),
/// in a deterministic order.
struct neighborhood {
  std::uint32_t point;
  const std::uint32_t* indices;
  std::uint32_t size;

  const std::uint32_t* begin() const noexcept { return indices; }
  const std::uint32_t* end() const noexcept { return indices + size; }
};

/// Per-point values whose neighbourhood sums the neighbour pass computes: the
/// input of every centroid-distance saliency (the fast extension point; see
/// docs/MODALITIES.md).
struct channel_source {
  /// N×dims floats, row-major; nullptr when the modality needs no sums (it
  /// reads neighbour lists instead). Must stay valid during the detection.
  const float* values = nullptr;
  std::uint32_t dims = 0;
  /// The values are the cloud's positions: their sums come from the distance
  /// test itself.
  bool positions = false;
};

/// One spatial block of the neighbour pass, as modalities see it: its points,
/// each point's neighbour count and, per channel slot, the sums
/// Σ_{j ∈ N(i)} (v_j − v_i). Made by the detector; valid only during the
/// call that receives it. Reading it is cheap (inline loads), so the
/// compile-time `detect` loses nothing to it.
class block_view {
 public:
  /// Builds a neighbour list on demand (the detector's own function).
  using list_fn = neighborhood (*)(const void* block, std::size_t k);

  block_view(std::size_t size, const std::uint32_t* points, const std::uint32_t* counts, const double* sums,
             std::size_t sum_stride, const std::size_t* slot_offsets, const void* block, list_fn list) noexcept
      : m_size(size),
        m_points(points),
        m_counts(counts),
        m_sums(sums),
        m_sum_stride(sum_stride),
        m_slot_offsets(slot_offsets),
        m_block(block),
        m_list(list) {}

  /// Number of points in the block.
  std::size_t size() const noexcept { return m_size; }
  /// Index (into the cloud) of the block's k-th point.
  std::uint32_t point(std::size_t k) const noexcept { return m_points[k]; }
  /// Neighbours of point k within the radius, itself included.
  std::uint32_t count(std::size_t k) const noexcept { return m_counts[k]; }
  /// Σ_{j ∈ N(i)} (v_j − v_i) of channel slot `slot` at point k (as many
  /// values as that slot's channel_source::dims), in double.
  const double* sums(std::size_t k, std::size_t slot) const noexcept {
    return m_sums + m_sum_stride * k + m_slot_offsets[slot];
  }
  /// Σ_{j ∈ N(i)} (p_j − p_i) at point k (3 values), in double: every pass
  /// makes them (the distance test itself), whatever the modalities' channels.
  const double* position_sums(std::size_t k) const noexcept { return m_sums + m_sum_stride * k; }
  /// Point k's neighbourhood as a list (the block's lists are built on first
  /// use, so a modality that never asks costs nothing).
  neighborhood operator[](std::size_t k) const { return m_list(m_block, k); }

 private:
  std::size_t m_size;
  const std::uint32_t* m_points;
  const std::uint32_t* m_counts;
  const double* m_sums;
  std::size_t m_sum_stride;
  const std::size_t* m_slot_offsets;
  const void* m_block;
  list_fn m_list;
};

}  // namespace ced
