// SPDX-License-Identifier: MIT
// Stage 1 of detection: the points grouped into spatial blocks.
#include "core/block_partition.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <utility>

#include "core/kernel/dispatch.hpp"
#include "core/parallel.hpp"
#include "core/raw_vector.hpp"

namespace ced {

namespace {
using chunk_runner = std::function<void(const std::function<void(std::size_t, std::size_t, std::size_t)>&)>;

/// Sorts the points by grid cell (key K) and index, and cuts the order into
/// blocks: one cell each, split after max_block points.
template <class K>
void sort_into_blocks(const float* xyz, std::size_t n, const double base[3], const std::uint64_t dims[3], double inv,
                      std::size_t chunks, const chunk_runner& for_chunks, std::vector<std::uint32_t>& order,
                      std::vector<std::size_t>& starts, std::vector<std::uint64_t>& cell_keys,
                      std::vector<std::size_t>& cell_starts) {
  // Written in full before they are read: not zeroed first.
  struct keyed_point {
    K first;
    std::uint32_t second;
  };
  detail::raw_vector<keyed_point> keyed(n), scratch(n);
  std::vector<K> max_keys(chunks, 0);
  for_chunks([&](std::size_t c, std::size_t b, std::size_t e) {
    K max_key = 0;
    for (std::size_t i = b; i < e; ++i) {
      std::uint64_t cc[3];
      for (int k = 0; k < 3; ++k) {  // cells at whole multiples of the cell size (see cell_of)
        const double v = std::floor(double(xyz[3 * i + std::size_t(k)]) * inv) - base[k];
        cc[k] = static_cast<std::uint64_t>(std::min(std::max(v, 0.0), double(dims[k] - 1)));
      }
      const auto key = static_cast<K>((cc[2] * dims[1] + cc[1]) * dims[0] + cc[0]);
      keyed[i] = {key, static_cast<std::uint32_t>(i)};
      max_key = std::max(max_key, key);
    }
    max_keys[c] = max_key;
  });
  const K max_key = *std::max_element(max_keys.begin(), max_keys.end());
  // Least-significant-digit radix sort on the key, 11 bits a pass, as many
  // passes as the largest key needs. Stable, so the order is (key, index):
  // the same on any number of threads. Each chunk counts its digits, and
  // scatters from its own offsets (digit by digit, chunk after chunk).
  constexpr unsigned digit_bits = 11, digits = 1u << digit_bits;
  std::vector<std::size_t> count(chunks * digits);
  for (unsigned shift = 0; shift < 8 * sizeof(K) && (max_key >> shift) != 0; shift += digit_bits) {
    for_chunks([&](std::size_t c, std::size_t b, std::size_t e) {
      std::size_t* cnt = count.data() + c * digits;
      std::fill_n(cnt, digits, 0);
      for (std::size_t i = b; i < e; ++i) ++cnt[(keyed[i].first >> shift) & (digits - 1)];
    });
    std::size_t at = 0;
    for (unsigned d = 0; d < digits; ++d)
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t here = count[c * digits + d];
        count[c * digits + d] = at;
        at += here;
      }
    for_chunks([&](std::size_t c, std::size_t b, std::size_t e) {
      std::size_t* next = count.data() + c * digits;
      for (std::size_t i = b; i < e; ++i) scratch[next[(keyed[i].first >> shift) & (digits - 1)]++] = keyed[i];
    });
    keyed.swap(scratch);
  }
  scratch = {};
  order.resize(n);
  for_chunks([&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) order[i] = keyed[i].second;
  });
  starts.clear();
  cell_keys.clear();
  cell_starts.clear();
  // Dense cells are split into blocks of at most max_block points, which
  // bounds a block's memory even when many points coincide.
  constexpr std::size_t max_block = 1024;
  for (std::size_t i = 0; i < n; ++i) {
    const bool new_cell = i == 0 || keyed[i].first != keyed[i - 1].first;
    if (new_cell || i - starts.back() >= max_block) starts.push_back(i);
    if (new_cell) {
      cell_keys.push_back(keyed[i].first);
      cell_starts.push_back(i);
    }
  }
  starts.push_back(n);
  cell_starts.push_back(n);
}

