// SPDX-License-Identifier: MIT
// Private to src/tiled: the largest tile size whose densest tile fits in a memory limit (sizing.cpp).
#pragma once

#include "ced/io/stream.hpp"
#include "ced/tiled.hpp"

namespace ced::tiled_detail {

/// The largest tile size whose densest tile fits in the request's memory
/// limit, from a histogram of the points (one more pass over `s`). `lo`,
/// `hi`: the bounds relative to the plan's origin.
double size_for_memory(io::point_stream& s, const tile_plan& p, const double lo[3], const double hi[3],
                       const tiled_progress& progress);

}  // namespace ced::tiled_detail
