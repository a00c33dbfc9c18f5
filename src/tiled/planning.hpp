// SPDX-License-Identifier: MIT
// Private to src/tiled: the plan, from a pass over the points or from the
// header alone, and the tiles' counts (planning.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ced/io/stream.hpp"
#include "ced/tiled.hpp"
#include "tiled/chunks.hpp"

namespace ced::tiled_detail {

/// What a pass over the points learns: counts, and each field's range over
/// the finite points (and whether every chunk had it).
struct scan_result {
  std::uint64_t file_points = 0, finite_points = 0;
  std::map<std::string, std::pair<value_range, bool>> ranges;
  std::size_t chunks = 0;
};
/// Adds chunk `c` to `s`.
void scan_chunk(const point_cloud& c, scan_result& s);
/// Each of `fields` that `scan` saw gets the range it saw.
void set_ranges(std::vector<plan_field>& fields, const scan_result& scan);
/// True for the names of LAS's one-bit flag fields (io::las_flag_fields()).
bool is_las_flag(const std::string& name);

/// The plan a LAS or LAZ file's header gives, without a pass over the
/// points: origin and grid from the header's bounds (grown by 1 %), every
/// field of the point format (each flag among them), the modalities'
/// tile_fields; no ranges, no tiles, and counts as the header declares.
/// None when the header's bounds are not finite and ordered (or not LAS),
/// or every field would go through the cache (no tile_fields) and one of
/// them is a flag, whose presence only a pass decides. What the file's
/// points make of it (the origin a whole read takes, the flags set) is for
/// the caller to check after a pass (build_cache).
std::optional<tile_plan> plan_from_header(const tiled_request& request, io::point_stream& s);

/// The sample of every field whose whole-cloud statistics a modality of
/// the request needs (plan_field::sample), from a pass that reads only those
/// fields; nothing when none does.
void sample_fields(tile_plan& p, const tiled_progress& progress);

/// Plans without the tiles' counts (run_tiled counts them while it fills
/// its cache; plan_tiles in a pass of its own). Leaves `s` rewound.
tile_plan plan_grid(const tiled_request& request, io::point_stream& s, const tiled_progress& progress);

/// Counts per tile, from the points of one chunk.
struct tile_counter {
  bool dense;
  std::vector<std::uint64_t> core_v, all_v;
  std::unordered_map<std::uint64_t, std::pair<std::uint64_t, std::uint64_t>> sparse;
  explicit tile_counter(std::uint64_t tiles) : dense(tiles <= (1u << 20)) {
    if (dense) {
      core_v.assign(tiles, 0);
      all_v.assign(tiles, 0);
    }
  }
  void core(std::uint64_t t) { dense ? ++core_v[t] : ++sparse[t].first; }
  void near(std::uint64_t t) { dense ? ++all_v[t] : ++sparse[t].second; }
  /// Point q (finite) of grid g: its own tile, and every tile it is near
  /// (`near_tiles`: scratch).
  void point(const tile_grid& g, const float* q, std::vector<std::uint64_t>& near_tiles) {
    core(g.tile_of(q));
    g.tiles_near(q, near_tiles);
    for (std::uint64_t t : near_tiles) near(t);
  }
  std::vector<tile_entry> entries() const;
};

/// Points per tile (a pass over `s`, which is left rewound), and the hash
/// of every decoded point into `content` when given.
std::vector<tile_entry> count_tiles(io::point_stream& s, const tile_plan& p, const tiled_progress& progress,
                                    std::uint64_t* content);

}  // namespace ced::tiled_detail
