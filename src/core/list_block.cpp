// SPDX-License-Identifier: MIT
#include "core/list_block.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/kernel/dispatch.hpp"

namespace ced {

void list_block::set_channels(const std::vector<channel_source>& sources) {
  m_balls.set_channels({});          // positions only: the balls are for their lists,
  m_balls.set_keep_distances(true);  // kept with their distances
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

/// Sorts a[0..n) of distinct keys without a branch to mispredict (each key
/// goes to its rank), through `scratch` (room for n); std::sort beyond 32.
template <class T>
void sort_distinct(T* a, std::size_t n, T* scratch) {
  if (n > 32) {
    std::sort(a, a + n);
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    T rank = 0;  // as wide as the keys: one vector lane each
    for (std::size_t j = 0; j < n; ++j) rank += a[j] < a[i];
    scratch[rank] = a[i];
  }
  std::copy_n(scratch, n, a);
}

float float_of(std::int32_t bits) noexcept {
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

std::int32_t bits_of(float f) noexcept {
  std::int32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  return bits;
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
  if (m_scratch.size() < m_found.size()) m_scratch.resize(2 * m_found.size());
  sort_distinct(m_found.data(), m_found.size(), m_scratch.data());
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
  // A point among k or more coincident ones has them as its k nearest: its
  // ball would hold every one of them (50,000 invalid returns at the origin
  // made each point's ball 50,000 points).
  m_short.clear();
  for (std::size_t q = 0; q < m_count; ++q)
    if (!index.coincident_nearest(m_points[q], k, m_ranked.data() + q * k))
      m_short.push_back(static_cast<std::uint32_t>(q));
  // ρ: the largest k-distance of every 32nd point (bounded by CGAL's k
  // nearest within the tree that holds it), or its adaptive radius if
  // larger (so that the ball holds the point's own ball too). Any ρ
  // gives the same lists; a ball of fewer than k points is asked again with
  // 2ρ (twice at most), then of CGAL.
  double rho = 0;
  for (std::size_t q = 0; q < m_count; q += 32) {
    const double dk =
        std::sqrt(double(index.k_distance_bound(xyz + 3 * std::size_t(m_points[q]), k, m_position + q, m_one)));
    rho = std::max(rho, dk);
    if (n.kind == neighborhood_kind::adaptive) rho = std::max(rho, adaptive_radius(n, k < n.k ? HUGE_VAL : dk));
  }
  rho = rho * 1.25 + 1e-30;  // a quarter to spare: points between the samples may be sparser
  for (int round = 0; round < 3 && !m_short.empty(); ++round, rho *= 2) {
    m_asked.resize(m_short.size());
    for (std::size_t t = 0; t < m_short.size(); ++t) m_asked[t] = m_points[m_short[t]];
    m_balls.fill(grid, xyz, m_asked.data(), m_asked.size(), rho);
    std::size_t still = 0;
    for (std::size_t t = 0; t < m_short.size(); ++t) {
      const neighbor_block::ball_view ball = m_balls.ball(t);
      if (ball.count < k)
        m_short[still++] = m_short[t];
      else
        select_nearest(ball, m_short[t], n, rho);
    }
    m_short.resize(still);
  }
  for (const std::uint32_t q : m_short) by_cgal(q);
}

void list_block::select_nearest(const neighbor_block::ball_view& the_ball, std::size_t q, const neighborhood_spec& spec,
                                double rho) {
  // The ball holds every point nearer than ρ, at least k of them (the point
  // itself, whose distance reads −1, among them), so every point as near as
  // the k-th.
  const std::size_t want = m_near_k;
  const std::size_t found = the_ball.count;
  const std::int32_t* bits = the_ball.d2_bits;
  const std::size_t room = found + 8;
  if (m_keys.size() < 2 * room) {  // the keys in [lo, hi] and their sort's scratch
    m_keys.resize(4 * room);
    m_split_bits.resize(4 * room);  // below lo, then from `room` on those in [lo, hi]
    m_split_ids.resize(4 * room);
  }
  // Narrow [lo, hi] around the want-th smallest distance (as bits: non-
  // negative floats order as their bits do) until it holds at most 12
  // points, with branch-free, vectorised counting passes (a selection by
  // comparisons mispredicts half its branches). Each pass counts below two
  // cuts aimed, by interpolation, a few points either side of the want-th:
  // on a surface the count grows as d², so evenly in the distances' values.
  // After three passes the cuts halve the range, so it always ends.
  std::int32_t lo = -1, hi = bits_of(squared_radius(rho));  // every distance is below ρ²
  std::size_t below = 0, up_to = found;                     // points nearer than lo, and not farther than hi
  for (int pass = 0; up_to - below > 12 && lo < hi; ++pass) {
    std::int32_t a = lo + (hi - lo) / 2, b = a;
    if (pass < 3) {
      const double v0 = lo < 0 ? 0.0 : double(float_of(lo)), v1 = float_of(hi);
      auto aim = [&](double count) {
        const double f = std::min(std::max((count - double(below)) / double(up_to - below), 0.0), 1.0);
        return std::min(std::max(bits_of(static_cast<float>(v0 + (v1 - v0) * f)), lo), hi - 1);
      };
      a = aim(double(want) - 4.5);
      b = std::max(a, aim(double(want) + 3.5));
    }
    std::int32_t to_a = 0, to_b = 0;
    for (std::size_t t = 0; t < found; ++t) to_a += bits[t] <= a, to_b += bits[t] <= b;
    if (std::size_t(to_a) >= want) {
      hi = a, up_to = std::size_t(to_a);
    } else if (std::size_t(to_b) >= want) {
      lo = a + 1, below = std::size_t(to_a), hi = b, up_to = std::size_t(to_b);
    } else {
      lo = b + 1, below = std::size_t(to_b);
    }
  }
  // The points nearer than lo (fewer than want), then those in [lo, hi] by
  // distance and index: the k-th nearest, the last of the list, is the
  // largest of those taken.
  neighbor_index::ranked_point* to = m_ranked.data() + q * m_near_k;
  std::int32_t* const below_bits = m_split_bits.data();
  std::uint32_t* const below_ids = m_split_ids.data();
  std::uint32_t ranged = 0;
  std::size_t n = detail::split_distances(bits, the_ball.ids, static_cast<std::uint32_t>(found), lo, hi, below_bits,
                                          below_ids, below_bits + room, below_ids + room, &ranged);
  for (std::size_t t = 0; t < n; ++t) to[t] = {float_of(std::max(below_bits[t], 0)), below_ids[t]};  // itself at 0
  // (distance, index), the point itself first (its −1 as 0, the rest + 1)
  std::uint64_t* const in_range = m_keys.data();
  for (std::size_t t = 0; t < ranged; ++t)
    in_range[t] = std::uint64_t(std::uint32_t(below_bits[room + t] + 1)) << 32 | below_ids[room + t];
  sort_distinct(in_range, ranged, in_range + ranged);
  for (std::size_t t = 0; n < want; ++t, ++n) {
    const auto d = static_cast<std::int32_t>(std::max<std::int64_t>(std::int64_t(in_range[t] >> 32) - 1, 0));
    to[n] = {float_of(d), static_cast<std::uint32_t>(in_range[t])};
  }
  if (!m_own_first.empty()) own_ball(q, spec, rho, the_ball);
}

void list_block::own_ball(std::size_t q, const neighborhood_spec& n, double rho,
                          const neighbor_block::ball_view& ball) {
  // An adaptive radius beyond the k-th distance but within ρ: the ball of ρ
  // holds its ball (the points nearer than it, and the point itself).
  const float kth = m_ranked[q * m_near_k + m_near_k - 1].d2;
  const double r = adaptive_radius(n, m_near_k < n.k ? HUGE_VAL : std::sqrt(double(kth)));
  const float r2 = squared_radius(r);
  if (!(r2 > kth) || r2 > squared_radius(rho)) return;
  m_own_first[q] = m_own.size();
  m_own.push_back(m_points[q]);
  for (std::size_t t = 0; t < ball.count; ++t)  // the point itself reads −1
    if (ball.d2_bits[t] >= 0 && float_of(ball.d2_bits[t]) < r2) m_own.push_back(ball.ids[t]);
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
