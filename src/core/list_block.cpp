// SPDX-License-Identifier: MIT
#include "core/list_block.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace ced {

void list_block::set_channels(const std::vector<channel_source>& sources) {
  m_balls.set_channels({});  // positions only: the balls are for their lists
  m_sources = sources;
  m_slot_offset.clear();
  std::size_t offset = 3;  // the position sums come first (block_view::position_sums)
  for (const auto& s : sources) {
    if (s.positions) {
      m_slot_offset.push_back(0);
      continue;
    }
    m_slot_offset.push_back(offset);
    offset += s.values ? s.dims : 0;
  }
  m_sum_stride = offset;
}

namespace {
/// An adaptive point's own radius from its k-th distance dk (infinite when
/// the cloud has fewer than K points).
double adaptive_radius(const neighborhood_spec& n, double dk) noexcept {
  return std::min(std::max(n.scale * dk, n.min_radius), n.max_radius);
}
}  // namespace

double list_block::gather(const neighbor_index& index, const float* xyz, std::size_t k, const detect_params& params) {
  const std::uint32_t i = m_points[k];
  const float* c = xyz + 3 * std::size_t(i);
  const neighborhood_spec& n = params.neighborhood;
  double r = params.radius;
  if (n.kind == neighborhood_kind::radius) {
    index.radius_search(c, r, m_found);
  } else {
    // Point k's nearest (m_near_k of them), the farthest last.
    const neighbor_index::ranked_point* first = m_ranked.data() + k * m_near_k;
    const neighbor_index::ranked_point* last = first + m_near_k;
    // Fewer than K points (adaptive with max only): the K-th is infinitely far.
    const double dk = m_near_k < n.k ? HUGE_VAL : std::sqrt(double(last[-1].d2));
    if (n.kind == neighborhood_kind::knn) {
      m_found.clear();
      for (auto p = first; p != last; ++p) m_found.push_back(p->index);
      r = dk;
    } else {
      r = adaptive_radius(n, dk);
      const float r2 = squared_radius(r);
      if (m_near_k == n.k && r2 <= last[-1].d2) {
        // Every point nearer than the k-th is in the list already.
        m_found.clear();
        for (auto p = first; p != last; ++p)
          if (p->d2 < r2) m_found.push_back(p->index);
      } else if (!m_own_first.empty() && m_own_first[k] != SIZE_MAX) {
        // Its ball of ρ held it (fill_nearest).
        m_found.assign(m_own.begin() + std::ptrdiff_t(m_own_first[k]),
                       m_own.begin() + std::ptrdiff_t(m_own_first[k] + m_own_size[k]));
      } else {
        index.radius_search(c, r, m_found);
      }
      // The point itself belongs to its neighbourhood even when its radius
      // is 0 (K points at one place and no floor).
      if (!(squared_radius(r) > 0)) m_found.assign(1, i);
    }
  }
  std::sort(m_found.begin(), m_found.end());
  m_indices.insert(m_indices.end(), m_found.begin(), m_found.end());
  return r;
}

