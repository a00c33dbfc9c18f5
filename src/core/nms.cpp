// SPDX-License-Identifier: MIT
// Stage 5 of detection: the multi-modal non-maximum suppression.
#include "core/nms.hpp"

#include <algorithm>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/candidates.hpp"
#include "core/parallel.hpp"
#include "core/ranking.hpp"

namespace ced::detail {

/// Keeps the sweep results of the block's candidates in `ch`, in memory from
/// `arena`, if `budget` (bytes, shared by all blocks) still allows.
void collect_candidate_hits(const neighbor_block& block, const float* const* columns,
                            const std::vector<double>& thresholds, chunk_arena& arena, std::atomic<std::size_t>& budget,
                            candidate_hits& ch, std::vector<std::uint32_t>& candidates) {
  constexpr std::size_t nr = 2 * neighbor_block::sweep_ranges;
  // Ranges index the gathered points: 16 bits hold them in all but blocks of
  // more than 65,535 gathered points, which are left to the NMS's queries.
  const std::size_t g = block.gathered_count();
  if (g > std::numeric_limits<std::uint16_t>::max()) return;
  // Which points are candidates and how many bytes of bits they keep, so
  // that every array is sized exactly, once.
  candidates.clear();
  std::size_t bit_bytes = 0;
  for (std::size_t k = 0; k < block.size(); ++k)
    if (is_candidate(columns, thresholds, block.point(k))) {
      candidates.push_back(static_cast<std::uint32_t>(k));
      bit_bytes += block.sweep(k).bytes;
    }
  const std::size_t n = candidates.size();
  if (n == 0) return;
  const std::size_t want = 4 * (n + g) + 2 * nr * n + bit_bytes;
  std::size_t have = budget.load();
  while (have >= want && !budget.compare_exchange_weak(have, have - want)) {
  }
  if (have < want) return;  // over budget: the NMS queries this block again
  auto* const memory = static_cast<std::uint32_t*>(arena.allocate(want));
  std::uint32_t* const points = memory;
  std::uint32_t* const gathered = points + n;
  auto* const ranges = reinterpret_cast<std::uint16_t*>(gathered + g);
  std::uint8_t* const bits = reinterpret_cast<std::uint8_t*>(ranges + nr * n);
  std::uint8_t* b = bits;
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t k = candidates[c];
    const auto v = block.sweep(k);
    points[c] = block.point(k);
    for (std::size_t q = 0; q < nr; ++q) ranges[nr * c + q] = static_cast<std::uint16_t>(v.ranges[q]);
    b = std::copy_n(v.bits, v.bytes, b);
  }
  std::copy_n(block.gathered(), g, gathered);
  ch = {true, n, g, points, gathered, ranges, bits};
}

namespace {
/// Bit l set when s[l] > x, for l < 8.
unsigned greater_lanes(const float* s, float x) noexcept {
#if defined(__SSE2__)
  const __m128 v = _mm_set1_ps(x);
  return static_cast<unsigned>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(s), v))) |
         (static_cast<unsigned>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(s + 4), v))) << 4);
#else
  unsigned greater = 0;
  for (unsigned l = 0; l < 8; ++l) greater |= unsigned(s[l] > x) << l;
  return greater;
#endif
}

/// The NMS of the candidates kept in `ch`: a candidate is kept unless a
/// neighbour within `nms_radius` has a strictly greater score.
void nms_from_hits(const candidate_hits& ch, const float* xyz, const float* score, double nms_radius, bool whole_ball,
                   std::uint8_t* keep, std::vector<float>& local) {
  constexpr std::size_t nr = 2 * neighbor_block::sweep_ranges;
  const float r2 = squared_radius(nms_radius);
  // The gathered points' scores in sweep order, so that a group of eight
  // neighbours is compared at once (padded: groups read whole).
  const std::size_t g = ch.gathered_count;
  local.resize(g + 8);
  for (std::size_t t = 0; t < g; ++t) local[t] = score[ch.gathered[t]];
  std::fill_n(local.begin() + std::ptrdiff_t(g), 8, 0.0f);
  // Each candidate's bits follow those of the candidates before it, and
  // each range's those of the ranges before it.
  const std::uint8_t* next_bits = ch.bits;
  for (std::size_t k = 0; k < ch.count; ++k) {
    const std::uint32_t i = ch.points[k];
    const float si = score[i];
    const float* pi = xyz + 3 * std::size_t(i);
    const std::uint16_t* rg = ch.ranges + nr * k;
    const std::uint8_t* const bits = next_bits;
    std::uint32_t first_bit[neighbor_block::sweep_ranges];
    std::size_t at = 0;
    for (std::size_t q = 0; q < neighbor_block::sweep_ranges; ++q) {
      first_bit[q] = static_cast<std::uint32_t>(at);
      at += (std::size_t(rg[2 * q + 1]) - rg[2 * q] + 7) / 8;
    }
    next_bits += at;
    // The point's own row first, then the rows beside it, then the corners:
    // nearer neighbours are likelier to beat it, which ends the walk early.
    // (Whether a greater neighbour exists does not depend on the order.)
    static constexpr std::size_t walk[neighbor_block::sweep_ranges] = {4, 1, 3, 5, 7, 0, 2, 6, 8};
    bool maximum = true;
    for (std::size_t w = 0; w < neighbor_block::sweep_ranges && maximum; ++w) {
      const std::size_t q = walk[w];
      const std::uint8_t* gb = bits + first_bit[q];
      for (std::uint32_t t = rg[2 * q]; t < rg[2 * q + 1] && maximum; t += 8) {
        const unsigned b = *gb++;
        const unsigned greater = greater_lanes(local.data() + t, si);
        if ((b & greater) == 0) continue;
        if (whole_ball) {
          maximum = false;
          break;
        }
        for (unsigned m = b & greater; m != 0 && maximum; m &= m - 1) {
          const std::uint32_t j = ch.gathered[t + static_cast<std::uint32_t>(__builtin_ctz(m))];
          maximum = !(squared_distance(xyz + 3 * std::size_t(j), pi) < r2);
        }
      }
    }
    keep[i] = maximum;
  }
}

}  // namespace

