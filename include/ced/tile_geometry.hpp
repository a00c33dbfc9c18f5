// SPDX-License-Identifier: MIT
// The geometry of exact tiles, on an in-memory cloud (ced::core; runs over
// files larger than memory are ced/tiled.hpp's). Exact tiles: a cloud cut
// into a regular grid of tiles, each detected on its own (core + halo),
// gives index for index the keypoints of the whole cloud.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/detect.hpp"
#include "ced/modality.hpp"
#include "ced/params.hpp"

namespace ced {

/// A regular grid of tiles over positions (the cloud's frame: relative to its
/// origin). Tile t owns the half-open core box
/// [lo + c·size, lo + (c+1)·size) per axis (c its grid coordinates; the last
/// tile of an axis also owns what lies beyond it); it reads its core grown by
/// `halo` on every side.
///
/// Why a tile is exact: a point's saliency depends on its neighbours within
/// the radius and on the order in which their values are summed, and that
/// order depends only on the spatial block of the point (a cell of the grid
/// of side block_scale·radius at whole multiples of that side) and on the
/// cells within one radius of it. A keypoint decision depends on the
/// saliencies within the NMS radius. So a tile that holds every point within
/// nms_radius + block side + radius of its core reproduces bitwise the whole
/// cloud's saliencies and decisions for its core (exact_halo()).
struct tile_grid {
  std::array<double, 3> lo{0.0, 0.0, 0.0};  ///< corner of tile (0, 0, 0)
  double size = 1.0;                        ///< edge of a core box (> 0)
  std::array<std::uint32_t, 3> dims{1, 1, 1};
  double halo = 0.0;

