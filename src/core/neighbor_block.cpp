// SPDX-License-Identifier: MIT
// Stage 2 of detection: the neighbour pass over one spatial block.
#include "core/neighbor_block.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/block_partition.hpp"
#include "core/kernel/block_kernel.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/parallel.hpp"
#include "core/raw_vector.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace ced {

static_assert(neighbor_block::sweep_ranges == detail::kernel_ranges);

namespace {

/// Resizes `v` to at least n elements; never shrinks, so that a reused
/// buffer is not cleared again and again.
template <class V>
void grow(V& v, std::size_t n) {
  if (v.size() < n) v.resize(n);
}

/// Copies D channels (row-major, `row` floats a point) of the gathered
/// points into structure of arrays, and of the block's points into `own`
/// (`own_stride` floats a point), each less the reference `ref`.
template <std::size_t D>
void copy_channels(const float* values, const float* ref_values, const std::uint32_t* gathered, std::size_t g,
                   float* dst, std::size_t stride, const std::uint32_t* points, std::size_t count, float* own,
                   std::size_t own_stride, std::size_t row = D) {
  float ref[D];
  for (std::size_t d = 0; d < D; ++d) ref[d] = ref_values[d];
  for (std::size_t t = 0; t < g; ++t) {
    const float* v = values + row * gathered[t];
    for (std::size_t d = 0; d < D; ++d) dst[d * stride + t] = v[d] - ref[d];
  }
  for (std::size_t k = 0; k < count; ++k) {
    const float* v = values + row * points[k];
    for (std::size_t d = 0; d < D; ++d) own[own_stride * k + d] = v[d] - ref[d];
  }
}

/// The squared radius that cuts a point's runs of sub-cells: r² with a
/// margin far above float rounding (the runs are conservative: every point
/// the float test can accept lies in one of them).
double cut_radius2(double r) noexcept { return r * r * (1.0 + 1e-4); }

/// Sub-grids up to this many cells are sorted by counting, larger ones
/// (blocks far wider than the radius) by comparison.
constexpr std::uint64_t max_counted_cells = 1u << 14;
}  // namespace

void neighbor_block::set_channels(const std::vector<channel_source>& sources) {
  m_sources = sources;
  m_slot_offset.clear();
  m_channels = 0;
  for (const channel_source& s : sources) {
    if (s.positions) {
      m_slot_offset.push_back(0);
    } else {
      m_slot_offset.push_back(3 + m_channels);
      if (s.values) m_channels += s.dims;
    }
  }
  m_sum_stride = 3 + m_channels;
  m_row_sources.clear();
  for (std::size_t s = 0; s < sources.size(); ++s)
    if (!sources[s].positions && sources[s].values && sources[s].dims != 0)
      m_row_sources.push_back({sources[s].values, sources[s].dims, m_slot_offset[s]});
  if (m_moments && m_channels != 0) throw std::logic_error("neighbor_block: moments are summed only with no channels");
  if (m_moments) m_sum_stride = 9;
}

void neighbor_block::set_moments(bool on) {
  m_moments = on;
  set_channels(std::vector<channel_source>(m_sources));
}

std::size_t neighbor_block::cell_start_sorted(std::uint64_t key) const noexcept {
  const auto end = m_keyed.begin() + std::ptrdiff_t(m_raw.size());
  const auto it = std::lower_bound(m_keyed.begin(), end, std::make_pair(key, std::uint32_t(0)));
  return static_cast<std::size_t>(it - m_keyed.begin());
}