/// The box of the n points at xyz, chunk by chunk (for_chunks(body) calls
/// body(chunk, begin, end) for each chunk), merged in chunk order.
template <class ForChunks>
void bounds_of(const float* xyz, std::size_t chunks, ForChunks& for_chunks, float lo[3], float hi[3]) {
  std::vector<std::array<float, 6>> bounds(chunks);
  for_chunks([&](std::size_t c, std::size_t b, std::size_t e) {
    float l[3] = {xyz[3 * b], xyz[3 * b + 1], xyz[3 * b + 2]}, h[3] = {l[0], l[1], l[2]};
    for (std::size_t i = b; i < e; ++i)
      for (int k = 0; k < 3; ++k) {
        l[k] = std::min(l[k], xyz[3 * i + std::size_t(k)]);
        h[k] = std::max(h[k], xyz[3 * i + std::size_t(k)]);
      }
    bounds[c] = {l[0], l[1], l[2], h[0], h[1], h[2]};
  });
  for (int k = 0; k < 3; ++k) {
    lo[k] = bounds[0][std::size_t(k)];
    hi[k] = bounds[0][std::size_t(k) + 3];
    for (const auto& bd : bounds) {
      lo[k] = std::min(lo[k], bd[std::size_t(k)]);
      hi[k] = std::max(hi[k], bd[std::size_t(k) + 3]);
    }
  }
}

/// Cells per axis, at whole multiples of the cell size (so that a part of
/// the cloud gets the same cells as the whole); the cell grows when the grid
/// would not fit a 64-bit key. (A span is checked before it becomes an
/// integer: a cell far smaller than the cloud, from a tiny radius, gives
/// spans past 2^64.) Sets base (first cell), dims and inv (1 / cell).
void grid_of(const float lo[3], const float hi[3], double cell, double base[3], std::uint64_t dims[3], double& inv) {
  for (;;) {
    inv = 1.0 / cell;
    long double total = 1;
    for (int k = 0; k < 3 && total < 1e18L; ++k) {
      base[k] = std::floor(double(lo[k]) * inv);
      const double span = std::floor(double(hi[k]) * inv) - base[k];
      if (!(span < 1e18)) {
        total = 1e18L;
        break;
      }
      dims[k] = static_cast<std::uint64_t>(span) + 1;
      total *= static_cast<long double>(dims[k]);
    }
    if (total < 1e18L) break;
    cell *= 2;
  }
}
}  // namespace

block_partition::block_partition(const float* xyz, std::size_t n, double cell_size, unsigned threads) {
  if (!(cell_size > 0) || !std::isfinite(cell_size)) throw std::invalid_argument("block_partition: bad cell size");
  if (n == 0) {
    m_starts = {0};
    return;
  }
  // Fixed chunks of the points for the passes below; any chunking gives the
  // same result (min/max, and a stable sort), the threads only share work.
  const std::size_t chunks =
      std::max<std::size_t>(1, std::min<std::size_t>(detail::resolve_threads(threads), n / (1 << 15)));
  auto chunk_begin = [&](std::size_t c) { return n * c / chunks; };
  auto for_chunks = [&](const std::function<void(std::size_t, std::size_t, std::size_t)>& body) {
    detail::parallel_for(chunks, threads, 1, [&](std::size_t c0, std::size_t c1) {
      for (std::size_t c = c0; c < c1; ++c) body(c, chunk_begin(c), chunk_begin(c + 1));
    });
  };
  float lo[3], hi[3];
  bounds_of(xyz, chunks, for_chunks, lo, hi);
  grid_of(lo, hi, cell_size, m_base, m_dims, m_inv);
  // Keys of 32 bits when the grid allows (half the memory to sort).
  if (static_cast<long double>(m_dims[0]) * static_cast<long double>(m_dims[1]) * static_cast<long double>(m_dims[2]) <
      4294967296.0L)
    sort_into_blocks<std::uint32_t>(xyz, n, m_base, m_dims, m_inv, chunks, for_chunks, m_order, m_starts, m_cell_keys,
                                    m_cell_starts);
  else
    sort_into_blocks<std::uint64_t>(xyz, n, m_base, m_dims, m_inv, chunks, for_chunks, m_order, m_starts, m_cell_keys,
                                    m_cell_starts);
  // The positions in that order: a box search then reads whole runs of
  // memory, not one scattered point after another.
  // (Structure of arrays, each readable 8 past its end.)
  for (auto* v : {&m_x, &m_y, &m_z}) {
    v->resize(n + 8);
    std::fill_n(v->begin() + std::ptrdiff_t(n), 8, 0.0f);
  }
  for_chunks([&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const float* p = xyz + 3 * std::size_t(m_order[i]);
      m_x[i] = p[0];
      m_y[i] = p[1];
      m_z[i] = p[2];
    }
  });
}

