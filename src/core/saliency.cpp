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

void detection_context::compute_saliency(const std::vector<channel_source>& sources,
                                         const std::function<void(const block_view&, float* const*)>& f) {
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
  // Bounded memory: at most 64 MiB or 16 bytes a point, whichever is more.
  // A candidate's sweep takes about 85 bytes, about 31 bytes a point in a
  // room at 1 cm: every block keeps its sweeps up to ~2 M points, about half
  // of them at 10 M, which keeps a whole ced6d run of a 10 M-point LAS file
  // under 100 bytes a point.
  // Past the budget, blocks fall back to querying again (which blocks do
  // depends on timing, the result does not).
  const bool keep_lists = m_impl->keep_lists;
  const bool keep_hits = params.nms_radius <= params.radius && keep_lists;
  std::atomic<std::size_t> budget{kept_sweeps_budget(n)};  // bytes
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
      w->block.set_keep_lists(keep_lists);
    }
    neighbor_block& block = w->block;
    std::vector<std::uint32_t>& candidates = w->candidates;
    for (std::size_t b = b0; b < b1; ++b) {
      block.fill(blocks, xyz, blocks.block_points(b), blocks.block_size(b), params.radius);
      for (std::size_t k = 0; k < block.size(); ++k) r.neighbor_count[block.point(k)] = block.count(k);
      f(block.view(), columns.data());
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
  r.times.saliency_ms += ms_since(t0);
}

}  // namespace ced::detail
