// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>

namespace ced {

/// Parameters shared by all modalities. Defaults are the paper's, for clouds
/// at about 1 cm resolution.
struct detect_params {
  /// Neighbourhood radius for the saliency (metres; 3D distance, strict <).
  double radius = 0.05;
  /// Non-maximum-suppression radius (metres; may differ from `radius`).
  double nms_radius = 0.05;
  /// Points with fewer neighbours (themselves included) get saliency 0 in
  /// every modality. 0 and 1 disable the gate.
  std::uint32_t min_neighbors = 5;
  /// Worker threads; 0 = all cores. The result does not depend on it.
  unsigned threads = 0;
  /// Side of the spatial blocks, as a multiple of the radius (a tuning knob:
  /// it changes the order of the neighbour sums, so saliencies may differ in
  /// the last bits, and only points within a rounding error of a threshold or
  /// of a neighbour's score can change; the thread count changes nothing).
  double block_scale = 6.0;
  /// Keypoint refinement (off in the paper's method; on in the robust
  /// presets). Each keypoint k of the NMS is replaced by the point of its NMS
  /// neighbourhood (within nms_radius of k, itself included) nearest to that
  /// neighbourhood's centroid weighted by the NMS score (the product of the
  /// saliencies): the peak's centre of mass rather than its noisiest point.
  /// Keypoints that land on the same point are kept once. Under noise the
  /// refined keypoints repeat far more (docs/EVALUATION.md#robust-presets).
  bool refine = false;
  /// At most this many keypoints (0: no limit, the default): the ones with
  /// the highest score, the product of their saliencies (the NMS score), ties
  /// to the smaller index; still ascending by index. A refined keypoint is
  /// ranked by its own score. The same keypoints in tiled runs (the merge
  /// selects them from all tiles). See keypoint_score() and strongest().
  std::size_t max_keypoints = 0;
  /// Optional: called with the fraction of the saliency stage done (0..1),
  /// from any worker thread, never concurrently; keep it cheap. It may throw
  /// to cancel the detection: detect() then stops its workers and rethrows
  /// the exception (how the Python module answers Ctrl-C).
  std::function<void(double)> progress;
};

/// The number of worker threads a request of `threads` means (0 = all cores).
unsigned resolve_threads(unsigned threads) noexcept;

/// Throws std::invalid_argument naming the parameter when one is out of range
/// (radius ≤ 0, NaN or infinite, ...).
void validate(const detect_params& params);

}  // namespace ced
