// SPDX-License-Identifier: MIT
// Clouds larger than memory: a file cut into exact tiles (ced/tile_geometry.hpp),
// planned in passes over it (or from its header or COPC index), each tile
// detected on its own (in this
// process, another one, another machine), the parts merged into exactly the
// whole-cloud result. What `ced plan`, `ced detect --tile-size`,
// `ced detect --plan --tile`, `ced merge`, `ced-mpi` and Python's
// ced.plan_tiles/detect_tile/merge_parts run.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/io.hpp"
#include "ced/params.hpp"
#include "ced/tile_geometry.hpp"

namespace ced {

/// What a tiled run detects, and how it cuts the input.
struct tiled_request {
  std::string input;
  io::read_options read;  ///< format, CSV options, the fields to read (all for keypoint clouds)
  /// radius, nms_radius, min_neighbors, block_scale, refine; threads are per tile.
  detect_params params;
  /// Modality specs ("xyz:0.2", ...); empty: ced6d when the file has colour, else ced3d.
  std::vector<std::string> modalities;
  double tile_size = 0;            ///< edge of a tile's core, > 0; or 0 with memory_limit
  std::uint64_t memory_limit = 0;  ///< bytes a tile may take (sets the tile size); 0 = none
  /// Plan by passes over the points even where the file would do without:
  /// plan_tiles() plans a COPC file from its index (tile_plan::indexed), and
  /// run_tiled() a LAS or LAZ file from its header (then one pass fills the cache).
  bool scan = false;
  /// The neighbourhood's reach= is ced's, not the caller's: knn:K, or
  /// adaptive:K without max, asked without reach= (unbounded_reach()). The
  /// plan then sets one (estimated_reach(), from the cloud's bounds and
  /// count), and run_tiled() grows it when a tile finds it too short
  /// (grown_reach()): the short tiles again, so the run stays exact. A run
  /// resumed without reach= takes the plan's. Set by the planners.
  bool reach_estimated = false;
};

/// One tile of a plan that owns points.
struct tile_entry {
  std::uint64_t id = 0;
  std::uint64_t core_points = 0;  ///< points it owns
  std::uint64_t points = 0;       ///< points it reads (core and halo)
};

/// A run of consecutive points of the input that a tile reads alone (a LAZ
/// chunk, a block of LAS records: point_stream::chunk_runs()), as the plan
/// found it: the box of its positions (relative to the plan's origin, as
/// read) and a hash of its decoded points.
struct plan_run {
  std::uint64_t first = 0, count = 0;
  std::array<float, 6> box{};  ///< x0, y0, z0, x1, y1, z1
  std::uint64_t hash = 0;
};

/// A field of the input, as every tile has it.
struct plan_field {
  std::string name;
  scalar_type type = scalar_type::float32;
  value_range range;  ///< over the whole file's finite points: each tile's whole_range
  /// Only for fields whose whole-cloud statistics a modality needs
  /// (any_modality::whole_cloud_fields()): the values at the whole file's
  /// sample points among its finite points (whole_sample_index()), each
  /// tile's whole_sample. Empty otherwise.
  std::shared_ptr<const std::vector<double>> sample;
};

/// The plan of a tiled run: the input (and a fingerprint of it), what was
/// asked, what the whole file decides (origin, fields, their ranges), and the
/// tiles. Written as JSON; every part of the run carries its digest.
struct tile_plan {
  tiled_request request;
  std::string details;  ///< "LAS 1.2, point format 3"
  std::uint64_t input_bytes = 0;
  std::string fingerprint;  ///< of the input's bytes (size and sampled blocks)
  /// Of every decoded point of the input (positions relative to `origin`,
  /// every field's values), made by plan_tiles() and checked by read_tile():
  /// any change to what a tile would read is an error. Empty in the plans of
  /// run_tiled(), which reads the input once more only to fill its cache.
  std::string content;
  std::uint64_t file_points = 0, finite_points = 0;
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  tile_grid grid;
  std::vector<plan_field> fields;
  /// The fields the tile cache and the parts carry, besides the positions:
  /// unset, all of `fields`; set (by run_tiled() when the modalities read
  /// fewer fields than the request), only these of `fields`, and the merge
  /// fetches the keypoints' whole records from the input in a last pass.
  std::optional<std::vector<std::string>> tile_fields;
  std::vector<tile_entry> tiles;  ///< ascending id
  bool streamed = true;           ///< false: the format is read whole (memory not bounded)
  /// Planned from the file's spatial index (COPC) and its header, without a
  /// pass over the points: the origin and grid come from the header's
  /// bounds, `fields` is every field the point format can give (each flag
  /// among them), only the tile_fields' ranges are known (read from their
  /// own layers alone; the others are 0..0), and the tiles are those whose
  /// core meets an index node with points, their counts estimated from the
  /// nodes' counts and boxes (read_tile() cannot check them; it checks each
  /// point against its node's box and the header's bounds instead).
  bool indexed = false;
  /// LAS, LAZ, binary PLY and PCD of finite points, planned by passes: the
  /// file's runs (point_stream::chunk_runs()) with their boxes and hashes.
  /// A tile then reads only the runs whose box meets its core and halo, and
  /// checks each one's hash (`content` is then empty: every run is read by
  /// some tile).
  std::vector<plan_run> runs;
  /// The tile cache of a run was filled in this many shares, one a process
  /// (ced-mpi's ranks: fill_cache_share()): each tile's cache file is then
  /// in as many pieces. 1 for every other plan.
  unsigned cache_shares = 1;
  /// Compressed inputs (every file LAZ or COPC) of a run with a tile cache:
  /// a hash of every byte of the input, taken when the cache was filled.
  /// A merge that needs only the keypoints' positions then checks these
  /// bytes again (the same bytes decode to the same points) instead of
  /// decoding the chunks that hold the keypoints. Empty otherwise.
  std::string bytes_hash;

