// SPDX-License-Identifier: MIT
// Private: the state of one detection, shared by its stages (detect.cpp,
// saliency.cpp).
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

struct detection_context::impl {
  const point_cloud& cloud;
  detect_params params;
  detection_result result;
  block_partition blocks;
  std::vector<candidate_hits> hits;
  chunk_arena hit_memory;  // the hits' arrays
  bool keep_lists = true;  // see detection_context::without_neighbor_lists
  // Modalities whose threshold is proportional to the radius (they measure
  // distances): under knn and adaptive their saliency is taken per unit of
  // each point's own radius (scale_with_radius).
  std::vector<std::uint8_t> per_radius;

  impl(const point_cloud& c, const detect_params& p, block_partition&& b) : cloud(c), params(p), blocks(std::move(b)) {}
};

}  // namespace ced::detail
