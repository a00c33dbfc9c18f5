// SPDX-License-Identifier: MIT
// Tiled runs: one tile of a plan, read from the input (checked against the
// plan) and detected into its part: the keypoints of its core.
#include <chrono>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ced/detect.hpp"
#include "ced/scaled.hpp"
#include "core/ranking.hpp"
#include "tiled/chunks.hpp"
#include "tiled/fingerprint.hpp"
#include "tiled/modalities.hpp"
#include "tiled/records.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// True when p lies in tile t's core grown by the halo (the test of tiles_near()).
bool near_tile(const tile_grid& g, const std::array<std::uint32_t, 3>& c, const float* p) noexcept {
  std::int64_t own[3], c0[3], c1[3];
  g.locate(p, own, c0, c1);
  for (std::size_t k = 0; k < 3; ++k)
    if (c0[k] > std::int64_t(c[k]) || c1[k] < std::int64_t(c[k])) return false;
  return true;
}

[[noreturn]] void input_changed(const tile_plan& plan, const std::string& what) {
  throw io::io_error(plan.request.input, "the file changed since the plan was made (" + what + "): make a new plan");
}

/// A chunk of the input as the tile's records carry it (its fields must be the plan's).
field_bytes plan_fields_of(const tile_plan& plan, const point_cloud& c, const std::vector<plan_field>& tile_fields,
                           std::vector<column>& converted) {
  if (c.fields().size() != plan.fields.size())
    throw io::io_error(plan.request.input, "its fields differ from the plan's: make a new plan");
  return conform_fields(c, tile_fields, converted);
}

/// The tile's points from `records`, which must be as many as the plan
/// says, `core` of them its own.
tile_points tile_from_records(const tile_plan& plan, std::uint64_t id, const std::string& records, std::uint64_t core) {
  tile_points pts = points_from_records(plan, id, records, 0, plan.request.input);
  const tile_entry& e = plan.tile(id);
  if (plan.indexed) return pts;  // its counts are estimates
  if (core != e.core_points || pts.cloud.size() != e.points)
    input_changed(plan, "tile " + std::to_string(id) + " reads " + std::to_string(pts.cloud.size()) +
                            " points and owns " + std::to_string(core) + "; the plan says " + std::to_string(e.points) +
                            " and " + std::to_string(e.core_points));
  return pts;
}

/// The absolute box that holds tile t's core grown by its halo (with a
/// margin; a tile at the grid's edge reaches out without end, as tile_of()
/// gives it the points beyond).
void tile_region(const tile_plan& plan, std::uint64_t t, double lo[3], double hi[3]) {
  const auto core = plan.grid.core_box(t);
  const auto c = plan.grid.coords(t);
  const double grow = plan.grid.halo + 0.01 * plan.grid.size;
  constexpr double far = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < 3; ++k) {
    lo[k] = c[k] == 0 ? -far : plan.origin[k] + core[k] - grow;
    hi[k] = c[k] + 1 == plan.grid.dims[k] ? far : plan.origin[k] + core[3 + k] + grow;
  }
}

/// Throws io_error when point `index` (q, relative to the plan's origin)
/// lies outside `box` (absolute) by more than `margin`: `what` says whose box.
void check_within(const tile_plan& plan, const float* q, const double* box, double margin, std::uint64_t index,
                  const std::string& what) {
  bool inside = true;
  for (std::size_t k = 0; k < 3; ++k) {
    const double x = double(q[k]) + plan.origin[k];
    inside = inside && x >= box[k] - margin && x <= box[3 + k] + margin;
  }
  if (!inside)
    throw io::io_error(plan.request.input, "point " + std::to_string(index) + " (" +
                                               std::to_string(q[0] + plan.origin[0]) + ", " +
                                               std::to_string(q[1] + plan.origin[1]) + ", " +
                                               std::to_string(q[2] + plan.origin[2]) + ") lies outside " + what);
}