bool block_partition::cell_range(const float lo[3], const float hi[3], std::int64_t c0[3], std::int64_t c1[3]) const {
  if (m_cell_keys.empty()) return false;
  for (int k = 0; k < 3; ++k) {
    const double last = double(m_dims[k] - 1);
    const double a = std::max(0.0, std::floor(double(lo[k]) * m_inv) - m_base[k]);
    const double b = std::min(last, std::floor(double(hi[k]) * m_inv) - m_base[k]);
    if (!(a <= b)) return false;
    c0[k] = static_cast<std::int64_t>(a);
    c1[k] = static_cast<std::int64_t>(b);
  }
  return true;
}

template <class F>
void block_partition::for_each_in_box(const float lo[3], const float hi[3], F&& f) const {
  std::int64_t c0[3], c1[3];
  if (!cell_range(lo, hi, c0, c1)) return;
  // Cells in key order, points of a cell in index order: the same order for
  // any part of the cloud that holds the cells' points.
  const auto dx = static_cast<std::int64_t>(m_dims[0]), dy = static_cast<std::int64_t>(m_dims[1]);
  const auto cell_points = [&](std::size_t c) {
    for (std::size_t i = m_cell_starts[c]; i < m_cell_starts[c + 1]; ++i) {
      const std::uint32_t j = m_order[i];
      const float p[3] = {m_x[i], m_y[i], m_z[i]};
      if (p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2]) f(j, p);
    }
  };
  // A box of far more rows than occupied cells between its first and last
  // key (a box much larger than the cells: knn or adaptive neighbourhoods
  // with a radius far below the spacing) walks those cells instead, in the
  // same key order: the same points in the same order.
  const auto key = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::uint64_t>((z * dy + y) * dx + x);
  };
  const auto rows = static_cast<std::uint64_t>((c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1));
  const auto from = std::lower_bound(m_cell_keys.begin(), m_cell_keys.end(), key(c0[0], c0[1], c0[2]));
  const auto to = std::upper_bound(from, m_cell_keys.end(), key(c1[0], c1[1], c1[2]));
  if (static_cast<std::uint64_t>(to - from) < rows) {
    for (auto it = from; it != to; ++it) {
      const auto x = static_cast<std::int64_t>(*it % std::uint64_t(dx));
      const auto yz = static_cast<std::int64_t>(*it / std::uint64_t(dx));
      const std::int64_t y = yz % dy, z = yz / dy;
      if (x >= c0[0] && x <= c1[0] && y >= c0[1] && y <= c1[1] && z >= c0[2] && z <= c1[2])
        cell_points(static_cast<std::size_t>(it - m_cell_keys.begin()));
    }
    return;
  }
  for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
    for (std::int64_t y = c0[1]; y <= c1[1]; ++y) {
      const std::uint64_t first = key(c0[0], y, z), last = key(c1[0], y, z);
      auto it = std::lower_bound(from, to, first);
      for (; it != to && *it <= last; ++it) cell_points(static_cast<std::size_t>(it - m_cell_keys.begin()));
    }
}

template <class T, class Select, class One>
void block_partition::search_rows(const float lo[3], const float hi[3], detail::raw_vector<T>& out, Select select,
                                  One one) const {
  // The same points in the same order as for_each_in_box, without a branch
  // per point: each row of cells is one run of the order, selected eight
  // points at a time (a test far harder to predict than to compute, on the
  // points near the box's faces).
  std::size_t runs[2 * max_box_rows];
  const std::size_t rows = row_runs(lo, hi, runs);
  if (rows == max_box_rows + 1) {  // a box of many rows: one point at a time
    out.clear();
    for_each_in_box(lo, hi, [&](std::uint32_t j, const float* p) { out.push_back(one(j, p)); });
    return;
  }
  std::size_t room = 0;
  for (std::size_t q = 0; q < rows; ++q) room += runs[2 * q + 1] - runs[2 * q];
  out.resize(room + 8);  // (a selection writes up to 8 past its count)
  std::size_t n = 0;
  for (std::size_t q = 0; q < rows; ++q) n += select(runs[2 * q], runs[2 * q + 1], out.data() + n);
  out.resize(n);
}

