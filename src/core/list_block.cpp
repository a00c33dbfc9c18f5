// SPDX-License-Identifier: MIT
#include "core/list_block.hpp"

#include <algorithm>
#include <cmath>

namespace ced {

void list_block::set_channels(const std::vector<channel_source>& sources) {
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

double list_block::gather(const neighbor_index& index, const float* xyz, std::uint32_t i, const detect_params& params) {
  const float* c = xyz + 3 * std::size_t(i);
  const neighborhood_spec& n = params.neighborhood;
  double r = params.radius;
  if (n.kind == neighborhood_kind::radius) {
    index.radius_search(c, r, m_found);
  } else {
    index.k_nearest(c, n.k, i, m_ranked);
    // Fewer than K points (adaptive with max only): the K-th is infinitely far.
    const double dk = m_ranked.size() < n.k ? HUGE_VAL : std::sqrt(double(m_ranked.back().d2));
    if (n.kind == neighborhood_kind::knn) {
      m_found.clear();
      for (const auto& p : m_ranked) m_found.push_back(p.index);
      r = dk;
    } else {
      r = std::min(std::max(n.scale * dk, n.min_radius), n.max_radius);
      const float r2 = squared_radius(r);
      if (m_ranked.size() == n.k && r2 <= m_ranked.back().d2) {
        // Every point nearer than the k-th is in the list already.
        m_found.clear();
        for (const auto& p : m_ranked)
          if (p.d2 < r2) m_found.push_back(p.index);
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

void list_block::sum(const float* xyz, std::size_t k) {
  const std::uint32_t i = m_points[k];
  const std::uint32_t* first = m_indices.data() + m_offsets[k];
  const std::uint32_t* last = first + m_counts[k];
  double* out = m_sums.data() + m_sum_stride * k;
  auto accumulate = [&](const float* values, std::size_t dims, double* to) {
    const float* vi = values + dims * i;
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

void list_block::fill(const neighbor_index& index, const float* xyz, const std::uint32_t* points, std::size_t count,
                      const detect_params& params) {
  m_points = points;
  m_count = count;
  m_counts.resize(count);
  m_offsets.resize(count + 1);
  m_radii.resize(count);
  m_indices.clear();
  m_offsets[0] = 0;
  for (std::size_t k = 0; k < count; ++k) {
    m_radii[k] = gather(index, xyz, points[k], params);
    m_offsets[k + 1] = m_indices.size();
    m_counts[k] = static_cast<std::uint32_t>(m_offsets[k + 1] - m_offsets[k]);
  }
  m_sums.resize(m_sum_stride * count);
  for (std::size_t k = 0; k < count; ++k) sum(xyz, k);
}

}  // namespace ced
