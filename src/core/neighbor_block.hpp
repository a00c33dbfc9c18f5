// SPDX-License-Identifier: MIT
// Private: the neighbour pass over one spatial block (stage 2 of detection).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "ced/neighborhood.hpp"
#include "core/block_partition.hpp"
#include "core/kernel/block_kernel.hpp"
#include "core/neighbor_index.hpp"
#include "core/raw_vector.hpp"

namespace ced {

/// The neighbour pass over one spatial block: one box query to the block grid
/// for the whole block, the gathered points sorted into sub-cells (≈ r wide in y
/// and z, r/8 in x), then per point one vectorised sweep over the nine runs
/// of sub-cells its ball reaches, which counts its neighbours
/// (|p_j - p_i|² < r², float) and sums (v_j − v_i) over them for every
/// channel at once. The sweep's hit bits are kept (sweep()); neighbour lists
/// are written only when asked for (modalities that read lists).
///
/// Reusable: filling it again keeps the buffers' capacity. Not thread-safe;
/// use one per thread.
class neighbor_block {
 public:
  /// The channels summed by fill(); slot s of sums() is sources[s].
  void set_channels(const std::vector<channel_source>& sources);
  /// Whether fill() records which points are neighbours (default true).
  /// Without, only counts and sums are made, and neighbors(), operator[]
  /// and sweep() must not be called: a pass that needs no lists and has no
  /// candidates (a scaled modality's own pass) skips that work.
  void set_keep_lists(bool keep) noexcept { m_keep_lists = keep; }
  /// Whether fill() only prepares each point's ball for ball(), instead of
  /// making counts, sums and lists (default false; only for positions
  /// alone, no channels). Then only size(), point() and ball() may be
  /// called.
  void set_keep_distances(bool keep) noexcept { m_keep_distances = keep; }
  /// Whether fill() also sums the positions' second moments Σ d dᵀ, d =
  /// p_j − p_i (default false; only with no channels, as set_channels was
  /// given positions alone). They follow the position sums: view()'s
  /// position_sums(k)[3..9) hold xx, yy, zz, xy, xz, yz.
  void set_moments(bool on);

  /// Runs the pass for points `points[0..count)`, gathering from the blocks'
  /// grid (in an order that does not depend on the rest of the cloud: a
  /// part of the cloud that holds the block's cell and the cells around it
  /// gives bitwise the same sums).
  void fill(const block_partition& grid, const float* xyz, const std::uint32_t* points, std::size_t count, double r);

  std::size_t size() const noexcept { return m_count; }
  std::uint32_t point(std::size_t k) const noexcept { return m_points[k]; }
  /// Neighbours of point k within the radius, itself included.
  std::uint32_t count(std::size_t k) const noexcept { return m_counts[k]; }
  /// Σ_{j ∈ N(i)} (v_j − v_i) for channel slot `slot` (sources[slot].dims
  /// values), accumulated in float over 8 fixed lanes and reduced in double
  /// (positions as p_j − p_i; other channels as v_j − ref for a per-block
  /// reference, then n·(v_i − ref) taken off in double; past 16 channels,
  /// one float sum of v_j a channel in sweep order, then n·v_i taken off in
  /// double).
  const double* sums(std::size_t k, std::size_t slot) const noexcept {
    return m_sums.data() + m_sum_stride * k + m_slot_offset[slot];
  }
  /// Writes point k's count(k) neighbours to `out`, in the block's fixed order.
  void neighbors(std::size_t k, std::uint32_t* out) const noexcept;
  /// Point k's ball (set_keep_distances), swept now: its neighbours in the
  /// block's fixed order, with their float squared distances from it (as
  /// squared_distance() computes them) as bits, which order as the
  /// distances do, and −1 for the point itself. Valid until the next call;
  /// both arrays are readable 8 entries past `count`.
  struct ball_view {
    const std::int32_t* d2_bits;
    const std::uint32_t* ids;
    std::size_t count;
  };
  ball_view ball(std::size_t k);
  /// Point k's neighbourhood as a list (all lists are built on first use).
  neighborhood operator[](std::size_t k) const;
  /// The block as modalities see it (valid while the block is not refilled).
  block_view view() const noexcept {
    return {m_count, m_points, m_counts.data(), m_sums.data(), m_sum_stride, m_slot_offset.data(), this, &list_of};
  }

