// SPDX-License-Identifier: MIT
// Private: how keypoints rank for detect_params::max_keypoints, written
// once for detection (ced::strongest) and for the tiled merge, which must
// choose the same keypoints from all tiles.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace ced::detail {

/// A keypoint's score and its index.
struct rank_key {
  float score;
  std::uint64_t index;
};

/// Whether `a` ranks before `b`: the higher score (NaN lowest), then the smaller index.
inline bool stronger(const rank_key& a, const rank_key& b) noexcept {
  const float inf = std::numeric_limits<float>::infinity();
  const float sa = std::isnan(a.score) ? -inf : a.score, sb = std::isnan(b.score) ? -inf : b.score;
  return sa != sb ? sa > sb : a.index < b.index;
}

/// The ranks of `subset`, keypoints of `keypoints` (both ascending), from
/// `ranks` (aligned with `keypoints`: detection_result::rank_score).
inline std::vector<float> ranks_of(const std::vector<std::uint32_t>& keypoints, const std::vector<float>& ranks,
                                   const std::vector<std::uint32_t>& subset) {
  std::vector<float> out(subset.size());
  for (std::size_t j = 0, q = 0; j < subset.size(); ++j, ++q) {
    while (keypoints[q] != subset[j]) ++q;
    out[j] = ranks[q];
  }
  return out;
}

/// The score of a point from its `modalities` saliencies, saliency(k) the
/// k-th: the product in float, in modality order, as candidates_and_scores()
/// computes it (0 without modalities).
template <class Saliency>
float score_of(std::size_t modalities, Saliency&& saliency) {
  float score = modalities ? saliency(std::size_t(0)) : 0.0f;
  for (std::size_t k = 1; k < modalities; ++k) score *= saliency(k);
  return score;
}

}  // namespace ced::detail
