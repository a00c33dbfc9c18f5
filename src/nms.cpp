// SPDX-License-Identifier: MIT
#include "ced/nms.hpp"

#include <stdexcept>

#include "ced/detail/parallel.hpp"

namespace ced {

std::vector<float> saliency_product(const std::vector<std::vector<float>>& saliency) {
  if (saliency.empty()) return {};
  std::vector<float> p = saliency[0];
  for (std::size_t m = 1; m < saliency.size(); ++m) {
    if (saliency[m].size() != p.size()) throw std::invalid_argument("saliency columns differ in length");
    for (std::size_t i = 0; i < p.size(); ++i) p[i] *= saliency[m][i];
  }
  return p;
}

namespace detail {
void nms_block_by_query(const neighbor_index& index, const float* xyz, const std::uint32_t* candidates,
                        std::size_t count, const float* score, double radius, std::uint8_t* keep,
                        std::vector<std::uint32_t>& gathered) {
  if (count == 0) return;
  float lo[3], hi[3];
  padded_bounds(xyz, candidates, count, radius, lo, hi);
  index.box_search(lo, hi, gathered);
  const float r2 = squared_radius(radius);
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint32_t i = candidates[k];
    const float si = score[i];
    const float* pi = xyz + 3 * std::size_t(i);
    bool maximum = true;
    for (std::uint32_t j : gathered)
      if (score[j] > si && squared_distance(xyz + 3 * std::size_t(j), pi) < r2) {
        maximum = false;
        break;
      }
    keep[i] = maximum;
  }
}
}  // namespace detail

std::vector<std::uint32_t> non_maximum_suppression(const neighbor_index& index, const block_partition& blocks,
                                                   const float* xyz, const std::vector<float>& score,
                                                   const std::vector<std::uint8_t>& candidate, double radius,
                                                   unsigned threads) {
  const std::size_t n = score.size();
  if (candidate.size() != n || index.size() != n) throw std::invalid_argument("non_maximum_suppression: sizes differ");
  std::vector<std::uint8_t> keep(n, 0);
  detail::parallel_for(blocks.block_count(), threads, 16, [&](std::size_t b0, std::size_t b1) {
    std::vector<std::uint32_t> cand, gathered;
    for (std::size_t b = b0; b < b1; ++b) {
      const std::uint32_t* pts = blocks.block_points(b);
      cand.clear();
      for (std::size_t k = 0; k < blocks.block_size(b); ++k)
        if (candidate[pts[k]]) cand.push_back(pts[k]);
      detail::nms_block_by_query(index, xyz, cand.data(), cand.size(), score.data(), radius, keep.data(), gathered);
    }
  });
  return detail::compact_flags(keep);
}

namespace detail {
std::vector<std::uint32_t> compact_flags(const std::vector<std::uint8_t>& flags) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}
}  // namespace detail

}  // namespace ced