void list_block::fill_nearest(const neighbor_index& index, const block_partition& grid, const float* xyz,
                              const detect_params& params) {
  const std::size_t k = m_near_k;
  m_ranked.resize(m_count * k);
  auto by_cgal = [&](std::size_t q) {
    index.k_nearest(xyz + 3 * std::size_t(m_points[q]), k, m_points[q], m_one, m_position + q);
    std::copy(m_one.begin(), m_one.end(), m_ranked.begin() + std::ptrdiff_t(q * k));
  };
  const neighborhood_spec& n = params.neighborhood;
  m_own_first.assign(n.kind == neighborhood_kind::adaptive ? m_count : 0, SIZE_MAX);
  m_own_size.resize(m_own_first.size());
  m_own.clear();
  if (params.search == search_kind::cgal) {
    for (std::size_t q = 0; q < m_count; ++q) by_cgal(q);
    return;
  }
  if (k == 1) {  // the point itself comes first: its only nearest
    for (std::size_t q = 0; q < m_count; ++q) m_ranked[q] = {0.0f, m_points[q]};
    return;
  }
  // ρ: the largest k-distance of every 32nd point, or its adaptive radius
  // if larger (so that the ball holds the point's own ball too). Any ρ
  // gives the same lists; a ball of fewer than k points is asked again with
  // 2ρ (twice at most), then of CGAL.
  double rho = 0;
  for (std::size_t q = 0; q < m_count; q += 32) {
    by_cgal(q);
    const double dk = std::sqrt(double(m_ranked[q * k + k - 1].d2));
    rho = std::max(rho, dk);
    if (n.kind == neighborhood_kind::adaptive) rho = std::max(rho, adaptive_radius(n, k < n.k ? HUGE_VAL : dk));
  }
  rho = rho * 1.25 + 1e-30;  // a quarter to spare: points between the samples may be sparser
  m_short.resize(m_count);  // m_balls keeps its lists (neighbor_block's default)
  for (std::size_t q = 0; q < m_count; ++q) m_short[q] = static_cast<std::uint32_t>(q);
  for (int round = 0; round < 3 && !m_short.empty(); ++round, rho *= 2) {
    m_asked.resize(m_short.size());
    for (std::size_t t = 0; t < m_short.size(); ++t) m_asked[t] = m_points[m_short[t]];
    m_balls.fill(grid, xyz, m_asked.data(), m_asked.size(), rho);
    std::size_t still = 0;
    for (std::size_t t = 0; t < m_short.size(); ++t) {
      if (m_balls.count(t) < k)
        m_short[still++] = m_short[t];
      else
        select_nearest(t, m_short[t], xyz + 3 * std::size_t(m_asked[t]), n, rho);
    }
    m_short.resize(still);
  }
  for (const std::uint32_t q : m_short) by_cgal(q);
}

void list_block::select_nearest(std::size_t ball, std::size_t q, const float* c, const neighborhood_spec& spec,
                                double rho) {
  // The ball holds every point nearer than ρ, at least k of them, so every
  // point as near as the k-th.
  const std::size_t want = m_near_k - 1;  // besides the point itself
  const std::uint32_t self = m_points[q];
  if (m_bits.size() < m_balls.count(ball)) {
    m_bits.resize(2 * m_balls.count(ball));
    m_ids.resize(2 * m_balls.count(ball));
    m_tied.resize(2 * m_balls.count(ball));
  }
  const std::size_t found = m_balls.neighbor_distances(ball, c, self, m_bits.data(), m_ids.data());
  const std::int32_t* bits = m_bits.data();
  // Narrow [lo, hi] around the want-th smallest distance (as bits: non-
  // negative floats order as their bits do) by bisection on counts, until
  // it holds at most 8 points: branch-free, vectorised passes, where a
  // selection by comparisons mispredicts half its branches.
  std::int32_t lo = bits[0], hi = bits[0];
  for (std::size_t t = 1; t < found; ++t) lo = std::min(lo, bits[t]), hi = std::max(hi, bits[t]);
  std::size_t below = 0, up_to = found;  // points nearer than lo, and not farther than hi
  while (up_to - below > 8 && lo < hi) {
    const std::int32_t mid = lo + (hi - lo) / 2;
    std::int32_t at_most = 0;
    for (std::size_t t = 0; t < found; ++t) at_most += bits[t] <= mid;
    const bool enough = std::size_t(at_most) >= want;
    hi = enough ? mid : hi;
    up_to = enough ? std::size_t(at_most) : up_to;
    lo = enough ? lo : mid + 1;
    below = enough ? below : std::size_t(at_most);
  }
  // The points nearer than lo (fewer than want), then those in [lo, hi] by
  // distance and index: the k-th nearest, the last of the list, is the
  // largest of those taken.
  neighbor_index::ranked_point* to = m_ranked.data() + q * m_near_k;
  auto at = [&](std::size_t t) {
    float d2;
    std::memcpy(&d2, &bits[t], sizeof d2);
    return neighbor_index::ranked_point{d2, m_ids[t]};
  };
  *to++ = {0.0f, self};
  neighbor_index::ranked_point* const in_range = m_tied.data();
  std::size_t n = 0, ranged = 0;
  for (std::size_t t = 0; t < found; ++t) {  // without a branch to mispredict
    const neighbor_index::ranked_point p = at(t);
    to[n] = p;
    in_range[ranged] = p;
    n += bits[t] < lo;
    ranged += bits[t] >= lo && bits[t] <= hi;
  }
  std::sort(in_range, in_range + ranged,
            [](const auto& a, const auto& b) { return a.d2 < b.d2 || (a.d2 == b.d2 && a.index < b.index); });
  std::copy_n(in_range, want - n, to + n);
  if (!m_own_first.empty()) own_ball(q, spec, rho, found);
}