namespace {
/// The gathered points sorted into cells of at least `radius` over the box
/// [lo, hi] (at most about two a point), their positions and scores copied
/// into `scratch` in cell order.
struct nms_cells {
  double lo[3], inv = 1;
  std::size_t dims[3] = {1, 1, 1};

  nms_cells(const float* score, const float box_lo[3], const float box_hi[3], double radius, nms_scratch& scratch) {
    const auto& gathered = scratch.gathered;
    const std::size_t g = gathered.size();
    double side = std::max(radius * (1 + 1e-6), 1e-30);  // a hair over: rounding never skips a cell
    auto fit = [&] {
      for (int a = 0; a < 3; ++a) dims[a] = std::size_t(std::min((double(box_hi[a]) - box_lo[a]) / side, 1e6)) + 1;
      return dims[0] * dims[1] * dims[2];
    };
    while (fit() > 2 * g + 8) side *= 2;
    for (int a = 0; a < 3; ++a) lo[a] = box_lo[a];
    inv = 1 / side;
    const std::size_t cells = dims[0] * dims[1] * dims[2];
    auto& start = scratch.cell_start;
    auto& of = scratch.cell_of;
    start.assign(cells + 1, 0);
    of.resize(g);
    for (std::size_t t = 0; t < g; ++t) {
      of[t] = static_cast<std::uint32_t>(key(gathered[t].xyz));
      ++start[of[t] + 1];
    }
    for (std::size_t c = 0; c < cells; ++c) start[c + 1] += start[c];
    for (auto* v : {&scratch.x, &scratch.y, &scratch.z, &scratch.score}) v->resize(g);
    for (std::size_t t = 0; t < g; ++t) {
      const neighbor_index::located_point& p = gathered[t];
      const std::uint32_t to = start[of[t]]++;
      scratch.x[to] = p.xyz[0], scratch.y[to] = p.xyz[1];
      scratch.z[to] = p.xyz[2], scratch.score[to] = score[p.index];
    }
    for (std::size_t c = cells; c > 0; --c) start[c] = start[c - 1];  // back to the starts
    start[0] = 0;
  }
  std::size_t cell(const float* p, int a) const noexcept {
    const double v = (double(p[a]) - lo[a]) * inv;
    return std::size_t(std::min(std::max(v, 0.0), double(dims[a] - 1)));
  }
  std::size_t key(const float* p) const noexcept { return (cell(p, 2) * dims[1] + cell(p, 1)) * dims[0] + cell(p, 0); }
};
}  // namespace

void nms_block_by_query(const block_partition& blocks, const float* xyz, const std::uint32_t* candidates,
                        std::size_t count, const float* score, double radius, std::uint8_t* keep, nms_scratch& scratch,
                        const float* point_nms) {
  if (count == 0) return;
  if (point_nms) {  // each candidate's own radius: the box holds the largest
    radius = 0;
    for (std::size_t k = 0; k < count; ++k) radius = std::max(radius, double(point_nms[candidates[k]]));
  }
  float lo[3], hi[3];
  padded_bounds(xyz, candidates, count, radius, lo, hi);
  blocks.box_search(lo, hi, scratch.gathered);
  const nms_cells grid(score, lo, hi, radius, scratch);
  const auto& start = scratch.cell_start;
  const float fixed_r2 = squared_radius(radius);
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t i = candidates[k];
    const float r2 = point_nms ? squared_radius(point_nms[i]) : fixed_r2;
    const float si = score[i];
    const float* pi = xyz + 3 * std::size_t(i);
    std::size_t c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
      const std::size_t c = grid.cell(pi, a);
      c0[a] = c > 0 ? c - 1 : 0;
      c1[a] = std::min(c + 1, grid.dims[a] - 1);
    }
    bool maximum = true;
    for (std::size_t cz = c0[2]; cz <= c1[2] && maximum; ++cz)
      for (std::size_t cy = c0[1]; cy <= c1[1] && maximum; ++cy) {
        // A row of up to three cells is one run of the arrays.
        const std::size_t row = (cz * grid.dims[1] + cy) * grid.dims[0];
        for (std::uint32_t t = start[row + c0[0]]; t < start[row + c1[0] + 1]; ++t) {
          // squared_distance(p_j, p_i), term for term.
          const float dx = scratch.x[t] - pi[0], dy = scratch.y[t] - pi[1], dz = scratch.z[t] - pi[2];
          if (scratch.score[t] > si && dx * dx + dy * dy + dz * dz < r2) {
            maximum = false;
            break;
          }
        }
      }
    keep[i] = maximum;
  }
}

