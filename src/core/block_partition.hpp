// SPDX-License-Identifier: MIT
// Private: the points grouped into spatial blocks (stage 1 of detection).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

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

 private:
  std::vector<std::uint32_t> m_order;
  std::vector<std::size_t> m_starts;
};

namespace detail {
/// Bounds of points[0..count) grown by a little more than r, widened by one
/// ulp: a box that holds every point within r of any of them.
void padded_bounds(const float* xyz, const std::uint32_t* points, std::size_t count, double r, float lo[3],
                   float hi[3]) noexcept;
}  // namespace detail

}  // namespace ced