void neighbor_block::sort_into_cells(const float lo[3], const float hi[3], double r) {
  // Sub-cells a little wider than r in y and z: a neighbour (even one the
  // float test accepts at a true distance a hair over r) is at most one row
  // away. Narrower in x, where each row is cut to the ball's extent.
  const double wide = r * (1.0 + 1.0 / 1024);
  const double side[3] = {wide / detail::x_cells_per_radius, wide, wide};
  for (int a = 0; a < 3; ++a) {
    m_side[a] = side[a];
    m_inv_side[a] = 1.0 / side[a];
  }
  long double total = 1;
  bool too_fine = false;
  for (int a = 0; a < 3; ++a) {
    m_lo[a] = lo[a];
    const double extent = std::floor((double(hi[a]) - m_lo[a]) * m_inv_side[a]);
    if (extent < 1e6)
      m_dims[a] = static_cast<std::uint64_t>(std::max(extent, 0.0)) + 1;
    else
      too_fine = true;
  }
  m_single_cell = too_fine;  // absurd radius for the block: one cell, all tested
  if (too_fine) m_dims[0] = m_dims[1] = m_dims[2] = 1;
  for (int a = 0; a < 3; ++a) total *= static_cast<long double>(m_dims[a]);
  // The gathered points, their positions as structure of arrays, with 8
  // entries of padding (the kernel and the compaction read whole groups).
  const std::size_t g = m_raw.size();
  const neighbor_index::located_point* raw = m_raw.data();
  grow(m_gathered, g + 8);
  std::fill_n(m_gathered.begin() + std::ptrdiff_t(g), 8, 0u);
  for (auto* v : {&m_gx, &m_gy, &m_gz}) {
    grow(*v, g + 8);
    std::fill_n(v->begin() + std::ptrdiff_t(g), 8, 0.0f);
  }
  auto key_of = [&](std::size_t t) {
    std::uint64_t c[3];
    cell_of(raw[t].xyz, c);
    return (c[2] * m_dims[1] + c[1]) * m_dims[0] + c[0];
  };
  auto place = [&](std::size_t to, std::size_t from) {
    m_gathered[to] = raw[from].index;
    m_gx[to] = raw[from].xyz[0];
    m_gy[to] = raw[from].xyz[1];
    m_gz[to] = raw[from].xyz[2];
  };
  if (total <= static_cast<long double>(max_counted_cells)) {
    // Counting sort: stable, so the order is (cell, query order).
    const std::size_t cells = static_cast<std::size_t>(m_dims[0] * m_dims[1] * m_dims[2]);
    grow(m_cell_start, cells + 1);
    std::fill_n(m_cell_start.begin(), cells + 1, 0u);
    grow(m_cell_key, g);
    if (const auto keys = detail::active_kernels().cell_keys) {
      const std::int64_t dims[3] = {std::int64_t(m_dims[0]), std::int64_t(m_dims[1]), std::int64_t(m_dims[2])};
      keys(reinterpret_cast<const float*>(raw), g, m_lo, m_inv_side, dims, m_cell_key.data());
    } else {
      for (std::size_t t = 0; t < g; ++t) m_cell_key[t] = static_cast<std::uint32_t>(key_of(t));
    }
    for (std::size_t t = 0; t < g; ++t) ++m_cell_start[m_cell_key[t] + 1];
    for (std::size_t c = 0; c < cells; ++c) m_cell_start[c + 1] += m_cell_start[c];
    std::vector<std::uint32_t>& next = m_ranges;  // scratch, overwritten later
    grow(next, cells);
    std::copy_n(m_cell_start.begin(), cells, next.begin());
    for (std::size_t t = 0; t < g; ++t) place(next[m_cell_key[t]]++, t);
    m_counted = true;
  } else {
    // Same order by comparison: (cell, then position in the query's order).
    grow(m_keyed, g);
    for (std::size_t t = 0; t < g; ++t) m_keyed[t] = {key_of(t), static_cast<std::uint32_t>(t)};
    std::sort(m_keyed.begin(), m_keyed.begin() + std::ptrdiff_t(g));
    for (std::size_t t = 0; t < g; ++t) place(t, m_keyed[t].second);
    m_counted = false;  // cell_start() then searches m_keyed
  }
}

