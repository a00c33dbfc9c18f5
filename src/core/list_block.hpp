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
#include "core/neighbor_block.hpp"
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
  /// neighbourhood), searched in `index` (built over `xyz` with the order of
  /// `grid`, whose block `points` is) or, with search = grid and a knn or
  /// adaptive neighbourhood, mostly on `grid` (see fill_nearest).
  void fill(const neighbor_index& index, const block_partition& grid, const float* xyz, const std::uint32_t* points,
            std::size_t count, const detect_params& params);

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
  /// Point k's neighbours (appended to m_indices, sorted) and its radius.
  double gather(const neighbor_index& index, const float* xyz, std::size_t k, const detect_params& params);
  void sum(const float* xyz, std::size_t k);
  /// Every point's k nearest (m_near_k of them, the k-th last) into
  /// m_ranked. With search = cgal, CGAL's k-nearest search for each point.
  /// With search = grid: CGAL's k-nearest search for a sample of the block
  /// bounds its k-distance by ρ, the grid gathers each point's ball of ρ
  /// (neighbor_block), and the k nearest are selected from it; a point whose
  /// ball holds fewer than k points falls back to CGAL. Both give the same
  /// lists (the ball holds every point as near as the k-th).
  void fill_nearest(const neighbor_index& index, const block_partition& grid, const float* xyz,
                    const detect_params& params);
  /// Point q's k nearest from its ball of ρ (which holds at least k
  /// points), into m_ranked. Under adaptive, also its own ball when the
  /// ball of ρ holds it (own_ball).
  void select_nearest(const neighbor_block::ball_view& ball, std::size_t q, const neighborhood_spec& spec, double rho);
  /// Point q's own adaptive ball from its ball of ρ, into m_own, when its
  /// radius lies beyond its k-th distance and within ρ (gather() queries
  /// CGAL otherwise).
  void own_ball(std::size_t q, const neighborhood_spec& n, double rho, const neighbor_block::ball_view& ball);

  std::vector<channel_source> m_sources;
  std::vector<std::size_t> m_slot_offset;
  std::size_t m_sum_stride = 3;
  const std::uint32_t* m_points = nullptr;
  std::size_t m_count = 0;
  std::vector<std::uint32_t> m_counts, m_indices;
  std::vector<std::size_t> m_offsets;
  std::vector<double> m_radii, m_sums;
  std::vector<std::uint32_t> m_found;
  /// The block's k nearest (knn, adaptive): m_near_k a point, the k-th last.
  std::vector<neighbor_index::ranked_point> m_ranked, m_one;
  std::size_t m_near_k = 0;
  std::size_t m_position = 0;  // the block's first point's position in the grid's order
  neighbor_block m_balls;
  std::vector<std::uint64_t> m_keys;  // (distance bits + 1, index) of the points in [lo, hi], and scratch
  std::vector<std::uint32_t> m_scratch, m_split_ids;
  std::vector<std::int32_t> m_split_bits;
  std::vector<std::uint32_t> m_short, m_asked;
  /// adaptive: point q's own ball, m_own[m_own_first[q] ..][.. m_own_size[q]]
  /// (SIZE_MAX: not made; gather() queries it).
  std::vector<std::size_t> m_own_first;
  std::vector<std::uint32_t> m_own_size, m_own;  // positions still without their k nearest, and their points
};

}  // namespace ced
