// SPDX-License-Identifier: MIT
#include "ced/detect.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "ced/detail/arena.hpp"
#include "ced/detail/parallel.hpp"
#include "ced/neighbor_index.hpp"
#include "ced/nms.hpp"
#include "raw_vector.hpp"

namespace ced {

void validate(const detect_params& p) {
  auto positive = [](double v, const char* what) {
    if (!std::isfinite(v) || !(v > 0))
      throw std::invalid_argument(std::string(what) + " must be a positive finite number, got " + std::to_string(v));
  };
  positive(p.radius, "radius");
  positive(p.nms_radius, "nms_radius");
  positive(p.block_scale, "block_scale");
  if (p.threads > 4096) throw std::invalid_argument("threads must be at most 4096, got " + std::to_string(p.threads));
}

namespace detail {

namespace {
using clock_type = std::chrono::steady_clock;
double ms_since(clock_type::time_point t) {
  return std::chrono::duration<double, std::milli>(clock_type::now() - t).count();
}
}  // namespace

/// The neighbourhoods of a block's candidates, kept from the saliency pass for
/// the NMS when the NMS radius does not exceed the radius, in the sweep's
/// compact form: the block's gathered points, and per candidate its ranges
/// and hit bits (about a quarter of the size of neighbour lists).
/// Its arrays live in the detection's chunk_arena.
struct candidate_hits {
  bool stored = false;
  std::size_t count = 0, gathered_count = 0;
  const std::uint32_t *points = nullptr, *gathered = nullptr, *ranges = nullptr, *bit_offsets = nullptr;
  const std::uint8_t* bits = nullptr;
};

struct detection_context::impl {
  const point_cloud& cloud;
  detect_params params;
  detection_result result;
  neighbor_index index;
  block_partition blocks;
  std::vector<candidate_hits> hits;
  chunk_arena hit_memory;  // the hits' arrays