/// Lays out the gathered points' channels as structure of arrays and the
/// block points' own values; returns the distance between channels.
std::size_t neighbor_block::copy_channels_in(const std::uint32_t* points, std::size_t count) {
  const std::size_t g = m_raw.size();
  // Many channels: the kernel reads the neighbours' rows where they lie
  // (set_channels listed them), nothing to copy.
  if (m_channels > detail::max_register_channels) return 0;
  // Gathered channels as structure of arrays, 8 floats of zero padding at
  // the end (the kernel reads whole groups of 8).
  const std::size_t stride =
      m_channels >= std::size_t(detail::min_fixed_stride_channels) && g + 8 <= detail::fixed_channel_stride
          ? detail::fixed_channel_stride
          : g + 8;
  grow(m_channel_values, m_channels * stride);
  grow(m_own, m_channels * count);
  // Each channel less a reference, the block's first point's value: the
  // kernel sums these (small, whatever the channel's offset) and takes n
  // times the point's own off the total.
  std::size_t base = 0;
  for (const channel_source& s : m_sources) {
    if (s.positions || !s.values) continue;
    const std::size_t dims = s.dims;
    float* const dst = m_channel_values.data() + base * stride;
    float* const own = m_own.data() + base;
    const float* const first = s.values + dims * points[0];
    switch (dims) {
      case 1:
        copy_channels<1>(s.values, first, m_gathered.data(), g, dst, stride, points, count, own, m_channels);
        break;
      case 2:
        copy_channels<2>(s.values, first, m_gathered.data(), g, dst, stride, points, count, own, m_channels);
        break;
      case 3:
        copy_channels<3>(s.values, first, m_gathered.data(), g, dst, stride, points, count, own, m_channels);
        break;
      default:
        for (std::size_t d = 0; d < dims; ++d)
          copy_channels<1>(s.values + d, first + d, m_gathered.data(), g, dst + d * stride, stride, points, count,
                           own + d, m_channels, dims);
    }
    for (std::size_t d = 0; d < dims; ++d) std::fill_n(dst + d * stride + g, 8, 0.0f);
    base += dims;
  }

  return stride;
}

/// Per point of the block: its nine ranges of gathered points and where its
/// hit bits start.
void neighbor_block::set_up_rows(std::size_t count, double r) {
  grow(m_ranges, 2 * detail::kernel_ranges * count);
  grow(m_bit_offsets, count + 1);
  m_bit_offsets[0] = 0;
  if (m_single_cell) {
    const std::size_t g = m_raw.size();
    for (std::size_t k = 0; k < count; ++k) {
      std::uint32_t* rg = m_ranges.data() + 2 * detail::kernel_ranges * k;
      std::fill(rg, rg + 2 * detail::kernel_ranges, 0u);
      rg[1] = static_cast<std::uint32_t>(g);
      m_bit_offsets[k + 1] = static_cast<std::uint32_t>(m_bit_offsets[k] + (g + 7) / 8);
    }
  } else if (m_counted && detail::active_kernels().rows) {
    const detail::row_grid grid{m_centre.data(),
                                count,
                                {m_lo[0], m_lo[1], m_lo[2]},
                                {m_inv_side[0], m_inv_side[1], m_inv_side[2]},
                                m_side[1],
                                m_side[2],
                                {std::int64_t(m_dims[0]), std::int64_t(m_dims[1]), std::int64_t(m_dims[2])},
                                cut_radius2(r),
                                m_cell_start.data()};
    detail::active_kernels().rows(grid, m_ranges.data(), m_bit_offsets.data());
  } else if (m_counted) {
    const std::uint32_t* const start = m_cell_start.data();
    rows_of_points(count, r, [start](std::int64_t key) { return std::size_t(start[key]); });
  } else {
    rows_of_points(count, r, [this](std::int64_t key) { return cell_start_sorted(std::uint64_t(key)); });
  }
}