std::vector<std::uint32_t> non_maximum_suppression(const block_partition& blocks, const float* xyz, const float* score,
                                                   const std::uint8_t* candidate, double nms_radius, double radius,
                                                   const std::vector<candidate_hits>& hits, unsigned threads,
                                                   const float* point_nms) {
  std::vector<std::uint8_t> keep(blocks.order().size(), 0);
  parallel_for(blocks.block_count(), threads, 16, [&](std::size_t b0, std::size_t b1) {
    std::vector<std::uint32_t> cand;
    nms_scratch scratch;
    std::vector<float> local;
    for (std::size_t b = b0; b < b1; ++b) {
      if (!hits.empty() && hits[b].stored) {
        nms_from_hits(hits[b], xyz, score, nms_radius, nms_radius == radius, keep.data(), local);
        continue;
      }
      const std::uint32_t* pts = blocks.block_points(b);
      cand.clear();
      for (std::size_t k = 0; k < blocks.block_size(b); ++k)
        if (candidate[pts[k]]) cand.push_back(pts[k]);
      nms_block_by_query(blocks, xyz, cand.data(), cand.size(), score, nms_radius, keep.data(), scratch, point_nms);
    }
  });
  return compact_flags(keep);
}

std::vector<std::uint32_t> refine_keypoints(const block_partition& blocks, const float* xyz, const float* score,
                                            const std::vector<std::uint32_t>& keypoints, double radius,
                                            unsigned threads, std::vector<float>& rank) {
  std::vector<std::uint32_t> moved(keypoints.size());
  const float r2 = squared_radius(radius);
  parallel_for(keypoints.size(), threads, 64, [&](std::size_t q0, std::size_t q1) {
    detail::raw_vector<std::uint32_t> ball;
    for (std::size_t q = q0; q < q1; ++q) {
      const std::uint32_t k = keypoints[q];
      const float* pk = xyz + 3 * std::size_t(k);
      float lo[3], hi[3];
      padded_bounds(xyz, &k, 1, radius, lo, hi);
      blocks.box_search(lo, hi, ball);
      ball.erase(
          std::remove_if(ball.begin(), ball.end(),
                         [&](std::uint32_t j) { return !(squared_distance(xyz + 3 * std::size_t(j), pk) < r2); }),
          ball.end());
      // By index: the sums do not depend on the blocks (tiles are exact).
      std::sort(ball.begin(), ball.end());
      double w = 0, m[3] = {0, 0, 0};
      for (std::uint32_t j : ball) {
        w += score[j];
        for (std::size_t a = 0; a < 3; ++a) m[a] += double(score[j]) * xyz[3 * std::size_t(j) + a];
      }
      if (!(w > 0)) {  // no score around (a keypoint whose product is 0): the plain centroid
        w = double(ball.size());
        m[0] = m[1] = m[2] = 0;
        for (std::uint32_t j : ball)
          for (std::size_t a = 0; a < 3; ++a) m[a] += xyz[3 * std::size_t(j) + a];
      }
      for (double& v : m) v /= w;
      std::uint32_t best = k;
      double best_d = std::numeric_limits<double>::infinity();
      for (std::uint32_t j : ball) {  // ascending: ties go to the smaller index
        double d = 0;
        for (std::size_t a = 0; a < 3; ++a) {
          const double e = double(xyz[3 * std::size_t(j) + a]) - m[a];
          d += e * e;
        }
        if (d < best_d) {
          best_d = d;
          best = j;
        }
      }
      moved[q] = best;
    }
  });
  // Each point once, ranked by the strongest maximum that moved to it.
  std::vector<std::pair<std::uint32_t, float>> to(keypoints.size());
  for (std::size_t q = 0; q < to.size(); ++q) to[q] = {moved[q], score[keypoints[q]]};
  std::sort(to.begin(), to.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  moved.clear();
  rank.clear();
  for (const auto& [j, s] : to) {
    if (!moved.empty() && moved.back() == j) {
      if (detail::stronger({s, 0}, {rank.back(), 1})) rank.back() = s;  // the higher score, NaN lowest
    } else {
      moved.push_back(j);
      rank.push_back(s);
    }
  }
  return moved;
}

std::vector<std::uint32_t> compact_flags(const std::vector<std::uint8_t>& flags) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

}  // namespace ced::detail