  impl(const point_cloud& c, const detect_params& p, neighbor_index&& idx, block_partition&& b)
      : cloud(c), params(p), index(std::move(idx)), blocks(std::move(b)) {}
};

namespace {
/// The paper's candidate rule: some modality reaches its threshold.
/// A saliency reaches its modality's threshold (compared in double).
inline bool reaches(float saliency, double threshold) noexcept { return static_cast<double>(saliency) >= threshold; }
bool is_candidate(const float* const* columns, const std::vector<double>& thresholds, std::uint32_t p) {
  for (std::size_t c = 0; c < thresholds.size(); ++c)
    if (reaches(columns[c][p], thresholds[c])) return true;
  return false;
}

/// Keeps the sweep results of the block's candidates in `ch`, in memory from
/// `arena`, if `budget` (bytes, shared by all blocks) still allows.
void collect_candidate_hits(const neighbor_block& block, const float* const* columns,
                            const std::vector<double>& thresholds, chunk_arena& arena, std::atomic<std::size_t>& budget,
                            candidate_hits& ch, std::vector<std::uint32_t>& candidates) {
  constexpr std::size_t nr = 2 * neighbor_block::sweep_ranges;
  // Which points are candidates and how many bytes of bits they keep, so
  // that every array is sized exactly, once.
  candidates.clear();
  std::size_t bit_bytes = 0;
  for (std::size_t k = 0; k < block.size(); ++k)
    if (is_candidate(columns, thresholds, block.point(k))) {
      candidates.push_back(static_cast<std::uint32_t>(k));
      bit_bytes += block.sweep(k).bytes;
    }
  if (candidates.empty()) return;
  const std::size_t n = candidates.size(), g = block.gathered_count();
  const std::size_t words = n + g + nr * n + (n + 1);
  const std::size_t want = 4 * words + bit_bytes;
  std::size_t have = budget.load();
  while (have >= want && !budget.compare_exchange_weak(have, have - want)) {
  }
  if (have < want) return;  // over budget: the NMS queries this block again
  auto* const memory = static_cast<std::uint32_t*>(arena.allocate(want));
  std::uint32_t* const points = memory;
  std::uint32_t* const gathered = points + n;
  std::uint32_t* const ranges = gathered + g;
  std::uint32_t* const bit_offsets = ranges + nr * n;
  std::uint8_t* const bits = reinterpret_cast<std::uint8_t*>(bit_offsets + n + 1);
  bit_offsets[0] = 0;
  std::uint8_t* b = bits;
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t k = candidates[c];
    const auto v = block.sweep(k);
    points[c] = block.point(k);
    std::copy_n(v.ranges, nr, ranges + nr * c);
    b = std::copy_n(v.bits, v.bytes, b);
    bit_offsets[c + 1] = static_cast<std::uint32_t>(b - bits);
  }
  std::copy_n(block.gathered(), g, gathered);
  ch = {true, n, g, points, gathered, ranges, bit_offsets, bits};
}

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
  for (std::size_t k = 0; k < ch.count; ++k) {
    const std::uint32_t i = ch.points[k];
    const float si = score[i];
    const float* pi = xyz + 3 * std::size_t(i);
    const std::uint32_t* rg = ch.ranges + nr * k;
    const std::uint8_t* const bits = ch.bits + ch.bit_offsets[k];
    // Each range's bits follow those of the ranges before it.
    std::uint32_t first_bit[neighbor_block::sweep_ranges];
    for (std::size_t q = 0, at = 0; q < neighbor_block::sweep_ranges; ++q) {
      first_bit[q] = static_cast<std::uint32_t>(at);
      at += (rg[2 * q + 1] - rg[2 * q] + 7) / 8;
    }
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

void check_inputs(const point_cloud& cloud, const detect_params& params, const std::vector<std::string>& names,
                  const std::vector<double>& thresholds) {
  validate(params);
  if (names.empty()) throw std::invalid_argument("no modality given: detection needs at least one");
  for (std::size_t m = 0; m < names.size(); ++m)
    if (!std::isfinite(thresholds[m]) || thresholds[m] < 0)
      throw std::invalid_argument("threshold of modality '" + names[m] + "' must be a finite number >= 0, got " +
                                  std::to_string(thresholds[m]));
  const auto& xyz = cloud.positions();
  // In chunks without an early exit, on the bits, which vectorises; the
  // failing chunk is then searched.
  constexpr std::size_t chunk = 4096;
  for (std::size_t b = 0; b < xyz.size(); b += chunk) {
    const std::size_t e = std::min(xyz.size(), b + chunk);
    std::uint32_t bad = 0;
    for (std::size_t i = b; i < e; ++i) {
      std::uint32_t bits;
      std::memcpy(&bits, xyz.data() + i, sizeof bits);
      // The exponent field all ones (NaN or infinite) carries into bit 31.
      bad |= ((bits & 0x7f800000u) + (1u << 23)) & (1u << 31);
    }
    if (bad == 0) continue;
    for (std::size_t i = b; i < e; ++i)
      if (!std::isfinite(xyz[i]))
        throw std::invalid_argument("point " + std::to_string(i / 3) +
                                    " has a non-finite coordinate (remove NaN/Inf points first)");
  }
  if (cloud.size() >= std::size_t(UINT32_MAX)) throw std::invalid_argument("too many points (at most 2^32-2)");
}
}  // namespace

detection_context::detection_context(const point_cloud& cloud, const detect_params& params,
                                     std::vector<std::string> names, std::vector<double> thresholds) {
  check_inputs(cloud, params, names, thresholds);
  const auto t0 = clock_type::now();
  const unsigned threads = resolve_threads(params.threads);
  const float* xyz = cloud.positions().data();
  // Blocks first: the tree is built over the points in block order, which is
  // several times faster than over an arbitrary order on large clouds. Its
  // leaves hold up to 256 points: the tree is only asked for whole blocks'
  // boxes, and a shallower tree builds faster (its build is most of this
  // stage) for a few more points tested per query.
  block_partition blocks(xyz, cloud.size(), params.radius * params.block_scale, threads);
  neighbor_index index(xyz, cloud.size(), 256, threads, blocks.order().data());
  m_impl = std::make_unique<impl>(cloud, params, std::move(index), std::move(blocks));
  m_impl->result.names = std::move(names);
  m_impl->result.thresholds = std::move(thresholds);
  m_impl->result.times.index_ms = ms_since(t0);
}

detection_context::~detection_context() = default;

void detection_context::compute_saliency(const std::vector<channel_source>& sources,
                                         const std::function<void(const neighbor_block&, float* const*)>& f) {
  if (sources.size() != m_impl->result.names.size())
    throw std::invalid_argument("compute_saliency: one channel source per modality expected");
  const auto t0 = clock_type::now();
  auto& r = m_impl->result;
  const std::size_t n = m_impl->cloud.size();
  const std::size_t m = r.names.size();
  r.saliency.assign(m, std::vector<float>(n, 0.0f));
  r.neighbor_count.assign(n, 0);
  std::vector<float*> columns(m);
  for (std::size_t k = 0; k < m; ++k) columns[k] = r.saliency[k].data();
  const float* xyz = m_impl->cloud.positions().data();
  const auto& blocks = m_impl->blocks;
  const auto& params = m_impl->params;
  // Keeping the candidates' neighbourhoods saves the NMS its own queries.
  // Bounded memory: past the budget, blocks fall back to querying again
  // (which blocks do depends on timing, the result does not).
  const bool keep_hits = params.nms_radius <= params.radius;
  std::atomic<std::size_t> budget{std::max<std::size_t>(std::size_t(1) << 28, 64 * n)};  // bytes
  m_impl->hits.assign(keep_hits ? blocks.block_count() : 0, {});
  std::atomic<std::size_t> blocks_done{0};
  std::mutex progress_mutex;
  const std::size_t report_every = std::max<std::size_t>(1, blocks.block_count() / 100);
  // Work buffers, reused by whichever chunk runs next (their growth is
  // costly), so that chunks can be small and the threads finish together.
  struct worker {
    neighbor_block block;
    std::vector<std::uint32_t> candidates;
  };
  std::vector<std::unique_ptr<worker>> idle;
  std::mutex idle_mutex;
  parallel_for(blocks.block_count(), resolve_threads(params.threads), 2, [&](std::size_t b0, std::size_t b1) {
    std::unique_ptr<worker> w;
    {
      std::lock_guard<std::mutex> lock(idle_mutex);
      if (!idle.empty()) {
        w = std::move(idle.back());
        idle.pop_back();
      }
    }
    if (!w) {
      w = std::make_unique<worker>();
      w->block.set_channels(sources);
    }
    neighbor_block& block = w->block;
    std::vector<std::uint32_t>& candidates = w->candidates;
    for (std::size_t b = b0; b < b1; ++b) {
      block.fill(m_impl->index, xyz, blocks.block_points(b), blocks.block_size(b), params.radius);
      for (std::size_t k = 0; k < block.size(); ++k) r.neighbor_count[block.point(k)] = block.count(k);
      f(block, columns.data());
      if (!keep_hits) continue;
      collect_candidate_hits(block, columns.data(), r.thresholds, m_impl->hit_memory, budget, m_impl->hits[b],
                             candidates);
    }
    {
      std::lock_guard<std::mutex> lock(idle_mutex);
      idle.push_back(std::move(w));
    }
    if (params.progress) {
      const std::size_t done = blocks_done.fetch_add(b1 - b0) + (b1 - b0);
      std::unique_lock<std::mutex> lock(progress_mutex, std::try_to_lock);
      if (lock && (done % report_every < b1 - b0 || done == blocks.block_count()))
        params.progress(double(done) / double(blocks.block_count()));
    }
  });
  r.times.saliency_ms = ms_since(t0);
}

detection_result detection_context::finish() {
  const auto t0 = clock_type::now();
  auto& r = m_impl->result;
  const std::size_t n = m_impl->cloud.size();
  r.candidate.assign(n, 0);
  std::vector<const float*> columns;
  for (const auto& s : r.saliency) columns.push_back(s.data());
  raw_vector<float> product(n);  // written in full below
  const unsigned threads = resolve_threads(m_impl->params.threads);
  parallel_for(n, threads, 1 << 14, [&](std::size_t b, std::size_t e) {
    // is_candidate() and the NMS's score (the product of the saliencies in
    // modality order), modality by modality over the chunk so that the loops
    // vectorise.
    auto* const cand = r.candidate.data();
    float* const p = product.data();
    for (std::size_t m = 0; m < columns.size(); ++m) {
      const float* col = columns[m];
      const double t = r.thresholds[m];
      for (std::size_t i = b; i < e; ++i) cand[i] |= reaches(col[i], t);
      if (m == 0)
        std::copy(col + b, col + e, p + b);
      else
        for (std::size_t i = b; i < e; ++i) p[i] *= col[i];
    }
  });
  const float* xyz = m_impl->cloud.positions().data();
  const auto& blocks = m_impl->blocks;
  const auto& hits = m_impl->hits;
  std::vector<std::uint8_t> keep(n, 0);
  parallel_for(blocks.block_count(), threads, 16, [&](std::size_t b0, std::size_t b1) {
    std::vector<std::uint32_t> cand, gathered;
    std::vector<float> local;
    for (std::size_t b = b0; b < b1; ++b) {
      if (!hits.empty() && hits[b].stored) {
        const auto& params = m_impl->params;
        nms_from_hits(hits[b], xyz, product.data(), params.nms_radius, params.nms_radius == params.radius, keep.data(),
                      local);
        continue;
      }
      const std::uint32_t* pts = blocks.block_points(b);
      cand.clear();
      for (std::size_t k = 0; k < blocks.block_size(b); ++k)
        if (r.candidate[pts[k]]) cand.push_back(pts[k]);
      nms_block_by_query(m_impl->index, xyz, cand.data(), cand.size(), product.data(), m_impl->params.nms_radius,
                         keep.data(), gathered);
    }
  });
  m_impl->hits.clear();
  m_impl->hits.shrink_to_fit();
  r.keypoints = compact_flags(keep);
  r.times.nms_ms = ms_since(t0);
  return std::move(r);
}

}  // namespace detail

void release_cached_memory() noexcept { detail::chunk_arena::release_cache(); }

detection_result detect(const point_cloud& cloud, const detect_params& params,
                        const std::vector<any_modality>& modalities) {
  std::vector<std::string> names;
  std::vector<double> thresholds;
  for (const auto& m : modalities) {
    if (!m) throw std::invalid_argument("empty modality in the list");
    names.push_back(m.name());
    thresholds.push_back(m.threshold(params));
  }
  detail::detection_context ctx(cloud, params, std::move(names), std::move(thresholds));
  std::vector<std::unique_ptr<bound_modality>> bound;
  std::vector<channel_source> sources;
  for (const auto& m : modalities) {
    bound.push_back(m.bind(cloud, params));
    sources.push_back(bound.back()->channels());
  }
  ctx.compute_saliency(sources, [&](const neighbor_block& block, float* const* columns) {
    for (std::size_t k = 0; k < bound.size(); ++k) bound[k]->evaluate(block, k, params.min_neighbors, columns[k]);
  });
  return ctx.finish();
}

}  // namespace ced
