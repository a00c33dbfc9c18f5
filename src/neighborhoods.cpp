// SPDX-License-Identifier: MIT
#include "ced/neighborhoods.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "ced/detail/parallel.hpp"

#ifdef CED_HAS_TBB
#include <oneapi/tbb/parallel_sort.h>
#include <oneapi/tbb/task_arena.h>
#endif

namespace ced {

block_partition::block_partition(const float* xyz, std::size_t n, double cell_size, unsigned threads) {
  if (!(cell_size > 0) || !std::isfinite(cell_size)) throw std::invalid_argument("block_partition: bad cell size");
  if (n == 0) {
    m_starts = {0};
    return;
  }
  float lo[3] = {xyz[0], xyz[1], xyz[2]}, hi[3] = {xyz[0], xyz[1], xyz[2]};
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], xyz[3 * i + std::size_t(k)]);
      hi[k] = std::max(hi[k], xyz[3 * i + std::size_t(k)]);
    }
  // Cells per axis; grow the cell if the grid would not fit a 64-bit key.
  double cell = cell_size;
  std::uint64_t dims[3];
  for (;;) {
    long double total = 1;
    for (int k = 0; k < 3; ++k) {
      dims[k] = static_cast<std::uint64_t>(std::floor((double(hi[k]) - double(lo[k])) / cell)) + 1;
      total *= static_cast<long double>(dims[k]);
    }
    if (total < 1e18L) break;
    cell *= 2;
  }
  const double inv = 1.0 / cell;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
  detail::parallel_for(n, threads, 1 << 14, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      std::uint64_t c[3];
      for (int k = 0; k < 3; ++k) {
        const double v = std::floor((double(xyz[3 * i + std::size_t(k)]) - double(lo[k])) * inv);
        c[k] = std::min<std::uint64_t>(static_cast<std::uint64_t>(std::max(v, 0.0)), dims[k] - 1);
      }
      keyed[i] = {(c[2] * dims[1] + c[1]) * dims[0] + c[0], static_cast<std::uint32_t>(i)};
    }
  });
  // Keys are unique pairs, so the sorted order is the same whatever the sort.
#ifdef CED_HAS_TBB
  if (detail::resolve_threads(threads) > 1) {
    oneapi::tbb::task_arena arena(
        static_cast<int>(std::min(detail::resolve_threads(threads), detail::resolve_threads(0))));
    arena.execute([&] { oneapi::tbb::parallel_sort(keyed.begin(), keyed.end()); });
  } else {
    std::sort(keyed.begin(), keyed.end());
  }
#else
  std::sort(keyed.begin(), keyed.end());
#endif
  m_order.resize(n);
  m_starts.clear();
  // Dense cells are split into blocks of at most max_block points, which
  // bounds a block's CSR memory even when many points coincide.
  constexpr std::size_t max_block = 256;
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0 || keyed[i].first != keyed[i - 1].first || i - m_starts.back() >= max_block) m_starts.push_back(i);
    m_order[i] = keyed[i].second;
  }
  m_starts.push_back(n);
}

namespace detail {
void padded_bounds(const float* xyz, const std::uint32_t* points, std::size_t count, double r, float lo[3],
                   float hi[3]) noexcept {
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = xyz[3 * std::size_t(points[0]) + std::size_t(k)];
  for (std::size_t q = 1; q < count; ++q)
    for (int k = 0; k < 3; ++k) {
      const float v = xyz[3 * std::size_t(points[q]) + std::size_t(k)];
      lo[k] = std::min(lo[k], v);
      hi[k] = std::max(hi[k], v);
    }
  const float pad = static_cast<float>(r) * 1.001f;
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::nextafter(lo[k] - pad, -std::numeric_limits<float>::infinity());
    hi[k] = std::nextafter(hi[k] + pad, std::numeric_limits<float>::infinity());
  }
}
}  // namespace detail

void neighbor_block::fill(const neighbor_index& index, const float* xyz, const std::uint32_t* points, std::size_t count,
                          double r) {
  m_points = points;
  m_count = count;
  m_offsets.assign(count + 1, 0);
  if (count == 0) return;
  float lo[3], hi[3];
  detail::padded_bounds(xyz, points, count, r, lo, hi);
  index.box_search(lo, hi, m_gathered);
  const std::size_t g = m_gathered.size();
  // Gathered coordinates as structure of arrays, padded to a multiple of 4
  // with points at infinity (their squared distance is +inf, never < r²).
  const std::size_t g4 = (g + 3) & ~std::size_t(3);
  m_gathered.resize(g4, 0);  // padding lanes never hit
  constexpr float far = std::numeric_limits<float>::infinity();
  m_gx.assign(g4, far);
  m_gy.assign(g4, far);
  m_gz.assign(g4, far);
  for (std::size_t t = 0; t < g; ++t) {
    const float* p = xyz + 3 * std::size_t(m_gathered[t]);
    m_gx[t] = p[0];
    m_gy[t] = p[1];
    m_gz[t] = p[2];
  }
  const float r2 = squared_radius(r);
  // Hits are written in gathered order, so a point's neighbour order depends
  // only on the block, whichever code path runs. The SSE2 path computes
  // ((dx·dx + dy·dy) + dz·dz) exactly as the scalar expression does.
  std::size_t pos = 0;
  for (std::size_t q = 0; q < count; ++q) {
    if (m_indices.size() < pos + g4) m_indices.resize(std::max(2 * m_indices.size(), pos + g4));
    const float* c = xyz + 3 * std::size_t(points[q]);
    std::uint32_t* dst = m_indices.data() + pos;
    std::size_t hits = 0;
#if defined(__SSE2__)
    const __m128 cx = _mm_set1_ps(c[0]), cy = _mm_set1_ps(c[1]), cz = _mm_set1_ps(c[2]), rr = _mm_set1_ps(r2);
    for (std::size_t t = 0; t < g4; t += 4) {
      const __m128 dx = _mm_sub_ps(_mm_loadu_ps(&m_gx[t]), cx);
      const __m128 dy = _mm_sub_ps(_mm_loadu_ps(&m_gy[t]), cy);
      const __m128 dz = _mm_sub_ps(_mm_loadu_ps(&m_gz[t]), cz);
      const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
      const unsigned mask = static_cast<unsigned>(_mm_movemask_ps(_mm_cmplt_ps(d2, rr)));
      const std::uint32_t* gi = m_gathered.data() + t;  // branch-free compaction of the 4 lanes
      dst[hits] = gi[0];
      hits += mask & 1u;
      dst[hits] = gi[1];
      hits += (mask >> 1) & 1u;
      dst[hits] = gi[2];
      hits += (mask >> 2) & 1u;
      dst[hits] = gi[3];
      hits += mask >> 3;
    }
#else
    const float cx = c[0], cy = c[1], cz = c[2];
    for (std::size_t t = 0; t < g; ++t) {
      const float dx = m_gx[t] - cx, dy = m_gy[t] - cy, dz = m_gz[t] - cz;
      dst[hits] = m_gathered[t];
      hits += (dx * dx + dy * dy + dz * dz < r2);
    }
#endif
    pos += hits;
    m_offsets[q + 1] = static_cast<std::uint32_t>(pos);
  }
}

}  // namespace ced
