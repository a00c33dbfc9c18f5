// SPDX-License-Identifier: MIT
// Private: one detection, its state shared by its stages: the grid and the
// result (detect.cpp), the saliency pass (saliency.cpp), candidates and NMS
// (detect.cpp, candidates.cpp, nms.cpp). detect() (both overloads), normals
// and scaled modalities run one.
#pragma once

#include <utility>
#include <vector>

#include "ced/detect.hpp"
#include "core/arena.hpp"
#include "core/block_partition.hpp"
#include "core/list_block.hpp"
#include "core/neighbor_block.hpp"
#include "core/nms.hpp"
#include "core/timing.hpp"

namespace ced::detail {

/// The non-template part of detection, shared by both composition paths.
class detection_context {
 public:
  detection_context(const point_cloud& cloud, const detect_params& params, std::vector<std::string> names,
                    std::vector<double> thresholds);
  ~detection_context();
  /// Runs the neighbour pass over every spatial block, in parallel, summing
  /// `sources` (one per modality), and calls `f(block, columns)`; columns[m]
  /// is modality m's saliency column, to be written at the block's points.
  void compute_saliency(const std::vector<channel_source>& sources,
                        const std::function<void(const block_view&, float* const*)>& f);
  /// The next compute_saliency() makes only neighbour counts and sums, not
  /// lists: for modalities that all sum channels (block_view::operator[]
  /// then throws std::logic_error). The NMS queries its neighbourhoods
  /// anew. Used by saliency_of, whose pass has no candidates.
  void without_neighbor_lists();
  /// The next compute_saliency() also sums the positions' second moments
  /// (neighbor_block::set_moments: position_sums(k)[3..9)). Only on the
  /// grid's pass (a fixed radius, search = grid) and with sources that carry
  /// no channels; std::logic_error otherwise.
  void with_position_moments();
  /// Candidates, products and NMS; moves the result out.
  detection_result finish();
  /// Under knn and adaptive neighbourhoods, the saliency of modality m is
  /// multiplied by radius / r_i at each point i when its threshold is
  /// proportional to the radius: `thresholds_at_twice` are the modalities'
  /// thresholds with the radius doubled, and m qualifies when its threshold
  /// doubles with it (xyz: ratio × radius). Its test s ≥ t·radius is then
  /// s ≥ t·r_i. Without this call, saliencies are left as measured.
  void scale_with_radius(const std::vector<double>& thresholds_at_twice);
  /// Adds the time the modalities took to bind (their channels; a scaled
  /// modality's own neighbour pass) to the saliency stage.
  void add_bind_ms(double ms);

 private:
  struct impl;
  std::unique_ptr<impl> m_impl;
};

struct detection_context::impl {
  const point_cloud& cloud;
  detect_params params;
  detection_result result;
  block_partition blocks;
  std::vector<candidate_hits> hits;
  chunk_arena hit_memory;  // the hits' arrays
  bool keep_lists = true;  // see detection_context::without_neighbor_lists
  bool moments = false;    // see detection_context::with_position_moments
  // Modalities whose threshold is proportional to the radius (they measure
  // distances): under knn and adaptive their saliency is taken per unit of
  // each point's own radius (scale_with_radius).
  std::vector<std::uint8_t> per_radius;

  impl(const point_cloud& c, const detect_params& p, block_partition&& b) : cloud(c), params(p), blocks(std::move(b)) {}
};

}  // namespace ced::detail