  /// The sweep's raw result for point k: nine [begin, end) ranges into
  /// gathered(), walked in order eight points at a time, and one byte of hit
  /// bits per group of eight (bit l: gathered point begin + 8·g + l is a
  /// neighbour). A compact form of the neighbourhood (the NMS keeps it).
  struct sweep_view {
    const std::uint32_t* ranges;  ///< 2 × sweep_ranges
    const std::uint8_t* bits;
    std::size_t bytes;
  };
  static constexpr std::size_t sweep_ranges = 9;
  sweep_view sweep(std::size_t k) const noexcept {
    return {m_ranges.data() + 2 * sweep_ranges * k, m_bits.data() + m_bit_offsets[k],
            std::size_t(m_bit_offsets[k + 1] - m_bit_offsets[k])};
  }
  /// The points gathered for the block, in sweep order (gathered_count() of them).
  const std::uint32_t* gathered() const noexcept { return m_gathered.data(); }
  std::size_t gathered_count() const noexcept { return m_raw.size(); }

 private:
  static neighborhood list_of(const void* block, std::size_t k) {
    return (*static_cast<const neighbor_block*>(block))[k];
  }
  void sort_into_cells(const float lo[3], const float hi[3], double r);
  /// The pass over the gathered points m_raw (fill(), which has set the centres).
  void run(const std::uint32_t* points, std::size_t count, double r, const float lo[3], const float hi[3]);
  std::size_t copy_channels_in(const std::uint32_t* points, std::size_t count);
  /// Per point: its runs and where its hit bits start (m_centre filled).
  void set_up_rows(std::size_t count, double r);
  template <class StartOf>
  void rows_of_points(std::size_t count, double r, StartOf start_of);
  void cell_of(const float* p, std::uint64_t c[3]) const noexcept {
    // Truncation is floor here: the value is clamped to ≥ 0 first.
    for (int a = 0; a < 3; ++a) {
      const double v = (double(p[a]) - m_lo[a]) * m_inv_side[a];
      c[a] = static_cast<std::uint64_t>(std::min(std::max(v, 0.0), double(m_dims[a] - 1)));
    }
  }
  /// Index of the first gathered point in cell `key` or after it.
  std::size_t cell_start(std::uint64_t key) const noexcept {
    return m_counted ? m_cell_start[key] : cell_start_sorted(key);
  }
  std::size_t cell_start_sorted(std::uint64_t key) const noexcept;

  std::vector<channel_source> m_sources;
  std::vector<std::size_t> m_slot_offset;
  std::size_t m_channels = 0, m_sum_stride = 3;

  const std::uint32_t* m_points = nullptr;
  std::size_t m_count = 0;
  // The gathered points in sub-cell order, as structure of arrays.
  double m_lo[3] = {0, 0, 0}, m_side[3] = {1, 1, 1}, m_inv_side[3] = {1, 1, 1};
  std::uint64_t m_dims[3] = {1, 1, 1};
  bool m_single_cell = false, m_counted = false;
  // The box query's points and positions, then sorted into sub-cells.
  detail::raw_vector<neighbor_index::located_point> m_raw;
  std::vector<std::uint32_t> m_gathered, m_cell_start, m_cell_key;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> m_keyed;
  std::vector<float> m_gx, m_gy, m_gz, m_channel_values, m_centre, m_own;
  // Per point: ranges, results, and the neighbour bits of its groups.
  std::vector<std::uint32_t> m_ranges, m_counts, m_bit_offsets;
  std::vector<std::uint32_t> m_places;                                // the kernel's row_scratch (many channels)
  std::vector<detail::block_kernel_input::row_source> m_row_sources;  // (many channels)
  std::vector<double> m_sums;
  std::vector<std::uint8_t> m_bits;
  // Lists, built on demand.
  mutable bool m_lists_built = false;
  bool m_keep_lists = true, m_keep_distances = false, m_moments = false;
  // The balls with their distances (set_keep_distances).
  std::vector<std::int32_t> m_ball_bits;
  std::vector<std::uint32_t> m_ball_ids;
  float m_r2 = 0;
  mutable std::vector<std::uint32_t> m_offsets, m_indices;
};

}  // namespace ced
