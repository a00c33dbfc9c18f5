// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "ced/neighbor_index.hpp"

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

 private:
  std::vector<std::uint32_t> m_order;
  std::vector<std::size_t> m_starts;
};

/// The fixed-radius neighbourhoods of the points of one block, in CSR form.
/// Reusable: filling it again keeps the buffers' capacity.
class neighbor_block {
 public:
  /// Fills the neighbourhoods (|p_j - p_i|² < r², float) of points
  /// `points[0..count)` with one box query to `index` for the whole block.
  void fill(const neighbor_index& index, const float* xyz, const std::uint32_t* points, std::size_t count, double r);

  std::size_t size() const noexcept { return m_count; }
  std::uint32_t point(std::size_t k) const noexcept { return m_points[k]; }
  neighborhood operator[](std::size_t k) const noexcept {
    return {m_points[k], m_indices.data() + m_offsets[k], m_offsets[k + 1] - m_offsets[k]};
  }

 private:
  const std::uint32_t* m_points = nullptr;
  std::size_t m_count = 0;
  std::vector<std::uint32_t> m_offsets;
  std::vector<std::uint32_t> m_indices;
  std::vector<std::uint32_t> m_gathered;
  std::vector<float> m_gx, m_gy, m_gz;
};

namespace detail {
/// Bounds of points[0..count) grown by a little more than r, widened by one
/// ulp: a box that holds every point within r of any of them.
void padded_bounds(const float* xyz, const std::uint32_t* points, std::size_t count, double r, float lo[3],
                   float hi[3]) noexcept;
}  // namespace detail

}  // namespace ced
