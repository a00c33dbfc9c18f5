// SPDX-License-Identifier: MIT
// Private: stage 5 of detection, the multi-modal non-maximum suppression.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/arena.hpp"
#include "core/block_partition.hpp"
#include "core/neighbor_block.hpp"
#include "core/raw_vector.hpp"

namespace ced::detail {

/// The neighbourhoods of a block's candidates, kept from the saliency pass for
/// the NMS when the NMS radius does not exceed the radius, in the sweep's
/// compact form: the block's gathered points, and per candidate its ranges
/// and hit bits (about a quarter of the size of neighbour lists).
/// Its arrays live in the detection's chunk_arena.
/// Per candidate: its index, its nine ranges as 16-bit indices into the
/// gathered points, and its hit bits (those of all candidates one after the
/// other; each candidate's length follows from its ranges).
struct candidate_hits {
  bool stored = false;
  std::size_t count = 0, gathered_count = 0;
  const std::uint32_t *points = nullptr, *gathered = nullptr;
  const std::uint16_t* ranges = nullptr;
  const std::uint8_t* bits = nullptr;
};

/// The memory budget of the kept sweeps (collect_candidate_hits), shared by
/// all blocks of a detection of n points: kept_sweeps_min_bytes or
/// kept_sweeps_bytes_per_point · n, whichever is more. docs/ALGORITHM.md
/// quotes it (tests/test_docs.cpp checks that it still does).
inline constexpr std::size_t kept_sweeps_min_bytes = std::size_t(64) << 20;
inline constexpr std::size_t kept_sweeps_bytes_per_point = 16;
inline std::size_t kept_sweeps_budget(std::size_t n) noexcept {
  return std::max(kept_sweeps_min_bytes, kept_sweeps_bytes_per_point * n);
}

/// Keeps the sweep results of the block's candidates in `ch`, in memory from
/// `arena`, if `budget` (bytes, shared by all blocks) still allows. Called by
/// the saliency pass, block by block, once the block's saliencies are known.
void collect_candidate_hits(const neighbor_block& block, const float* const* columns,
                            const std::vector<double>& thresholds, chunk_arena& arena, std::atomic<std::size_t>& budget,
                            candidate_hits& ch, std::vector<std::uint32_t>& candidates);

/// Non-maximum suppression: candidate i is kept when no point j with
/// |p_j - p_i|² < nms_radius² (float, strict) has score[j] > score[i]. Ties
/// keep both; non-candidates suppress too. Returns the kept indices,
/// ascending. `blocks` groups the points spatially and is the search
/// structure of the queries. A block whose candidates' neighbourhoods were kept in
/// `hits` (which is empty, or has one entry per block) is suppressed from
/// them, without a query; `radius` is the radius they were found with.
/// Deterministic for any thread count.
/// `point_nms`, when given (neighborhood_spec::nms_own), is each point's own
/// NMS radius, used instead of nms_radius (and `hits` must be empty).
std::vector<std::uint32_t> non_maximum_suppression(const block_partition& blocks, const float* xyz, const float* score,
                                                   const std::uint8_t* candidate, double nms_radius, double radius,
                                                   const std::vector<candidate_hits>& hits, unsigned threads,
                                                   const float* point_nms = nullptr);

/// Work buffers of nms_block_by_query, reused between blocks.
struct nms_scratch {
  detail::raw_vector<neighbor_index::located_point> gathered;
  std::vector<std::uint32_t> cell_start, cell_of;
  std::vector<float> x, y, z, score;
};
/// NMS for `candidates[0..count)` of one spatial block, with one box query:
/// sets keep[i] for each candidate i. The gathered points are sorted into
/// cells one NMS radius wide, so each candidate reads only the 27 cells
/// around its own.
void nms_block_by_query(const block_partition& blocks, const float* xyz, const std::uint32_t* candidates,
                        std::size_t count, const float* score, double radius, std::uint8_t* keep, nms_scratch& scratch,
                        const float* point_nms = nullptr);

/// Keypoint refinement (detect_params::refine): each of `keypoints` moved to
/// the point within `radius` (strict) nearest to the score-weighted centroid
/// of the points within `radius`; ascending, each point once. `rank` gets,
/// for each, the highest score of the keypoints that moved to it.
std::vector<std::uint32_t> refine_keypoints(const block_partition& blocks, const float* xyz, const float* score,
                                            const std::vector<std::uint32_t>& keypoints, double radius,
                                            unsigned threads, std::vector<float>& rank);

/// Indices of the non-zero flags, ascending.
std::vector<std::uint32_t> compact_flags(const std::vector<std::uint8_t>& flags);

}  // namespace ced::detail