/// The tile's points from a file with a spatial index (COPC): only the index
/// nodes near the tile are read. The file's fingerprint and point count are
/// checked against the plan, and each point read against its node's box and
/// (for a plan made from the index) the header's bounds; then the tile's
/// counts, when the plan has them exactly. Its content hash needs every
/// point, so it is not checked. Empty when the file has no index.
std::optional<tile_points> read_tile_indexed(const tile_plan& plan, std::uint64_t id, io::point_stream& s) {
  // Only files whose every point is finite (LAS): a point's index is then its file index.
  if (plan.file_points != plan.finite_points) return std::nullopt;
  const auto nodes = s.index_nodes();
  if (!nodes) return std::nullopt;
  if (s.declared_points() != plan.file_points)
    input_changed(plan,
                  std::to_string(s.declared_points()) + " points; the plan says " + std::to_string(plan.file_points));
  // A plan from the index took its origin and grid from the header's bounds,
  // which the whole file's read trusts when they hold every point to 1 %.
  double header[6];
  if (plan.indexed && !s.header_box(0.005, header)) input_changed(plan, "its header's bounds are not finite");
  double lo[3], hi[3];
  tile_region(plan, id, lo, hi);
  const std::vector<std::string> names = field_names(plan);
  const auto coords = plan.grid.coords(id);
  const std::vector<plan_field> tile_fields = tile_fields_of(plan);
  const std::size_t rs = record_size(plan);
  const double margin = io::point_stream::index_margin(*nodes);
  std::vector<column> converted;
  std::string records;
  std::uint64_t core = 0, decoded = 0;
  point_cloud c;
  for (const io::point_stream::index_node& n : io::point_stream::nodes_within(*nodes, lo, hi)) {
    s.read_run(n.run, names, plan.origin, c);
    decoded += c.size();
    const field_bytes fields = plan_fields_of(plan, c, tile_fields, converted);
    for (std::size_t i = 0; i < c.size(); ++i) {
      const std::uint64_t index = n.run.first + i;
      check_within(plan, c.position(i), n.box.data(), margin, index,
                   n.whole_file
                       ? "its file's header bounds, from which the plan took its tiles: make a plan with --scan"
                       : "the box of the index node that holds it");
      if (plan.indexed)
        check_within(plan, c.position(i), header, 0, index,
                     "the header's bounds (by more than 0.5 % of their extent), from which the plan took its tiles: "
                     "make a plan with --scan");
      if (!near_tile(plan.grid, coords, c.position(i))) continue;
      append_record(records, rs, index, index, c.positions().data(), fields, i);
      core += plan.grid.tile_of(c.position(i)) == id;
    }
  }
  tile_points pts = tile_from_records(plan, id, records, core);
  pts.decoded = decoded;
  pts.indexed = true;
  return pts;
}

/// The tile's points from the plan's runs (tile_plan::runs): only the runs
/// whose box meets the tile's core and halo are read, each checked against
/// its hash, then the tile's counts. Empty when the plan has no runs.
std::optional<tile_points> read_tile_runs(const tile_plan& plan, std::uint64_t id, io::point_stream& s) {
  if (plan.runs.empty()) return std::nullopt;
  const std::vector<io::point_stream::point_run> runs = s.chunk_runs();
  bool same = runs.size() == plan.runs.size() && s.declared_points() == plan.file_points;
  for (std::size_t r = 0; same && r < runs.size(); ++r)
    same = runs[r].first == plan.runs[r].first && runs[r].count == plan.runs[r].count;
  if (!same) input_changed(plan, "its points or chunks are not the plan's runs");
  double lo[3], hi[3];
  tile_region(plan, id, lo, hi);
  std::vector<io::point_stream::point_run> wanted;
  std::vector<std::size_t> which;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto& b = plan.runs[r].box;
    bool meets = true;
    for (std::size_t k = 0; k < 3; ++k)
      meets = meets && double(b[3 + k]) >= lo[k] - plan.origin[k] && double(b[k]) <= hi[k] - plan.origin[k];
    if (!meets) continue;
    wanted.push_back(runs[r]);
    which.push_back(r);
  }
  const std::vector<std::string> names = field_names(plan);
  const auto coords = plan.grid.coords(id);
  const std::vector<plan_field> tile_fields = tile_fields_of(plan);
  const std::size_t rs = record_size(plan);
  std::vector<column> converted;
  std::string records;
  std::uint64_t core = 0, decoded = 0;
  for_each_run_group(s, wanted, names, plan.origin, [&](const point_cloud& c, std::size_t r0, std::size_t r1) {
    std::size_t at = 0;
    for (std::size_t r = r0; r < r1; ++r) {
      const plan_run& e = plan.runs[which[r]];
      const std::uint64_t h = at + e.count <= c.size() ? hash_points(c, at, std::size_t(e.count), 0) : ~e.hash;
      if (h != e.hash)
        input_changed(plan, "the points " + std::to_string(e.first) + ".." + std::to_string(e.first + e.count - 1) +
                                " hash to " + hex(h) + ", the plan's to " + hex(e.hash));
      // The box decides which tiles read the run: it must be the points' own
      // (an edited box would leave the run out of a tile's halo unseen).
      if (run_box(c, at, std::size_t(e.count)) != e.box)
        throw io::io_error(plan.request.input, "invalid tile plan: the box of the run of points " +
                                                   std::to_string(e.first) + ".." +
                                                   std::to_string(e.first + e.count - 1) +
                                                   " is not its points' box (an edited plan?): make a new plan");
      at += std::size_t(e.count);
    }
    const field_bytes fields = plan_fields_of(plan, c, tile_fields, converted);
    const std::uint64_t first = wanted[r0].first;
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (!near_tile(plan.grid, coords, c.position(i))) continue;
      append_record(records, rs, first + i, first + i, c.positions().data(), fields, i);
      core += plan.grid.tile_of(c.position(i)) == id;
    }
    decoded += c.size();
  });
  tile_points pts = tile_from_records(plan, id, records, core);
  pts.decoded = decoded;
  pts.runs_read = wanted.size();
  return pts;
}

}  // namespace