template <class StartOf>
void neighbor_block::rows_of_points(std::size_t count, double r, StartOf start_of) {
  // Per point: the runs of sub-cells it tests, one per row (y, z) within one
  // cell, cut to the x-cells that the ball of radius r (with a margin far
  // above float rounding) reaches. Conservative: every point the float test
  // can accept lies in one of them.
  const double rc2 = cut_radius2(r), inv_x = m_inv_side[0];
  const std::int64_t dims_x = std::int64_t(m_dims[0]), dims_y = std::int64_t(m_dims[1]),
                     dims_z = std::int64_t(m_dims[2]), last_x = dims_x - 1;
  const double lo_x = m_lo[0], lo_y = m_lo[1], lo_z = m_lo[2], side_y = m_side[1], side_z = m_side[2];
  constexpr std::int64_t x_reach = detail::x_cells_per_radius + 1;
  constexpr double far = std::numeric_limits<double>::infinity();
  std::uint32_t* const ranges = m_ranges.data();
  std::uint32_t* const bit_offsets = m_bit_offsets.data();
  const float* const centre = m_centre.data();
  for (std::size_t k = 0; k < count; ++k) {
    const float* p = centre + 3 * k;
    std::uint32_t* rg = ranges + 2 * detail::kernel_ranges * k;
    std::uint64_t c[3];
    cell_of(p, c);
    // Squared distances from p to the rows below, at and above its own in
    // y and z (0 for its own); a row out of the grid is infinitely far.
    const std::int64_t cx = std::int64_t(c[0]), cy = std::int64_t(c[1]), cz = std::int64_t(c[2]);
    const double py = double(p[1]) - lo_y - double(cy) * side_y;
    const double pz = double(p[2]) - lo_z - double(cz) * side_z;
    const double gy2[3] = {cy > 0 ? py * py : far, 0.0, cy + 1 < dims_y ? (side_y - py) * (side_y - py) : far};
    const double gz2[3] = {cz > 0 ? pz * pz : far, 0.0, cz + 1 < dims_z ? (side_z - pz) * (side_z - pz) : far};
    // The half-widths of the ball's slices in the nine rows, two square
    // roots an instruction (each as exact as one alone).
    alignas(16) double left[10], w[10];
    for (int dz = 0; dz < 3; ++dz)
      for (int dy = 0; dy < 3; ++dy) left[3 * dz + dy] = rc2 - gy2[dy] - gz2[dz];
    left[9] = 0;
#if defined(__SSE2__)
    for (int q = 0; q < 10; q += 2)
      _mm_store_pd(w + q, _mm_sqrt_pd(_mm_max_pd(_mm_load_pd(left + q), _mm_setzero_pd())));
#else
    for (int q = 0; q < 10; ++q) w[q] = std::sqrt(std::max(left[q], 0.0));
#endif
    const double x = double(p[0]) - lo_x;
    const std::int64_t reach_lo = cx - x_reach, reach_hi = std::min(last_x, cx + x_reach);
    std::size_t groups = 0;
    for (int dz = -1; dz <= 1; ++dz) {
      const std::int64_t plane = (cz + dz) * dims_y;
      for (int dy = -1; dy <= 1; ++dy, rg += 2) {
        const int q = 3 * (dz + 1) + (dy + 1);
        std::size_t b = 0, e = 0;
        if (left[q] >= 0) {
          // Truncation is floor for the clamped, non-negative values.
          const std::int64_t x0 = std::max(reach_lo, static_cast<std::int64_t>(std::max(0.0, (x - w[q]) * inv_x)));
          const std::int64_t x1 = std::min(reach_hi, static_cast<std::int64_t>((x + w[q]) * inv_x));
          if (x1 >= x0) {
            const std::int64_t row = (plane + (cy + dy)) * dims_x;
            b = start_of(row + x0);
            e = start_of(row + x1 + 1);
          }
        }
        rg[0] = static_cast<std::uint32_t>(b);
        rg[1] = static_cast<std::uint32_t>(e);
        groups += (e - b + 7) / 8;
      }
    }
    bit_offsets[k + 1] = static_cast<std::uint32_t>(bit_offsets[k] + groups);
  }
}

void neighbor_block::fill(const block_partition& grid, const float* xyz, const std::uint32_t* points, std::size_t count,
                          double r) {
  m_points = points;
  m_count = count;
  m_lists_built = false;
  if (count == 0) return;
  float lo[3], hi[3];
  // The block's points' positions (the sweep's centres) and their bounds.
  // A block of the grid is a run of its order: read in sequence from the
  // grid's own copy.
  grow(m_centre, 3 * count);
  const std::vector<std::uint32_t>& order = grid.order();
  if (std::less_equal<const std::uint32_t*>()(order.data(), points) &&
      std::less_equal<const std::uint32_t*>()(points + count, order.data() + order.size())) {
    const auto first = std::size_t(points - order.data());
    grid.padded_bounds(first, count, r, lo, hi);
    grid.copy_positions(first, count, m_centre.data());
  } else {
    detail::padded_bounds(xyz, points, count, r, lo, hi);
    for (std::size_t k = 0; k < count; ++k) std::copy_n(xyz + 3 * std::size_t(points[k]), 3, m_centre.data() + 3 * k);
  }
  grid.box_search(lo, hi, m_raw);
  run(points, count, r, lo, hi);
}

