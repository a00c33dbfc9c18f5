// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <tuple>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/modality.hpp"
#include "ced/params.hpp"

namespace ced {

/// Wall-clock time of each stage, in milliseconds.
struct stage_times {
  double index_ms = 0;     ///< spatial blocks (the grid that neighbours are gathered from)
  double saliency_ms = 0;  ///< neighbourhoods and all modalities' saliencies
  double nms_ms = 0;       ///< candidates and multi-modal non-maximum suppression
  double total_ms() const noexcept { return index_ms + saliency_ms + nms_ms; }
};

/// Everything a caller needs to see why a point was (not) chosen.
struct detection_result {
  /// Keypoint indices into the input cloud, ascending.
  std::vector<std::uint32_t> keypoints;
  /// What each keypoint ranks by for max_keypoints and keypoint_share (see
  /// strongest()), aligned with `keypoints`: its score (keypoint_score()),
  /// or with refinement the highest score of the NMS maxima refined onto it.
  std::vector<float> rank_score;
  /// One entry per modality, in the order given.
  std::vector<std::string> names;
  /// Absolute thresholds (xyz: ratio × radius).
  std::vector<double> thresholds;
  /// saliency[m][i]: saliency of point i in modality m (0 when point i has
  /// fewer than min_neighbors neighbours).
  std::vector<std::vector<float>> saliency;
  /// candidate[i] != 0 when some modality reaches its threshold at point i.
  std::vector<std::uint8_t> candidate;
  /// Number of neighbours of each point within the radius (itself included).
  std::vector<std::uint32_t> neighbor_count;
  /// Each point's own radius under a knn or adaptive neighbourhood (the
  /// distance to its k-th nearest point, or its clamped adaptive radius);
  /// empty for the fixed radius.
  std::vector<float> point_radius;
  stage_times times;
};

/// Detects keypoints with modalities chosen at run time (CLI, config).
/// Throws std::invalid_argument for bad parameters, a non-finite coordinate,
/// an empty modality list, or a modality whose fields the cloud lacks.
/// Deterministic: the same result for any `params.threads`.
detection_result detect(const point_cloud& cloud, const detect_params& params,
                        const std::vector<any_modality>& modalities);

/// The NMS score of point i: the product of its saliencies over the
/// modalities, in float, in modality order (as detection ranks points).
float keypoint_score(const detection_result& result, std::uint32_t i) noexcept;

/// The `n` strongest of `keypoints` (scores[q] is the score of keypoints[q]):
/// highest score first, ties to the smaller index, a NaN score lowest;
/// returned ascending by index. All of them when n is 0 or at least their
/// number. What detect_params::max_keypoints keeps, and what a tiled merge
/// keeps from all tiles.
std::vector<std::uint32_t> strongest(const std::vector<std::uint32_t>& keypoints, const std::vector<float>& scores,
                                     std::size_t n);

/// Keeps the `n` strongest keypoints of `result` by their rank_score, as
/// strongest() chooses them, with their rank scores (all when n is 0).
void keep_strongest(detection_result& result, std::size_t n);

/// The candidates of a result: points at or over some modality's threshold.
std::size_t candidate_count(const detection_result& result) noexcept;

/// How many keypoints `params` keep of a cloud with `candidates` candidate
/// points: max_keypoints and ceil(keypoint_share x candidates), the smaller
/// of those set; 0 when neither is (no limit).
std::size_t keypoint_limit(const detect_params& params, std::uint64_t candidates) noexcept;

/// Frees the working memory that detections keep cached for the next one (at
/// most 32 MiB: the NMS's chunks, which would otherwise be page-faulted in
/// again at every detection). Thread-safe; a later detection simply starts
/// with an empty cache.
void release_cached_memory() noexcept;

namespace detail {
/// `params` with the radius (and the NMS radius) doubled: where the
/// thresholds are read that say which modalities scale with the radius under
/// knn and adaptive neighbourhoods.
inline detect_params twice_the_radius(detect_params params) noexcept {
  params.radius *= 2;
  params.nms_radius *= 2;
  return params;
}

/// The saliency pass of a detection: the modalities' channels (a source
/// each) summed over every neighbourhood in one pass, then f(block,
/// columns), which writes modality m's saliency at the block's points to
/// columns[m].
using saliency_pass = std::function<void(const std::vector<channel_source>& sources,
                                         const std::function<void(const block_view&, float* const*)>& f)>;

/// A detection whose modalities the caller binds (detect()'s template; the
/// rest is private, src/core/detection.hpp): checks the inputs, builds the
/// grid, calls bind(pass), which binds the modalities and calls pass once
/// (binding is timed with the saliency stage), then finds the candidates
/// and runs the NMS. `thresholds_at_twice`: the thresholds at
/// twice_the_radius(), under knn and adaptive neighbourhoods (empty under a
/// fixed radius).
detection_result detect_bound(const point_cloud& cloud, const detect_params& params, std::vector<std::string> names,
                              std::vector<double> thresholds, std::vector<double> thresholds_at_twice,
                              const std::function<void(const saliency_pass&)>& bind);
}  // namespace detail

/// Detects keypoints with modalities fixed at compile time, e.g.
/// `ced::detect(cloud, params, ced::xyz{0.2}, ced::rgb{0.1}, my_band{...})`.
/// Each modality's evaluator is inlined into the neighbourhood loop; there are
/// no virtual calls. Same semantics and result as the runtime overload.
template <class... M, class = std::enable_if_t<(sizeof...(M) > 0) && (is_modality_v<M> && ...)>>
detection_result detect(const point_cloud& cloud, const detect_params& params, const M&... modalities) {
  std::vector<double> at_twice;
  if (!params.neighborhood.fixed()) {
    const detect_params twice = detail::twice_the_radius(params);
    at_twice = {double(modalities.threshold(twice))...};
  }
  return detail::detect_bound(
      cloud, params, {std::string(modalities.name())...}, {double(modalities.threshold(params))...},
      std::move(at_twice), [&](const detail::saliency_pass& pass) {
        // the evaluators (and their channels) end before the NMS: less peak memory
        const auto evaluators = std::make_tuple(modalities.bind(cloud, params)...);
        const auto sources =
            std::apply([](const auto&... e) { return std::vector<channel_source>{channels_of(e)...}; }, evaluators);
        pass(sources, [&](const block_view& block, float* const* columns) {
          std::apply(
              [&](const auto&... e) {
                std::size_t m = 0;
                ((ced::evaluate_block(e, block, m, params.min_neighbors, columns[m]), ++m), ...);
              },
              evaluators);
        });
      });
}

}  // namespace ced
