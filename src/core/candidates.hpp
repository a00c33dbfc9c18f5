// SPDX-License-Identifier: MIT
// Private: stage 4 of detection, the paper's candidate rule and the NMS score.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace ced::detail {

/// A saliency reaches its modality's threshold (compared in double).
inline bool reaches(float saliency, double threshold) noexcept { return static_cast<double>(saliency) >= threshold; }

/// The paper's candidate rule: some modality reaches its threshold at point p.
inline bool is_candidate(const float* const* columns, const std::vector<double>& thresholds, std::uint32_t p) {
  for (std::size_t c = 0; c < thresholds.size(); ++c)
    if (reaches(columns[c][p], thresholds[c])) return true;
  return false;
}

/// For every point of `columns` (one saliency column per modality, n points):
/// candidate[i] |= is_candidate(i) (`candidate` comes zeroed), and score[i] = the product of the
/// saliencies in modality order (float, as the paper's code multiplies), the
/// NMS's score. On up to `threads` threads; the same for any count.
void candidates_and_scores(const std::vector<const float*>& columns, const std::vector<double>& thresholds,
                           std::size_t n, unsigned threads, std::uint8_t* candidate, float* score);

}  // namespace ced::detail
