// SPDX-License-Identifier: MIT
// Tiled runs in a work directory: prepare (the plan and the tile cache, or a
// run to resume), detect each cached tile into its part, merge the parts
// (run_tiled; ced-mpi shares the steps between ranks).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <future>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "tiled/fingerprint.hpp"
#include "tiled/part_file.hpp"
#include "tiled/plan_file.hpp"
#include "tiled/records.hpp"
#include "tiled/tile_cache.hpp"
#include "tiled/work_dir.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// Tile id's part in the work directory (`folder` kept: kept from a shorter reach).
std::string part_file(const std::string& work_dir, std::uint64_t id, const char* folder = "parts") {
  return (fs::path(work_dir) / folder / ("t" + std::to_string(id) + ".part")).string();
}

/// The plan of the unfinished run in `work_dir` (plan.json), which must be
/// of the same request and input.
tile_plan resumed_plan(const tiled_request& request, const tiled_run_options& o, const fs::path& plan_path) {
  if (!o.resume)
    throw io::io_error(o.work_dir,
                       "holds the tiles of an unfinished run: pass --resume to finish it, or remove the directory");
  tile_plan plan = tile_plan::from_json(io::detail::read_whole_file(plan_path.string()), plan_path.string());
  tiled_request asked = request;
  if (asked.modalities.empty()) asked.modalities = plan.request.modalities;
  if (plan.request.reach_estimated && unbounded_reach(asked.params.neighborhood)) {
    asked.params.neighborhood.reach = plan.request.params.neighborhood.reach;  // the reach the run found
    asked.reach_estimated = true;
  }
  if (request_json(asked) != request_json(plan.request))
    throw io::io_error(o.work_dir, "holds the tiles of another run (" + request_json(plan.request).dump() +
                                       "): remove it or choose another work directory");
  check_plan_input(plan);
  return plan;
}

/// Detects a cached tile and keeps its part (the cache file goes).
tile_part detect_and_keep(const tile_plan& plan, const std::string& work_dir, const tile_points& pts,
                          unsigned threads) {
  tile_part part = detect_tile(plan, pts, threads);
  write_part_as(part_file(work_dir, pts.tile), plan, part.plan, part);  // detect_tile's digest
  remove_cached(plan, work_dir, pts.tile);
  // The resume tests' hook: die like a killed process after so many tiles.
  static std::atomic<long> detected{0};
  if (const char* kill_after = std::getenv("CED_TEST_KILL_AFTER_TILES"))
    if (++detected >= std::atol(kill_after)) std::raise(SIGKILL);
  return part;
}

/// The parts of the plan's tiles in the work directory, merged into `sink`,
/// or into one tile_part that is returned.
tile_part merge_work_dir(const tile_plan& plan, const std::string& work_dir, const merge_sink* sink) {
  std::vector<std::string> paths;
  std::error_code ec;
  for (const auto& t : plan.tiles)
    if (fs::exists(part_file(work_dir, t.id), ec)) paths.push_back(part_file(work_dir, t.id));
  tile_part out;
  merge_sink collect;
  collect.begin = [&](const tile_part& totals, std::uint64_t n) {
    out = totals;
    if (!sink) {
      resize_part(out, plan, static_cast<std::size_t>(n));
      out.keypoints = record_cloud(plan, static_cast<std::size_t>(n));  // the merge's chunks have every field
    }
    if (sink && sink->begin) sink->begin(totals, n);
  };
  std::size_t at = 0;
  collect.chunk = [&](const tile_part& c) {
    if (sink) {
      if (sink->chunk) sink->chunk(c);
      return;
    }
    const std::size_t n = c.index.size();
    std::copy_n(c.index.begin(), n, out.index.begin() + at);
    std::copy_n(c.file_index.begin(), n, out.file_index.begin() + at);
    copy_points(c.keypoints, 0, out.keypoints, at, n);
    for (std::size_t k = 0; k < c.saliency.size(); ++k)
      std::copy_n(c.saliency[k].begin(), n, out.saliency[k].begin() + at);
    std::copy_n(c.rank.begin(), n, out.rank.begin() + at);
    at += n;
  };
  collect.records = !sink || sink->records;
  merge_part_files(plan, paths, collect);
  for (auto& f : out.keypoints.fields()) f.whole_range.reset();
  return out;
}

}  // namespace