tile_points read_tile(const tile_plan& plan, std::uint64_t id) {
  plan.tile(id);  // throws for a tile that owns no points
  check_plan_input(plan);
  auto s = io::open_point_stream(plan.request.input, plan.request.read);
  if (auto pts = read_tile_runs(plan, id, *s)) return std::move(*pts);
  if (auto pts = read_tile_indexed(plan, id, *s)) return std::move(*pts);
  if (plan.indexed) input_changed(plan, "it no longer has the spatial index the plan was made from");
  // The whole file's fields (LAS flags) as the plan names them, else a
  // pass to learn them; then the tile's points.
  const std::vector<std::string> names = field_names(plan);
  const bool named = s->take_fields(names);
  if (!named) {
    for_each_chunk(*s, {0, 0, 0}, [](const point_cloud&) {});
    s->rewind();
  }
  const auto coords = plan.grid.coords(id);
  std::string records;
  std::uint64_t file_index = 0, index = 0, content = 0, core = 0;
  const std::vector<plan_field> tile_fields = tile_fields_of(plan);
  const std::size_t rs = record_size(plan);
  std::vector<column> converted;
  for_each_chunk(*s, plan.origin, [&](const point_cloud& c) {
    const field_bytes fields = plan_fields_of(plan, c, tile_fields, converted);
    if (!plan.content.empty()) content = hash_chunk(c, content);
    for (std::size_t i = 0; i < c.size(); ++i, ++file_index) {
      if (!finite3(c.position(i))) continue;
      if (near_tile(plan.grid, coords, c.position(i))) {
        append_record(records, rs, index, file_index, c.positions().data(), fields, i);
        core += plan.grid.tile_of(c.position(i)) == id;
      }
      ++index;
    }
  });
  if (file_index != plan.file_points || index != plan.finite_points)
    input_changed(plan, std::to_string(file_index) + " points, " + std::to_string(index) + " finite; the plan says " +
                            std::to_string(plan.file_points) + ", " + std::to_string(plan.finite_points));
  if (!plan.content.empty() && hex(content) != plan.content)
    input_changed(plan, "its decoded points hash to " + hex(content) + ", the plan's to " + plan.content);
  tile_points pts = tile_from_records(plan, id, records, core);
  pts.decoded = (named ? 1 : 2) * file_index;
  return pts;
}

tile_part detect_tile(const tile_plan& plan, const tile_points& points, unsigned threads) {
  const auto t0 = std::chrono::steady_clock::now();
  tile_part part;
  part.tile = points.tile;
  part.plan = plan.digest();
  const auto modalities = modalities_of(plan.request.modalities);
  detect_params params = plan.request.params;
  params.threads = threads;
  params.max_keypoints = 0;  // every keypoint of the core: the merge keeps the strongest of all tiles
  params.keypoint_share = 0;
  const std::size_t m = modalities.size();
  name_modalities(plan, modalities, part);
  part.saliency.assign(m, {});
  part.candidates.assign(m, 0);
  part.keypoints = empty_cloud(plan, 0);
  if (points.cloud.empty()) return part;
  check_tile_reach(plan.grid, points.tile, points.cloud, nullptr, params);
  const detection_result r = detect(points.cloud, params, modalities);
  check_tile_reach(plan.grid, points.tile, points.cloud, &r, params, tile_check_extra(params, modalities));
  std::vector<std::uint64_t> tiles(points.cloud.size());
  plan.grid.tile_of_many(points.cloud.positions().data(), tiles.size(), tiles.data());
  for (std::size_t i = 0; i < points.cloud.size(); ++i) {
    if (tiles[i] != points.tile) continue;
    for (std::size_t k = 0; k < m; ++k) part.candidates[k] += r.saliency[k][i] >= r.thresholds[k];
    part.any_candidates += r.candidate[i] != 0;
  }
  const std::vector<std::uint32_t> kept = core_keypoints(plan.grid, points.tile, points.cloud, r);
  part.keypoints = empty_cloud(plan, kept.size());
  part.rank = detail::ranks_of(r.keypoints, r.rank_score, kept);
  for (std::size_t j = 0; j < kept.size(); ++j) {
    const std::uint32_t i = kept[j];
    part.index.push_back(points.index[i]);
    part.file_index.push_back(points.file_index[i]);
    copy_points(points.cloud, i, part.keypoints, j);
    for (std::size_t k = 0; k < m; ++k) part.saliency[k].push_back(r.saliency[k][i]);
  }
  part.detect_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return part;
}

}  // namespace ced