  /// Number of tiles, dims[0]·dims[1]·dims[2]; tile ids are x-fastest.
  std::uint64_t count() const noexcept { return std::uint64_t(dims[0]) * dims[1] * dims[2]; }
  std::array<std::uint32_t, 3> coords(std::uint64_t t) const noexcept;
  /// The id of the tile at grid coordinates (x, y, z): coords()' inverse.
  std::uint64_t tile_id(std::uint64_t x, std::uint64_t y, std::uint64_t z) const noexcept {
    return (z * dims[1] + y) * dims[0] + x;
  }
  /// The tile whose core holds position p.
  std::uint64_t tile_of(const float p[3]) const noexcept;
  /// The tiles whose core grown by the halo holds p (p's own among them),
  /// ascending; `out` is replaced.
  void tiles_near(const float p[3], std::vector<std::uint64_t>& out) const;
  /// Per axis: the grid coordinate of p's own tile (`own`) and the range
  /// [lo, hi] of those whose core grown by the halo holds p. What tile_of()
  /// and tiles_near() are made of.
  void locate(const float p[3], std::int64_t own[3], std::int64_t lo_c[3], std::int64_t hi_c[3]) const noexcept;
  /// locate() for n points (xyz, 3 floats each) at once: 9 values a point
  /// to cells (own x, y, z, then lo_c and hi_c), the same numbers; a point
  /// that is not finite gets −1 as its lo_c x (its other values are
  /// unspecified). Without branches; in vectors of 8 points on AVX-512 and
  /// of 4 on AVX2 (the same roundings), as the neighbour pass chooses its
  /// build (detail::kernel_isa()): what a tiled run's cache pass spends
  /// much of its time on.
  void locate_many(const float* xyz, std::size_t n, std::int32_t* cells) const noexcept;
  /// tile_of() for n points (xyz, 3 floats each) at once, to out[0..n): the
  /// same ids, built like locate_many().
  void tile_of_many(const float* xyz, std::size_t n, std::uint64_t* out) const noexcept;
  /// The core box of tile t, {x0, y0, z0, x1, y1, z1} (half-open).
  std::array<double, 6> core_box(std::uint64_t t) const noexcept;
  /// Whether tile ids name the same core boxes in `other` (the halo aside).
  bool same_cores(const tile_grid& other) const noexcept {
    return lo == other.lo && size == other.size && dims == other.dims;
  }
};

/// The halo that makes tiles exact under `params`: nms_radius (twice with
/// `refine`) + block side (block_scale · radius) + the neighbourhood's reach
/// (the radius; max(r1, r1 / scale) for adaptive:K,max=r1), with a margin
/// for float rounding of coordinates up to `max_abs_coordinate` (positions,
/// the cloud's frame). Throws std::invalid_argument for knn, or adaptive
/// without max, unless they give reach= (their reach depends on the data:
/// tiled runs set one, estimated_reach()).
double exact_halo(const detect_params& params, double max_abs_coordinate = 0.0);

/// Whether `n` reaches as far as the data make it: knn:K, or adaptive:K
/// without max, with no reach= given. A tiled run then takes a reach of its
/// own (estimated_reach()) and grows it when a tile finds it too short
/// (grown_reach()), so that tiles stay exact.
bool unbounded_reach(const neighborhood_spec& n) noexcept;

/// A first reach for the neighbourhood of `params` over `points` finite
/// points in the box [lo, hi]: three times the distance to the K-th nearest point
/// at the mean density of a surface as large as the box's largest face (a
/// line: its longest edge), for adaptive the radius and K-th distance that
/// gives (at least min=), rounded up to two significant digits. A guess: a
/// tile whose points reach farther says how far (tile_reach_error::needed).
double estimated_reach(const detect_params& params, const double lo[3], const double hi[3], std::uint64_t points);

/// The reach to try after `tried` proved too short, given the farthest
/// reach the tiles measured (the largest finite tile_reach_error::needed):
/// that distance rounded up to two significant digits; at least four times
/// `tried` when it is no farther or a tile could not measure it
/// (`unmeasured`: a tile of fewer than K points).
double grown_reach(double tried, double needed, bool unmeasured = false) noexcept;

/// Tiles of edge `size` covering the positions in the box [lo, hi], with the
/// exact halo for `params`. Throws std::invalid_argument when `size` is not
/// positive and finite, or when the grid would have more than 2^24 tiles.
tile_grid make_tile_grid(const double lo[3], const double hi[3], double size, const detect_params& params);

/// One tile of an in-memory cloud: its points (core and halo, in the cloud's
/// order, the same origin), each field's whole_range and whole_sample set
/// from the whole cloud, and index[i], the cloud's index of point i.
struct cloud_tile {
  point_cloud cloud;
  std::vector<std::uint32_t> index;
};

/// The min and max of each field of `cloud` (what cloud_tile sets as whole_range).
std::vector<value_range> field_ranges(const point_cloud& cloud);

/// Cuts tile t out of `cloud`. `ranges` is field_ranges(cloud) (computed
/// when empty).
cloud_tile extract_tile(const point_cloud& cloud, const tile_grid& grid, std::uint64_t t,
                        const std::vector<value_range>& ranges = {});

/// The keypoints of tile t among those of a detection on its points: those in
/// its core, as indices into the tile's cloud, ascending.
std::vector<std::uint32_t> core_keypoints(const tile_grid& grid, std::uint64_t t, const point_cloud& tile_cloud,
                                          const detection_result& result);

/// Whether tiles under `params` rest on the neighbourhood's reach= (knn:K,
/// or adaptive without max, given reach=): then each tile checks it.
bool tiles_check_reach(const detect_params& params) noexcept;

/// A tile whose points reach beyond the neighbourhood's reach= (see
/// check_tile_reach): a rerun with the same parameters fails again.
struct tile_reach_error : std::runtime_error {
  tile_reach_error(const std::string& what, double needed_reach) : std::runtime_error(what), needed(needed_reach) {}
  /// The farthest any point of the tile's core reaches among the tile's
  /// points: at least as far as it reaches in the whole cloud (the tile
  /// holds part of it), so a reach past the largest over every tile makes
  /// every tile pass. +infinity when the tile holds fewer than K points.
  double needed;
};

/// What the tiles that found a reach short measured, gathered over them
/// (tile_reach_error::needed): the next reach is grown_reach(tried,
/// needed, unmeasured).
struct reach_shortfall {
  double needed = 0;        ///< the largest finite measure
  bool unmeasured = false;  ///< a tile held fewer than K points
  bool any = false;         ///< some tile found the reach short
  std::size_t tiles = 0;    ///< how many
  void add(const tile_reach_error& e) noexcept { add(e.needed); }
  /// A tile that measured `tile_needed` (+infinity: nothing measured).
  void add(double tile_needed) noexcept {
    any = true;
    ++tiles;
    if (tile_needed <= std::numeric_limits<double>::max())
      needed = std::max(needed, tile_needed);
    else
      unmeasured = true;
  }
};

/// Under tiles_check_reach(params): throws tile_reach_error, naming the
/// tile, the point and the distance needed, unless every point that tile
/// t's core depends on (its core, and the points within the NMS reach of
/// it) reaches no farther than reach= (its K-th nearest and, for adaptive,
/// its own radius), the bound the tile's halo assumed. `result` is the
/// detection on the tile's points (nullptr: before it, when the tile holds
/// fewer than K points). Passing, the tile's results for its core are the
/// whole cloud's. No-op for other neighbourhoods.
/// `extra`: how much farther the checked points reach (tile_check_extra():
/// normals estimated over each neighbour's own neighbourhood).
void check_tile_reach(const tile_grid& grid, std::uint64_t t, const point_cloud& tile_cloud,
                      const detection_result* result, const detect_params& params, double extra = 0);

/// Detects keypoints tile by tile (tiles of edge `tile_size`, one after the
/// other, each with `params.threads`) and returns the indices into `cloud`,
/// ascending: exactly detect(cloud, params, modalities).keypoints. Under a
/// neighbourhood of unbounded reach the tiles take estimated_reach(), and
/// when a tile finds it too short the short tiles are detected again with
/// grown_reach(), the others keeping their keypoints (`reach_used`, when
/// given, is the reach that passed). For
/// clouds that fit in memory (tests, and a check of the tiling); the CLI's
/// --tile-size streams files instead.
std::vector<std::uint32_t> detect_tiled(const point_cloud& cloud, const detect_params& params,
                                        const std::vector<any_modality>& modalities, double tile_size,
                                        double* reach_used = nullptr);

}  // namespace ced