tile_plan prepare_tiled(const tiled_request& request, const tiled_run_options& o) {
  if (o.work_dir.empty()) throw std::invalid_argument("tiled run: no work directory");
  const fs::path dir(o.work_dir), plan_path = dir / "plan.json", parts = dir / "parts";
  std::error_code ec;
  tile_plan plan;
  bool announced = false;
  claim_work_dir(o.work_dir);
  if (fs::exists(plan_path, ec)) {
    plan = resumed_plan(request, o, plan_path);
  } else {
    clear_tiles(dir);  // a run stopped before its plan was written: its cache is incomplete
    try {
      plan = build_cache(request, o, dir, announced);
    } catch (...) {
      // Nothing to resume without a plan (a rerun redoes the cache): ced's
      // files go, and the directory when ced made it.
      remove_work_dir(o.work_dir);
      throw;
    }
  }
  fs::create_directories(parts, ec);
  if (ec) throw io::io_error(parts.string(), "cannot create the parts directory: " + ec.message());
  if (o.planned && !announced) o.planned(plan);
  return plan;
}

std::string begin_cache_shares(const tiled_request& request, const tiled_run_options& o, unsigned shares,
                               tile_plan& plan) {
  if (o.work_dir.empty()) throw std::invalid_argument("tiled run: no work directory");
  const fs::path dir(o.work_dir);
  std::error_code ec;
  claim_work_dir(o.work_dir);
  if (!fs::exists(dir / "plan.json", ec)) {
    std::optional<tile_plan> p;
    try {
      p = plan_for_shares(request, shares);
    } catch (...) {
      remove_work_dir(o.work_dir);
      throw;
    }
    if (p) {
      clear_tiles(dir);  // a run stopped before its plan was written: its cache is incomplete
      fs::create_directories(dir / "cache", ec);
      if (ec) throw io::io_error((dir / "cache").string(), "cannot create the tile cache directory: " + ec.message());
      return p->to_json();
    }
  }
  plan = prepare_tiled(request, o);
  return {};
}

tile_part detect_cached_tile(const tile_plan& plan, const std::string& work_dir, std::uint64_t id, unsigned threads,
                             bool* was_done) {
  plan.tile(id);
  std::error_code ec;
  const bool done = fs::exists(part_file(work_dir, id), ec);
  if (was_done) *was_done = done;
  if (done) return read_part(part_file(work_dir, id), plan);
  return detect_and_keep(plan, work_dir, load_cached(plan, work_dir, id), threads);
}

tile_part finish_tiled(const tile_plan& plan, const std::string& work_dir, const merge_sink* sink, bool keep_work_dir) {
  tile_part merged = merge_work_dir(plan, work_dir, sink);
  if (!keep_work_dir) remove_work_dir(work_dir);
  return merged;
}

