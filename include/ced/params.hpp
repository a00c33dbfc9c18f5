// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <string_view>

namespace ced {

/// Which points make up a point's neighbourhood (docs/ALGORITHM.md,
/// "Neighbourhoods").
enum class neighborhood_kind : std::uint8_t {
  radius,    ///< every point within detect_params::radius (the paper's)
  knn,       ///< the k nearest points, the point itself included
  adaptive,  ///< every point within scale × (distance to the k-th nearest), clamped
};

/// A neighbourhood: the fixed ball (default), `knn:K` or
/// `adaptive:K[,scale=α][,min=r0][,max=r1]` (parse_neighborhood()).
///
/// - radius: N(i) = { j : |p_j − p_i|² < r² }, r = detect_params::radius.
/// - knn: N(i) = the k points nearest to p_i (p_i included), by squared
///   distance in float, ties to the smaller index; the point's own radius
///   r_i is the distance to the k-th of them.
/// - adaptive: r_i = clamp(scale × d_k(i), min_radius, max_radius), d_k(i)
///   the distance to the k-th nearest point (p_i is the first; infinite in a
///   cloud of fewer than k points, which only a finite max_radius allows),
///   and N(i) = { j : |p_j − p_i|² < r_i² } ∪ { i }.
///
/// Under knn and adaptive, sums of positions are measured in units of the
/// point's own radius (times detect_params::radius, so that they stay in
/// metres at that radius): the geometry test d ≥ t_g·r becomes
/// d ≥ t_g·r_i, and a ratio stays a ratio. The NMS radius stays fixed.
struct neighborhood_spec {
  neighborhood_kind kind = neighborhood_kind::radius;
  /// K: 1 .. 65,535 for knn and adaptive; unused by radius.
  std::uint32_t k = 0;
  /// α > 0 (adaptive).
  double scale = 1.0;
  /// r0 ≥ 0 and r1 ≥ r0 (adaptive), metres; r1 may be +infinity.
  double min_radius = 0.0;
  double max_radius = std::numeric_limits<double>::infinity();
  /// knn and adaptive: the NMS ball of point i has radius nms_radius × r_i /
  /// radius (a ratio of its own radius, as the thresholds), not nms_radius
  /// (option `nms=own`; default `nms=fixed`). Refinement keeps nms_radius.
  bool nms_own = false;
  /// knn and adaptive: a bound on how far any neighbourhood reaches, metres
  /// (option `reach=R`; default +infinity, none). Tiled runs take it for
  /// their halo and check it: a tile whose points reach farther (the K-th
  /// nearest, or an adaptive radius) stops with an error naming the
  /// distance needed. Without it (knn:K, adaptive without max), tiled runs
  /// take a reach of their own and grow it (estimated_reach(),
  /// grown_reach()). Whole runs do not use it.
  double reach = std::numeric_limits<double>::infinity();

  bool fixed() const noexcept { return kind == neighborhood_kind::radius; }
};

/// Parses "radius", "knn:K[,nms=own][,reach=R]" or
/// "adaptive:K[,scale=α][,min=r0][,max=r1][,nms=own][,reach=R]";
/// throws std::invalid_argument naming the bad part.
neighborhood_spec parse_neighborhood(const std::string& text);
/// The spec in the form parse_neighborhood() reads ("knn:16", ...).
std::string to_string(const neighborhood_spec& n);
/// Throws std::invalid_argument naming the parameter when K, scale, min,
/// max or reach is out of range (K < 1 or > 65,535, scale ≤ 0, min > max,
/// reach ≤ 0, NaN, ...).
void validate(const neighborhood_spec& n);

/// How fixed-radius neighbours are gathered. Both give the same
/// neighbourhoods; the sums may differ in their last bits.
enum class search_kind : std::uint8_t {
  grid,  ///< ced's block grid (default, the fastest)
  cgal,  ///< CGAL's Kd_tree, one ball query per point: the reference
};
/// Parses "grid" or "cgal"; throws std::invalid_argument ("must be grid or
/// cgal, got '...'") otherwise.
search_kind parse_search_kind(std::string_view text);
/// "grid" or "cgal".
const char* to_string(search_kind s) noexcept;

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
  /// to the smaller index; still ascending by index. A refined keypoint ranks
  /// by the score of the maximum it stands for (the highest of the NMS
  /// maxima refined onto it), not by its own. The same keypoints in tiled
  /// runs (the merge selects them from all tiles). See
  /// detection_result::rank_score and strongest().
  std::size_t max_keypoints = 0;
  /// At most this share of the candidates become keypoints (0: no limit, the
  /// default; at most 1): the ceil(keypoint_share x C) strongest, C the number
  /// of candidate points, ranked as max_keypoints ranks them (with both, the
  /// smaller limit holds; see keypoint_limit()). The candidates hardly change
  /// under noise while the NMS's maxima multiply, so this holds a count steady
  /// on noisy scans (robust3d: 0.01, docs/EVALUATION.md). Exact in tiled runs.
  double keypoint_share = 0;
  /// Which points make up a neighbourhood (default: the ball of `radius`).
  neighborhood_spec neighborhood;
  /// How neighbours are gathered (grid by default; knn and adaptive always
  /// use CGAL's spatial search).
  search_kind search = search_kind::grid;
  /// Optional: called with the fraction of the saliency stage done (0..1),
  /// from any worker thread, never concurrently; keep it cheap. It may throw
  /// to cancel the detection: detect() then stops its workers and rethrows
  /// the exception (how the Python module answers Ctrl-C).
  std::function<void(double)> progress;
};

/// The number of worker threads a request of `threads` means (0 = every core
/// this process may run on: its CPU affinity, as taskset and mpirun set it).
unsigned resolve_threads(unsigned threads) noexcept;

/// Throws std::invalid_argument naming the parameter when one is out of range
/// (radius ≤ 0, NaN or infinite, ...).
void validate(const detect_params& params);

}  // namespace ced