void list_block::own_ball(std::size_t q, const neighborhood_spec& n, double rho, std::size_t found) {
  // An adaptive radius beyond the k-th distance but within ρ: the ball of ρ
  // holds its ball (the points nearer than it, and the point itself).
  const float kth = m_ranked[q * m_near_k + m_near_k - 1].d2;
  const double r = adaptive_radius(n, m_near_k < n.k ? HUGE_VAL : std::sqrt(double(kth)));
  const float r2 = squared_radius(r);
  if (!(r2 > kth) || r2 > squared_radius(rho)) return;
  m_own_first[q] = m_own.size();
  m_own.push_back(m_points[q]);
  for (std::size_t t = 0; t < found; ++t) {
    float d2;
    std::memcpy(&d2, &m_bits[t], sizeof d2);
    if (d2 < r2) m_own.push_back(m_ids[t]);
  }
  m_own_size[q] = static_cast<std::uint32_t>(m_own.size() - m_own_first[q]);
}

void list_block::sum(const float* xyz, std::size_t k) {
  const std::uint32_t i = m_points[k];
  const std::uint32_t* first = m_indices.data() + m_offsets[k];
  const std::uint32_t* last = first + m_counts[k];
  double* out = m_sums.data() + m_sum_stride * k;
  auto accumulate = [&](const float* values, std::size_t dims, double* to) {
    const float* vi = values + dims * i;
    if (dims == 3) {  // positions, colours: the same sums, unrolled
      const double v0 = vi[0], v1 = vi[1], v2 = vi[2];
      double s0 = 0, s1 = 0, s2 = 0;
      for (const std::uint32_t* j = first; j != last; ++j) {
        const float* vj = values + 3 * std::size_t(*j);
        s0 += double(vj[0]) - v0, s1 += double(vj[1]) - v1, s2 += double(vj[2]) - v2;
      }
      to[0] = s0, to[1] = s1, to[2] = s2;
      return;
    }
    for (std::size_t d = 0; d < dims; ++d) to[d] = 0;
    for (const std::uint32_t* j = first; j != last; ++j) {
      const float* vj = values + dims * *j;
      for (std::size_t d = 0; d < dims; ++d) to[d] += double(vj[d]) - double(vi[d]);
    }
  };
  accumulate(xyz, 3, out);
  for (std::size_t s = 0; s < m_sources.size(); ++s)
    if (!m_sources[s].positions && m_sources[s].values)
      accumulate(m_sources[s].values, m_sources[s].dims, out + m_slot_offset[s]);
}

void list_block::fill(const neighbor_index& index, const block_partition& grid, const float* xyz,
                      const std::uint32_t* points, std::size_t count, const detect_params& params) {
  m_points = points;
  m_count = count;
  m_position = static_cast<std::size_t>(points - grid.order().data());
  m_counts.resize(count);
  m_offsets.resize(count + 1);
  m_radii.resize(count);
  m_indices.clear();
  m_offsets[0] = 0;
  if (!params.neighborhood.fixed() && count > 0) {
    m_near_k = std::min<std::size_t>(params.neighborhood.k, index.size());
    fill_nearest(index, grid, xyz, params);
  }
  for (std::size_t k = 0; k < count; ++k) {
    m_radii[k] = gather(index, xyz, k, params);
    m_offsets[k + 1] = m_indices.size();
    m_counts[k] = static_cast<std::uint32_t>(m_offsets[k + 1] - m_offsets[k]);
  }
  m_sums.resize(m_sum_stride * count);
  for (std::size_t k = 0; k < count; ++k) sum(xyz, k);
}

}  // namespace ced