namespace {

/// Whether tile ids name the same cores in plans `a` and `b` of one input
/// (which differ in the reach), and their parts carry the same fields.
bool same_tiles(const tile_plan& a, const tile_plan& b) {
  auto names = [](const tile_plan& p) {
    std::vector<std::string> n;
    for (const auto& f : p.fields) n.push_back(f.name + "/" + std::to_string(int(f.type)));
    return n;
  };
  return a.grid.same_cores(b.grid) && a.origin == b.origin && a.fingerprint == b.fingerprint &&
         a.file_points == b.file_points && a.tile_fields == b.tile_fields && names(a) == names(b) &&
         a.request.modalities == b.request.modalities;
}

/// The parts kept from a try of plan `before` whose reach was short
/// (keep_parts()), made parts of `now`: a tile whose check passed is
/// exact, and its part the same under any longer reach.
void adopt_kept_parts(const tile_plan& before, const tile_plan& now, const std::string& work_dir) {
  if (same_tiles(before, now))
    for (const auto& t : now.tiles) {
      const std::string from = part_file(work_dir, t.id, "kept");
      std::error_code ec;
      if (!fs::exists(from, ec) || fs::exists(part_file(work_dir, t.id), ec)) continue;
      const auto was = std::lower_bound(before.tiles.begin(), before.tiles.end(), t.id,
                                        [](const tile_entry& e, std::uint64_t id) { return e.id < id; });
      if (was == before.tiles.end() || was->id != t.id || was->core_points != t.core_points) continue;
      tile_part part = read_part(from, before);
      part.plan = now.digest();
      write_part(part_file(work_dir, t.id), now, part);
    }
  clear_kept(fs::path(work_dir));
}

/// run_tiled()'s tiles and merge under `plan` (made in plan_ms). When a
/// tile finds the reach that ced estimated too short, the other tiles still
/// run, to measure how far theirs reach; then there is no result, and
/// `shortfall` says how far they reach.
std::optional<tile_part> run_once(const tile_plan& plan, const tiled_run_options& o, double plan_ms,
                                  reach_shortfall& shortfall) {
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  // The tiles one after the other, threads within each; the next tile's
  // cache is read while this one is detected.
  const auto t0 = clock::now();
  std::error_code ec;
  auto needs_work = [&](std::size_t k) { return !fs::exists(part_file(o.work_dir, plan.tiles[k].id), ec); };
  auto load = [&](std::size_t k) {
    return std::async(std::launch::async, [&, k] { return load_cached(plan, o.work_dir, plan.tiles[k].id); });
  };
  std::future<tile_points> next;
  try {
    for (std::size_t k = 0; k < plan.tiles.size(); ++k) {
      if (needs_work(k)) {
        const tile_points pts = next.valid() ? next.get() : load(k).get();
        std::size_t after = k + 1;
        while (after < plan.tiles.size() && !needs_work(after)) ++after;
        if (after < plan.tiles.size()) next = load(after);
        try {
          detect_and_keep(plan, o.work_dir, pts, o.threads);
        } catch (const tile_reach_error& e) {
          if (!plan.request.reach_estimated) throw;
          shortfall.add(e);
        }
      }
      if (o.tile_done) o.tile_done(k + 1, plan.tiles.size(), ms(t0, clock::now()));
    }
  } catch (const tile_reach_error&) {
    // Resuming cannot help (the same reach fails again): ced's files go,
    // kept or not (keep_work_dir keeps them for outputs still to commit).
    if (next.valid()) next.wait();
    remove_work_dir(o.work_dir);
    throw;
  }
  if (shortfall.any) return std::nullopt;
  const auto t_merge = clock::now();
  tile_part merged = merge_work_dir(plan, o.work_dir, o.sink);
  if (!o.keep_work_dir) remove_work_dir(o.work_dir);
  if (o.times) *o.times = {plan_ms, ms(t0, t_merge), ms(t_merge, clock::now())};
  return merged;
}

}  // namespace

tile_plan grow_tiled_reach(const tile_plan& plan, const reach_shortfall& shortfall, const tiled_run_options& o) {
  if (!plan.request.reach_estimated)
    throw std::invalid_argument("grow_tiled_reach: the plan's reach= is the caller's, not ced's own");
  if (!shortfall.any) throw std::invalid_argument("grow_tiled_reach: no tile found the reach short");
  // Each try measures how far the tiles' points reach (at least as far as
  // they do in the whole cloud), so the next passes; only a tile of fewer
  // than K points measures nothing: its reach grows fourfold, until the
  // halo holds the whole cloud. The plan and cache go (the marker stays:
  // the directory is still ced's); the passed tiles' parts are kept.
  const fs::path dir(o.work_dir);
  keep_parts(dir);
  std::error_code ec;
  fs::remove(dir / "plan.json", ec);
  tiled_request r = plan.request;
  const double tried = r.params.neighborhood.reach;
  r.params.neighborhood.reach = grown_reach(tried, shortfall.needed, shortfall.unmeasured);
  if (o.reach_grown)
    o.reach_grown(tried, shortfall.unmeasured ? std::numeric_limits<double>::infinity() : shortfall.needed,
                  r.params.neighborhood.reach, shortfall.tiles);
  tiled_run_options fresh = o;
  fresh.resume = false;  // the plan just went
  const tile_plan next = prepare_tiled(r, fresh);
  adopt_kept_parts(plan, next, o.work_dir);
  return next;
}

tile_part run_tiled(const tiled_request& request, const tiled_run_options& o, tile_plan* plan_out) {
  const auto t_plan = std::chrono::steady_clock::now();
  auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
  };
  tile_plan plan = prepare_tiled(request, o);
  double plan_ms = since(t_plan);
  for (;;) {
    reach_shortfall shortfall;
    if (auto merged = run_once(plan, o, plan_ms, shortfall)) {
      if (plan_out) *plan_out = std::move(plan);
      return std::move(*merged);
    }
    const auto t_grow = std::chrono::steady_clock::now();
    plan = grow_tiled_reach(plan, shortfall, o);
    plan_ms += since(t_grow);
  }
}

}  // namespace ced
