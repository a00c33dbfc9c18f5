// SPDX-License-Identifier: MIT
// Stages 2 and 3 of detection: the neighbour pass over every spatial block,
// in parallel, and every modality's saliency from it.
#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "core/detection.hpp"
#include "core/parallel.hpp"

namespace ced::detail {

namespace {

using saliency_fn = std::function<void(const block_view&, float* const*)>;

/// Calls params.progress after blocks [b0, b1) (at most about 100 times).
class progress_report {
 public:
  progress_report(const detect_params& p, std::size_t block_count) : params(p), blocks(block_count) {}
  void operator()(std::size_t b0, std::size_t b1) {
    if (!params.progress) return;
    const std::size_t every = std::max<std::size_t>(1, blocks / 100);
    const std::size_t now = done.fetch_add(b1 - b0) + (b1 - b0);
    std::unique_lock<std::mutex> lock(mutex, std::try_to_lock);
    if (lock && (now % every < b1 - b0 || now == blocks)) params.progress(double(now) / double(blocks));
  }

 private:
  const detect_params& params;
  std::size_t blocks;
  std::atomic<std::size_t> done{0};
  std::mutex mutex;
};

/// Work buffers, reused by whichever chunk runs next (their growth is
/// costly), so that chunks can be small and the threads finish together.
template <class Worker>
class worker_pool {
 public:
  template <class Make>
  std::unique_ptr<Worker> take(Make&& make) {
    {
      std::lock_guard<std::mutex> lock(m_mutex);
      if (!m_idle.empty()) {
        auto w = std::move(m_idle.back());
        m_idle.pop_back();
        return w;
      }
    }
    return make();
  }
  void give(std::unique_ptr<Worker> w) {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_idle.push_back(std::move(w));
  }

 private:
  std::vector<std::unique_ptr<Worker>> m_idle;
  std::mutex m_mutex;
};

/// The grid's neighbour pass (neighbor_block) over every block.
template <class Impl>
void grid_pass(Impl& s, const std::vector<channel_source>& sources, const saliency_fn& f, float* const* columns) {
  auto& r = s.result;
  const std::size_t n = s.cloud.size();
  const float* xyz = s.cloud.positions().data();
  const auto& blocks = s.blocks;
  const auto& params = s.params;
  // Keeping the candidates' neighbourhoods saves the NMS its own queries.
  // Bounded memory: at most 64 MiB or 16 bytes a point, whichever is more.
  // A candidate's sweep takes about 85 bytes, about 31 bytes a point in a
  // room at 1 cm: every block keeps its sweeps up to ~2 M points, about half
  // of them at 10 M, which keeps a whole ced6d run of a 10 M-point LAS file
  // under 100 bytes a point.
  // Past the budget, blocks fall back to querying again (which blocks do
  // depends on timing, the result does not).
  const bool keep_lists = s.keep_lists;
  const bool keep_hits = params.nms_radius <= params.radius && keep_lists;
  std::atomic<std::size_t> budget{kept_sweeps_budget(n)};  // bytes
  s.hits.assign(keep_hits ? blocks.block_count() : 0, {});
  progress_report progress{params, blocks.block_count()};
  struct worker {
    neighbor_block block;
    std::vector<std::uint32_t> candidates;
  };
  worker_pool<worker> pool;
  parallel_for(blocks.block_count(), resolve_threads(params.threads), 2, [&](std::size_t b0, std::size_t b1) {
    auto w = pool.take([&] {
      auto made = std::make_unique<worker>();
      made->block.set_channels(sources);
      made->block.set_moments(s.moments);
      made->block.set_keep_lists(keep_lists);
      return made;
    });
    neighbor_block& block = w->block;
    for (std::size_t b = b0; b < b1; ++b) {
      block.fill(blocks, xyz, blocks.block_points(b), blocks.block_size(b), params.radius);
      for (std::size_t k = 0; k < block.size(); ++k) r.neighbor_count[block.point(k)] = block.count(k);
      f(block.view(), columns);
      if (!keep_hits) continue;
      collect_candidate_hits(block, columns, r.thresholds, s.hit_memory, budget, s.hits[b], w->candidates);
    }
    pool.give(std::move(w));
    progress(b0, b1);
  });
}

/// The pass by lists on CGAL's spatial search (list_block) over every
/// block: knn and adaptive neighbourhoods, and search = cgal.
template <class Impl>
void list_pass(Impl& s, const std::vector<channel_source>& sources, const saliency_fn& f, float* const* columns) {
  auto& r = s.result;
  const std::size_t n = s.cloud.size();
  const float* xyz = s.cloud.positions().data();
  const auto& blocks = s.blocks;
  const auto& params = s.params;
  const unsigned threads = resolve_threads(params.threads);
  const auto t0 = clock_type::now();
  const bool fixed = params.neighborhood.fixed();
  // Ball queries run on a forest of trees over runs of the blocks' order
  // (cheap to build); k-nearest queries on one tree (one query a point).
  const neighbor_index index(xyz, n, 32, threads, blocks.order().data());
  r.times.index_ms += ms_since(t0);
  if (!fixed) r.point_radius.assign(n, 0.0f);
  s.hits.clear();  // the NMS queries its own neighbourhoods
  progress_report progress{params, blocks.block_count()};
  worker_pool<list_block> pool;
  parallel_for(blocks.block_count(), threads, 2, [&](std::size_t b0, std::size_t b1) {
    auto block = pool.take([&] {
      auto made = std::make_unique<list_block>();
      made->set_channels(sources);
      return made;
    });
    for (std::size_t b = b0; b < b1; ++b) {
      block->fill(index, blocks, xyz, blocks.block_points(b), blocks.block_size(b), params);
      for (std::size_t k = 0; k < block->size(); ++k) r.neighbor_count[block->point(k)] = block->count(k);
      f(block->view(), columns);
      if (fixed) continue;
      for (std::size_t k = 0; k < block->size(); ++k) {
        const std::uint32_t i = block->point(k);
        const double ri = block->radius(k);
        r.point_radius[i] = static_cast<float>(ri);
        // K points at one place: every distance is 0, and so is the saliency.
        const double per_unit = ri > 0 ? params.radius / ri : 0.0;
        for (std::size_t m = 0; m < s.per_radius.size(); ++m)
          if (s.per_radius[m]) columns[m][i] = static_cast<float>(double(columns[m][i]) * per_unit);
      }
    }
    pool.give(std::move(block));
    progress(b0, b1);
  });
}

}  // namespace

void detection_context::compute_saliency(const std::vector<channel_source>& sources, const saliency_fn& f) {
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
  const auto& params = m_impl->params;
  const double index_before = r.times.index_ms;
  if (params.neighborhood.fixed() && params.search == search_kind::grid)
    grid_pass(*m_impl, sources, f, columns.data());
  else
    list_pass(*m_impl, sources, f, columns.data());  // its index's time goes to index_ms
  r.times.saliency_ms += ms_since(t0) - (r.times.index_ms - index_before);
}

}  // namespace ced::detail
