// SPDX-License-Identifier: MIT
// Private: how keypoints rank for detect_params::max_keypoints, written
// once for detection (ced::strongest) and for the tiled merge, which must
// choose the same keypoints from all tiles.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

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
