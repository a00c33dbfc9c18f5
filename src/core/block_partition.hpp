// SPDX-License-Identifier: MIT
// Private: the points grouped into spatial blocks (stage 1 of detection).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/neighbor_index.hpp"
#include "core/raw_vector.hpp"

namespace ced {

/// The points grouped into spatial blocks (cubic grid cells). Work is done
/// block by block: one index query per block, then an exact per-point filter.
/// The grouping depends only on the points and the cell size, never on the
/// number of threads. Points of a block are in ascending index order.
class block_partition {
 public:
  block_partition() = default;
  block_partition(const float* xyz, std::size_t n, double cell_size, unsigned threads = 1);

  std::size_t block_count() const noexcept { return m_starts.empty() ? 0 : m_starts.size() - 1; }
  const std::uint32_t* block_points(std::size_t b) const noexcept { return m_order.data() + m_starts[b]; }
  std::size_t block_size(std::size_t b) const noexcept { return m_starts[b + 1] - m_starts[b]; }
  /// All points, block after block: a spatially coherent permutation.
  const std::vector<std::uint32_t>& order() const noexcept { return m_order; }

  /// The points inside the closed box [lo, hi], cell by cell in key order
  /// and by index within a cell: an order that depends only on the points
  /// in and near the box, not on the rest of the cloud (cells lie at whole
  /// multiples of the cell size), so a part of the cloud that holds them
  /// gets the same order.
  void box_search(const float lo[3], const float hi[3], detail::raw_vector<neighbor_index::located_point>& out) const;
  /// The same points, indices only.
  void box_search(const float lo[3], const float hi[3], detail::raw_vector<std::uint32_t>& out) const;
  /// detail::padded_bounds of the points order()[first, first + count),
  /// the same box, read from the partition's own copy of their positions.
  void padded_bounds(std::size_t first, std::size_t count, double r, float lo[3], float hi[3]) const noexcept;
  /// The positions of order()[first, first + count) to out, 3 floats each.
  void copy_positions(std::size_t first, std::size_t count, float* out) const noexcept {
    for (std::size_t q = 0; q < count; ++q) {
      out[3 * q] = m_x[first + q];
      out[3 * q + 1] = m_y[first + q];
      out[3 * q + 2] = m_z[first + q];
    }
  }
  /// The cell size used (the one asked for, unless the grid would not fit
  /// 64-bit keys: then doubled until it does).
  double cell_size() const noexcept { return 1.0 / m_inv; }

 private:
  /// Boxes of up to this many rows of cells (y, z) are searched row by row.
  static constexpr std::size_t max_box_rows = 64;
  /// The cells [c0, c1] that the box meets; false when none.
  bool cell_range(const float lo[3], const float hi[3], std::int64_t c0[3], std::int64_t c1[3]) const;
  /// Each row of the box's cells that holds points, as [begin, end) of the
  /// order (2 entries a row, in key order); max_box_rows + 1 when the box
  /// has more rows than that.
  std::size_t row_runs(const float lo[3], const float hi[3], std::size_t* runs) const;
  /// A box search into `out`: select(begin, end, to) selects a run of the
  /// order to `to` (up to 8 written past its count), one(j, p) makes the
  /// entry of point j at p for boxes of many rows.
  template <class T, class Select, class One>
  void search_rows(const float lo[3], const float hi[3], detail::raw_vector<T>& out, Select select, One one) const;
  template <class F>
  void for_each_in_box(const float lo[3], const float hi[3], F&& f) const;

  std::vector<std::uint32_t> m_order;
  detail::raw_vector<float> m_x, m_y, m_z;  // the positions in that order
  std::vector<std::size_t> m_starts;
  std::vector<std::uint64_t> m_cell_keys;  // the occupied cells, ascending
  std::vector<std::size_t> m_cell_starts;  // where each starts in m_order (and the end)
  double m_base[3] = {0, 0, 0};            // the first cell's coordinates, in cells
  std::uint64_t m_dims[3] = {0, 0, 0};
  double m_inv = 1;
};

namespace detail {
/// Bounds of points[0..count) grown by a little more than r, widened by one
/// ulp: a box that holds every point within r of any of them.
void padded_bounds(const float* xyz, const std::uint32_t* points, std::size_t count, double r, float lo[3],
                   float hi[3]) noexcept;
}  // namespace detail

}  // namespace ced