void block_partition::box_search(const float lo[3], const float hi[3],
                                 detail::raw_vector<neighbor_index::located_point>& out) const {
  static_assert(sizeof(neighbor_index::located_point) == 4 * sizeof(float));
  search_rows(
      lo, hi, out,
      [&](std::size_t b, std::size_t e, neighbor_index::located_point* to) {
        return detail::select_in_box(m_x.data(), m_y.data(), m_z.data(), m_order.data(), b, e, lo, hi,
                                     reinterpret_cast<float*>(to));
      },
      [](std::uint32_t j, const float* p) {
        return neighbor_index::located_point{{p[0], p[1], p[2]}, j};
      });
}

void block_partition::box_search(const float lo[3], const float hi[3], detail::raw_vector<std::uint32_t>& out) const {
  search_rows(
      lo, hi, out,
      [&](std::size_t b, std::size_t e, std::uint32_t* to) {
        return detail::select_ids_in_box(m_x.data(), m_y.data(), m_z.data(), m_order.data(), b, e, lo, hi, to);
      },
      [](std::uint32_t j, const float*) { return j; });
}

std::size_t block_partition::row_runs(const float lo[3], const float hi[3], std::size_t* runs) const {
  std::int64_t c0[3], c1[3];
  if (!cell_range(lo, hi, c0, c1)) return 0;
  if ((c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1) > std::int64_t(max_box_rows)) return max_box_rows + 1;
  const auto dx = static_cast<std::int64_t>(m_dims[0]), dy = static_cast<std::int64_t>(m_dims[1]);
  std::size_t rows = 0;
  for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
    for (std::int64_t y = c0[1]; y <= c1[1]; ++y) {
      const auto row = static_cast<std::uint64_t>((z * dy + y) * dx);
      const auto first = std::lower_bound(m_cell_keys.begin(), m_cell_keys.end(), row + std::uint64_t(c0[0]));
      const auto end = std::upper_bound(first, m_cell_keys.end(), row + std::uint64_t(c1[0]));
      if (first == end) continue;
      runs[2 * rows] = m_cell_starts[std::size_t(first - m_cell_keys.begin())];
      runs[2 * rows + 1] = m_cell_starts[std::size_t(end - m_cell_keys.begin())];
      ++rows;
    }
  return rows;
}

namespace {
/// The bounds of count points (position q at at(q)), grown as padded_bounds says.
template <class At>
void pad_bounds(At at, std::size_t count, double r, float lo[3], float hi[3]) noexcept {
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = at(0, k);
  for (std::size_t q = 1; q < count; ++q)
    for (int k = 0; k < 3; ++k) {
      const float v = at(q, k);
      lo[k] = std::min(lo[k], v);
      hi[k] = std::max(hi[k], v);
    }
  const float pad = static_cast<float>(r) * 1.001f;
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::nextafter(lo[k] - pad, -std::numeric_limits<float>::infinity());
    hi[k] = std::nextafter(hi[k] + pad, std::numeric_limits<float>::infinity());
  }
}
}  // namespace

void block_partition::padded_bounds(std::size_t first, std::size_t count, double r, float lo[3],
                                    float hi[3]) const noexcept {
  const float* const axes[3] = {m_x.data() + first, m_y.data() + first, m_z.data() + first};
  pad_bounds([&](std::size_t q, int k) { return axes[k][q]; }, count, r, lo, hi);
}

namespace detail {
void padded_bounds(const float* xyz, const std::uint32_t* points, std::size_t count, double r, float lo[3],
                   float hi[3]) noexcept {
  pad_bounds([&](std::size_t q, int k) { return xyz[3 * std::size_t(points[q]) + std::size_t(k)]; }, count, r, lo, hi);
}
}  // namespace detail

}  // namespace ced
