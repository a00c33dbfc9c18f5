// SPDX-License-Identifier: MIT
// Private to src/tiled: passes 1 and 2: the plan and the tile cache (tile_cache.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "ced/tiled.hpp"

namespace ced::tiled_detail {

namespace fs = std::filesystem;

/// Passes 1 and 2 of a run without a plan yet: the plan and the tile cache
/// in `dir`, then plan.json. `announced`: the plan was reported already.
tile_plan build_cache(const tiled_request& request, const tiled_run_options& o, const fs::path& dir, bool& announced);
/// build_cache() by passes (plan_grid()), whatever the header says.
tile_plan build_cache_by_passes(const tiled_request& request, const tiled_run_options& o, const fs::path& dir,
                                bool& announced, const std::string& bytes_hash);
/// The plan from the headers for a cache filled in `shares` shares
/// (fill_cache_share()); none when the input cannot be planned so (no
/// header plan, or no runs), or shares < 2.
std::optional<tile_plan> plan_for_shares(const tiled_request& request, unsigned shares);
std::string cache_file(const std::string& work_dir, std::uint64_t id);
/// The piece of share `share` of tile id's cache (tile_plan::cache_shares > 1).
std::string cache_piece(const std::string& work_dir, std::uint64_t id, unsigned share);
/// Removes tile id's cache file, or its pieces.
void remove_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id);
/// Tile id's points from the cache.
tile_points load_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id);

}  // namespace ced::tiled_detail
