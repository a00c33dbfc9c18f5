// SPDX-License-Identifier: MIT
// Private to src/tiled: the work directory: claimed, emptied, parts kept between tries (work_dir.cpp).
#pragma once

#include <filesystem>
#include <string>

namespace ced::tiled_detail {

namespace fs = std::filesystem;

/// Makes `dir` ced's: creates it (marker "created yes"), or marks an empty
/// directory (marker "created no"), or accepts one that has ced's marker.
/// Anything else is refused, with or without `resume`.
void claim_work_dir(const std::string& work_dir);
/// Empties ced's cache and parts of a work directory (a run stopped before
/// its plan was written: its cache is incomplete).
void clear_tiles(const fs::path& dir);
/// Before a second try with a longer reach: empties the cache and keeps
/// the parts of the tiles that passed (parts/ becomes kept/; when it
/// cannot, they are removed).
void keep_parts(const fs::path& dir);
/// Removes the kept parts (keep_parts()) and their directory.
void clear_kept(const fs::path& dir);

}  // namespace ced::tiled_detail
