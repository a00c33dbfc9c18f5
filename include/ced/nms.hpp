// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include "ced/neighborhoods.hpp"

namespace ced {

/// Product of the saliency columns, in float, multiplied in column order
/// (as the paper's code does for two modalities).
std::vector<float> saliency_product(const std::vector<std::vector<float>>& saliency);

/// Non-maximum suppression: candidate i is kept when no point j with
/// |p_j - p_i|² < r² (float, strict) has score[j] > score[i]. Ties keep
/// both; non-candidates suppress too. Returns the kept indices, ascending.
/// `blocks` groups the points spatially (any partition of them works; it only
/// affects speed). Deterministic for any thread count.
std::vector<std::uint32_t> non_maximum_suppression(const neighbor_index& index, const block_partition& blocks,
                                                   const float* xyz, const std::vector<float>& score,
                                                   const std::vector<std::uint8_t>& candidate, double radius,
                                                   unsigned threads);

namespace detail {
/// NMS for `candidates[0..count)` of one spatial block, with one box query:
/// sets keep[i] for each candidate i.
void nms_block_by_query(const neighbor_index& index, const float* xyz, const std::uint32_t* candidates,
                        std::size_t count, const float* score, double radius, std::uint8_t* keep,
                        std::vector<std::uint32_t>& gathered);
/// Indices of the non-zero flags, ascending.
std::vector<std::uint32_t> compact_flags(const std::vector<std::uint8_t>& flags);
}  // namespace detail

}  // namespace ced