void neighbor_block::run(const std::uint32_t* points, std::size_t count, double r, const float lo[3],
                         const float hi[3]) {
  sort_into_cells(lo, hi, r);

  const std::size_t stride = copy_channels_in(points, count);
  set_up_rows(count, r);
  // The kernel skips the bits only for positions alone (no channels), and
  // the balls' distances replace them.
  const bool bits = (m_keep_lists || m_channels != 0) && !m_keep_distances;
  if (bits) grow(m_bits, m_bit_offsets[count]);
  grow(m_counts, count);
  grow(m_sums, m_sum_stride * count);

  std::uint32_t* row_scratch = nullptr;
  if (m_channels > detail::max_register_channels && bits) {
    std::uint32_t most = 0;
    for (std::size_t k = 0; k < count; ++k) most = std::max(most, m_bit_offsets[k + 1] - m_bit_offsets[k]);
    grow(m_places, 8 * std::size_t(most) + 8);
    row_scratch = m_places.data();
  }
  const detail::block_kernel_input in{m_gx.data(),
                                      m_gy.data(),
                                      m_gz.data(),
                                      m_channel_values.data(),
                                      stride,
                                      m_channels,
                                      count,
                                      m_centre.data(),
                                      m_own.data(),
                                      m_ranges.data(),
                                      squared_radius(r),
                                      m_moments,
                                      row_scratch,
                                      m_row_sources.data(),
                                      m_row_sources.size(),
                                      m_gathered.data(),
                                      points};
  m_r2 = squared_radius(r);
  if (m_keep_distances) return;  // ball() sweeps a point at a time
  const detail::block_kernel_output out{m_counts.data(), m_sums.data(), bits ? m_bits.data() : nullptr};
  detail::active_kernels().pass(in, out);
}

void neighbor_block::neighbors(std::size_t k, std::uint32_t* out) const noexcept {
  detail::active_kernels().compact(m_gathered.data(), m_ranges.data() + 2 * detail::kernel_ranges * k,
                                   m_bits.data() + m_bit_offsets[k], m_counts[k], out);
}

neighbor_block::ball_view neighbor_block::ball(std::size_t k) {
  // 8 entries a group tested, and 8 more: ball_view is readable 8 past its count.
  const std::size_t room = 8 * std::size_t(m_bit_offsets[k + 1] - m_bit_offsets[k]) + 8;
  grow(m_ball_bits, room);
  grow(m_ball_ids, room);
  const detail::block_kernel_input in{m_gx.data(), m_gy.data(),     m_gz.data(), nullptr,         0,   0,
                                      m_count,     m_centre.data(), nullptr,     m_ranges.data(), m_r2};
  const std::size_t n =
      detail::active_kernels().balls(in, m_gathered.data(), m_points, k, m_ball_bits.data(), m_ball_ids.data());
  return {m_ball_bits.data(), m_ball_ids.data(), n};
}

neighborhood neighbor_block::operator[](std::size_t k) const {
  if (!m_keep_lists) throw std::logic_error("neighbor_block: neighbour lists were not kept (set_keep_lists)");
  if (!m_lists_built) {
    grow(m_offsets, m_count + 1);
    m_offsets[0] = 0;
    for (std::size_t q = 0; q < m_count; ++q) m_offsets[q + 1] = m_offsets[q] + m_counts[q];
    grow(m_indices, m_offsets[m_count]);
    for (std::size_t q = 0; q < m_count; ++q) neighbors(q, m_indices.data() + m_offsets[q]);
    m_lists_built = true;
  }
  return {m_points[k], m_indices.data() + m_offsets[k], m_offsets[k + 1] - m_offsets[k]};
}

}  // namespace ced