  std::string to_json() const;
  /// Throws io_error naming `name` for anything malformed.
  static tile_plan from_json(const std::string& text, const std::string& name);
  /// Reads a plan file (from `ced plan` or to_json()); io_error naming it.
  static tile_plan load(const std::string& path);
  /// A short hash of to_json(): parts of one plan carry it.
  std::string digest() const;
  /// The tile entry of `id`; throws std::invalid_argument when the plan has none.
  const tile_entry& tile(std::uint64_t id) const;
};

/// Progress of a long step: what is being done, and the fraction done.
using tiled_progress = std::function<void(const std::string& step, double fraction)>;

/// Reads the input once (twice with a memory limit: once more to count points
/// per area) and plans the tiles. A file with a spatial index (COPC) is
/// planned from the index instead (tile_plan::indexed), without a pass over
/// the points, unless the request asks to `scan` or gives a memory limit, a
/// modality does not say which fields it reads, or the grid has more than
/// 2^20 tiles (such a plan lists every tile of the grid). So is a catalogue
/// of LAS, LAZ and COPC files, from their headers (and indexes), when its
/// tiles would decode at most 3 points a point: a tile decodes every file
/// without an index whose header's box its core and halo meet. Throws std::invalid_argument for a bad
/// request (tile size, limit, modalities), io_error for the input.
tile_plan plan_tiles(const tiled_request& request, const tiled_progress& progress = {});

/// Throws io_error when the input file is no longer the one planned (size or
/// fingerprint differ). The fingerprint reads the size, the first and last
/// 64 KiB and 64 blocks of 4 KiB: cheap, and blind to a change elsewhere of
/// the same size; read_tile() then checks every decoded point (`content`).
void check_plan_input(const tile_plan& plan);

/// The points a tile reads, with their indices: `index` among the file's
/// finite points, `file_index` among all its points.
struct tile_points {
  std::uint64_t tile = 0;
  point_cloud cloud;  ///< fields with whole_range set
  std::vector<std::uint64_t> index, file_index;
  /// Points decoded from the file to find these (read_tile()).
  std::uint64_t decoded = 0;
  bool indexed = false;  ///< found through the file's spatial index (COPC)
  /// Of the plan's runs (tile_plan::runs), those read: the ones near the tile.
  std::uint64_t runs_read = 0;
};

/// Reads tile `id`'s points from the input: when the plan has runs (LAS and
/// LAZ), only the runs whose box meets the tile's core and halo; else, when
/// the file has a spatial index (COPC), only the chunks of the octree nodes
/// that meet them; else two passes over the file (the first learns what the
/// whole file decides about its fields, as plan_tiles).
/// Throws io_error when the input differs from the plan's: its fingerprint,
/// its point count, its decoded content (when the plan has `content`; the
/// hash of each run read when it has runs; not checked through an index,
/// which decodes only part of the file), or the tile's counts.
tile_points read_tile(const tile_plan& plan, std::uint64_t id);

/// What one tile contributes: its core keypoints, ascending index.
struct tile_part {
  std::uint64_t tile = 0;
  std::vector<std::uint64_t> index, file_index;
  point_cloud keypoints;  ///< positions and fields of the keypoints
  std::vector<std::string> names;
  std::vector<double> thresholds;
  std::vector<std::vector<float>> saliency;  ///< [modality][keypoint]
  std::vector<float> rank;                   ///< what each keypoint ranks by (detection_result::rank_score)
  std::vector<std::uint64_t> candidates;     ///< per modality, core points at or over the threshold
  std::uint64_t any_candidates = 0;          ///< core candidates (any modality)
  double detect_ms = 0;
  std::string plan;  ///< the digest of the plan it belongs to (tile_plan::digest())
};

/// Detects one tile. `threads` as in detect_params.
tile_part detect_tile(const tile_plan& plan, const tile_points& points, unsigned threads = 0);

/// Writes a part atomically (a temporary file renamed into place), in a
/// versioned little-endian format that reads on any host. Throws
/// std::invalid_argument for a part of another plan (part.plan).
void write_part(const std::string& path, const tile_plan& plan, const tile_part& part);
/// Reads a part; throws io_error when it is malformed, of another plan, or
/// of another format version (written by another ced version).
tile_part read_part(const std::string& path, const tile_plan& plan);

/// Every tile's part merged: tile_part of the whole cloud (with a plan's
/// tile_fields, the keypoints have only those: merge_part_files() and
/// run_tiled() fetch the whole records from the input). Throws io_error
/// naming the missing tiles when a tile that owns points has no part, for a
/// tile given twice, and for a part that is not of this plan or not whole
/// (its digest, its arrays' sizes, indices out of range, out of order,
/// repeated, or keypoints outside the tile's core).
tile_part merge_parts(const tile_plan& plan, std::vector<tile_part> parts);

/// A merge handed over a piece at a time, so that no more than a chunk of
/// the keypoints is held: begin(totals, keypoints) first (totals: the
/// merged part without keypoints: names, thresholds, candidate counts,
/// detection time), then chunk(part) with the keypoints in ascending index,
/// chunk after chunk.
struct merge_sink {
  std::function<void(const tile_part& totals, std::uint64_t keypoints)> begin;
  std::function<void(const tile_part& chunk)> chunk;
  /// Whether chunk() uses the keypoints' fields. When false and the parts
  /// carry only the tile fields, the merge reads no field of the input, only
  /// the keypoints' positions (still checked against the input), and the
  /// chunks' keypoints have no fields: a LAZ 1.4 or COPC input then decodes
  /// only its position layers.
  bool records = true;
};

/// merge_parts() of part files (write_part), streamed into `sink`: a k-way
/// merge that holds about `memory` bytes, however many keypoints there are.
/// The same checks and errors as read_part() and merge_parts(). With a
/// plan's tile_fields, each chunk's keypoints get every field of the input
/// by one more pass over it (io_error when it changed since the plan).
void merge_part_files(const tile_plan& plan, const std::vector<std::string>& paths, const merge_sink& sink,
                      std::size_t memory = std::size_t(64) << 20);

/// Wall time of a run_tiled(): the plan and cache (passes over the input),
/// the tiles, the merge, in milliseconds.
struct tiled_times {
  double plan_ms = 0, tiles_ms = 0, merge_ms = 0;
};

/// The whole run in one process: plan, an on-disk tile cache in `work_dir`
/// (one more pass over the input; LAS and LAZ are planned from their header
/// and that pass alone, see docs/SCALE.md), the tiles one after the other,
/// the merge. Each finished tile's part is kept in `work_dir` (a manifest):
/// with `resume`, a run of the same request that was stopped redoes only
/// the tiles without a part. `tile_done(done, total)` after each tile.
///
/// The work directory is ced's only when ced made it: a new directory, or
/// an empty one, gets a marker file (work_dir_marker) and is then ced's to
/// fill and empty. A directory that holds anything without that marker is
/// refused (work_dir_error), with or without `resume`. When the run
/// succeeds, remove_work_dir() removes ced's own files from it, and the
/// directory itself only if ced created it.
struct tiled_run_options {
  std::string work_dir;
  bool resume = false;
  unsigned threads = 0;
  tiled_progress progress;
  /// Once the plan is known (made or, with resume, read), before the tiles.
  std::function<void(const tile_plan&)> planned;
  std::function<void(std::size_t done, std::size_t total, double elapsed_ms)> tile_done;
  /// When ced's own reach (tiled_request::reach_estimated) proved too short
  /// and the tiles it was short for are detected again (the others keep
  /// their parts): the reach tried, the one the tiles measured (+infinity
  /// when a tile held fewer than K points), the next, and how many tiles.
  std::function<void(double tried, double needed, double next, std::size_t tiles)> reach_grown;
  /// Filled by run_tiled when set.
  struct tiled_times* times = nullptr;
  /// When set, the merge streams into it (merge_part_files) and run_tiled
  /// returns the totals only (no keypoints): memory then stays bounded by
  /// the tiles, not by the number of keypoints.
  const merge_sink* sink = nullptr;
  /// Leave the work directory for the caller to remove once its outputs are
  /// committed: an output that fails to be written can then be redone with
  /// resume, from the parts, without detecting a tile again.
  bool keep_work_dir = false;
};
tile_part run_tiled(const tiled_request& request, const tiled_run_options& options, tile_plan* plan_out = nullptr);

/// run_tiled() in three steps, for runs that share the tiles between
/// processes (ced-mpi; the work directory on storage they all see):
/// the plan and the tile cache (or, with resume, the plan found there) ...
tile_plan prepare_tiled(const tiled_request& request, const tiled_run_options& options);
/// prepare_tiled() with its pass over the input shared between processes
/// (ced-mpi's ranks, the work directory on storage they all see), for an
/// input planned from its headers (LAS, LAZ, COPC, or a catalogue of them):
/// no process reads the whole input. In three steps:
/// begin_cache_shares() in one process claims the work directory. When the
/// plan can come from the headers, it returns that plan as an opaque text
/// for the others (the `begun` of the steps below). Otherwise it returns ""
/// with `plan` made: a run to resume, an input that needs passes (then
/// prepare_tiled() has filled the cache here), or `shares` < 2 ...
std::string begin_cache_shares(const tiled_request& request, const tiled_run_options& options, unsigned shares,
                               tile_plan& plan);
/// ... fill_cache_share() in each process, `share` its number below the
/// shares: a block of the input's runs (LAS records, LAZ chunks) of about
/// the points of the others, into its own pieces of the tile cache (the
/// blocks follow the input's order, so the pieces in share order hold a
/// tile's points in index order, whatever the number of shares). Returns
/// what the share learnt (counts per tile, bounds, ranges, the LAS flags
/// its points set) for the last step ...
std::string fill_cache_share(const std::string& begun, unsigned share, const tiled_run_options& options);
/// ... finish_cache_shares() in the first process, with every share's
/// report in share order: the plan, written to the work directory (the one
/// a single process makes from the headers, but for cache_shares). When the
/// points belie the headers (a point outside their bounds, a tile field
/// that is a flag no point sets, a count that differs), the cache goes and
/// this process plans and fills it by passes, as prepare_tiled() does.
tile_plan finish_cache_shares(const std::string& begun, const std::vector<std::string>& learnt,
                              const tiled_run_options& options);
/// ... the part of one tile, detected from the cache and kept in the work
/// directory (or read from there when it is already) ...
tile_part detect_cached_tile(const tile_plan& plan, const std::string& work_dir, std::uint64_t id, unsigned threads = 0,
                             bool* was_done = nullptr);
/// ... when some tiles found ced's own reach (reach_estimated) short (their
/// detect_cached_tile() threw tile_reach_error, gathered in `shortfall`),
/// the plan of the next try: the reach grown (grown_reach(); reach_grown is
/// called), the cache filled again, and the parts of the tiles that passed
/// taken over, so that only the short tiles are left to detect. Throws
/// std::invalid_argument when the plan's reach is the caller's ...
tile_plan grow_tiled_reach(const tile_plan& plan, const reach_shortfall& shortfall, const tiled_run_options& options);
/// ... every tile's part from the work directory merged (into `sink` when
/// given: then the totals only are returned, as run_tiled); the directory is
/// then removed, unless `keep_work_dir`.
tile_part finish_tiled(const tile_plan& plan, const std::string& work_dir, const merge_sink* sink = nullptr,
                       bool keep_work_dir = false);

/// A work directory that ced may not use (it holds files ced did not make,
/// is not a directory, or its parent does not exist).
struct work_dir_error : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// The file that marks a directory as a tiled run's work directory.
constexpr const char* work_dir_marker = ".ced-work-dir";

/// Removes what a tiled run put in `work_dir` (its marker, plan, tile cache
/// and parts, by their names), and the directory itself when ced created it
/// and it is then empty. Anything else stays. A directory without ced's
/// marker is left alone. Never throws.
void remove_work_dir(const std::string& work_dir) noexcept;

}  // namespace ced
