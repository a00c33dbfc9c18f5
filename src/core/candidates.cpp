// SPDX-License-Identifier: MIT
// Stage 4 of detection: candidates and the NMS score.
#include "core/candidates.hpp"

#include <algorithm>

#include "core/parallel.hpp"

namespace ced::detail {

void candidates_and_scores(const std::vector<const float*>& columns, const std::vector<double>& thresholds,
                           std::size_t n, unsigned threads, std::uint8_t* candidate, float* score) {
  parallel_for(n, threads, 1 << 14, [&](std::size_t b, std::size_t e) {
    // Modality by modality over the chunk, so that the loops vectorise.
    for (std::size_t m = 0; m < columns.size(); ++m) {
      const float* col = columns[m];
      const double t = thresholds[m];
      for (std::size_t i = b; i < e; ++i) candidate[i] |= reaches(col[i], t);
      if (m == 0)
        std::copy(col + b, col + e, score + b);
      else
        for (std::size_t i = b; i < e; ++i) score[i] *= col[i];
    }
  });
}

}  // namespace ced::detail
