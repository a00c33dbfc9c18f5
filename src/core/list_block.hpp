// SPDX-License-Identifier: MIT
// Private: the neighbour pass over one block of points by lists, on CGAL's
// spatial search (stage 2 of detection for knn and adaptive neighbourhoods,
// and for the fixed radius with search = cgal, the reference path).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "ced/neighborhood.hpp"
#include "ced/params.hpp"
#include "core/neighbor_index.hpp"

namespace ced {

/// One block's neighbourhoods as lists, each sorted by index, with each
/// point's own radius, neighbour count and channel sums Σ (v_j − v_i),
/// accumulated in double in index order (so a part of the cloud that holds
/// the same neighbours in the same relative order gives bitwise the same
/// sums). Reusable; not thread-safe, one per thread.
class list_block {
 public:
  /// The channels summed by fill(); slot s of the view's sums is sources[s].
  void set_channels(const std::vector<channel_source>& sources);
  /// The neighbourhoods of points[0..count) under `params` (its radius and
  /// neighbourhood), searched in `index` (built over `xyz`).
  void fill(const neighbor_index& index, const float* xyz, const std::uint32_t* points, std::size_t count,
            const detect_params& params);

  std::size_t size() const noexcept { return m_count; }
  std::uint32_t point(std::size_t k) const noexcept { return m_points[k]; }
  std::uint32_t count(std::size_t k) const noexcept { return m_counts[k]; }
  /// Point k's own radius: the fixed radius, the distance to its k-th
  /// nearest point (knn), or its clamped adaptive radius.
  double radius(std::size_t k) const noexcept { return m_radii[k]; }
  neighborhood operator[](std::size_t k) const noexcept {
    return {m_points[k], m_indices.data() + m_offsets[k], m_counts[k]};
  }
  block_view view() const noexcept {
    return {m_count, m_points, m_counts.data(), m_sums.data(), m_sum_stride, m_slot_offset.data(), this, &list_of};
  }

 private:
  static neighborhood list_of(const void* block, std::size_t k) { return (*static_cast<const list_block*>(block))[k]; }
  /// Point i's neighbours (appended to m_indices, sorted) and its radius.
  double gather(const neighbor_index& index, const float* xyz, std::uint32_t i, const detect_params& params);
  void sum(const float* xyz, std::size_t k);

  std::vector<channel_source> m_sources;
  std::vector<std::size_t> m_slot_offset;
  std::size_t m_sum_stride = 3;
  const std::uint32_t* m_points = nullptr;
  std::size_t m_count = 0;
  std::vector<std::uint32_t> m_counts, m_indices;
  std::vector<std::size_t> m_offsets;
  std::vector<double> m_radii, m_sums;
  std::vector<std::uint32_t> m_found;
  std::vector<neighbor_index::ranked_point> m_ranked;
};

}  // namespace ced
