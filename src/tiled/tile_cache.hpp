// SPDX-License-Identifier: MIT
// Private to src/tiled: passes 1 and 2: the plan and the tile cache (tile_cache.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "ced/tiled.hpp"

namespace ced::tiled_detail {

namespace fs = std::filesystem;

/// Passes 1 and 2 of a run without a plan yet: the plan and the tile cache
/// in `dir`, then plan.json. `announced`: the plan was reported already.
tile_plan build_cache(const tiled_request& request, const tiled_run_options& o, const fs::path& dir, bool& announced);
std::string cache_file(const std::string& work_dir, std::uint64_t id);
/// Tile id's points from the cache.
tile_points load_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id);

}  // namespace ced::tiled_detail
