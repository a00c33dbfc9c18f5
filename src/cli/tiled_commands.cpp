// SPDX-License-Identifier: MIT
// Clouds larger than memory: `ced detect --tile-size/--memory-limit` (one
// process, a tile cache), `ced plan`, `ced detect --plan --tile` and
// `ced merge` (any scheduler runs the tiles). The work is ced/tiled.hpp's.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../core/hash.hpp"
#include "../core/text.hpp"
#include "ced/ced.hpp"
#include "ced/io/catalogue.hpp"
#include "ced/io/io.hpp"
#include "ced/io/stream.hpp"
#include "ced/tiled.hpp"
#include "commands.hpp"
#include "common.hpp"
#include "detect.hpp"

namespace ced_cli {

namespace {

/// "4G", "512M", "64k", "1.5G" or a number of bytes.
std::uint64_t parse_size(const std::string& text, const std::string& option) {
  double v = 0;
  char unit = 0, extra = 0;
  const int got = std::sscanf(text.c_str(), "%lf%c%c", &v, &unit, &extra);
  double scale = 1;
  if (got == 2 ||
      (got == 3 && (extra == 'B' || extra == 'b') && text.size() >= 2 && text.find_first_of("Bb") == text.size() - 1)) {
    switch (unit) {
      case 'k':
      case 'K':
        scale = 1024.0;
        break;
      case 'm':
      case 'M':
        scale = 1024.0 * 1024;
        break;
      case 'g':
      case 'G':
        scale = 1024.0 * 1024 * 1024;
        break;
      case 't':
      case 'T':
        scale = 1024.0 * 1024 * 1024 * 1024;
        break;
      default:
        throw usage_error(option + " must be a size such as 4G, 512M or 1000000 (bytes), got '" + text + "'");
    }
  } else if (got != 1) {
    throw usage_error(option + " must be a size such as 4G, 512M or 1000000 (bytes), got '" + text + "'");
  }
  // Checked before the conversion: a double beyond 2^64 cast to an integer is undefined.
  if (!(v > 0) || !std::isfinite(v * scale) || v * scale > 1e18 || v * scale < 1)
    throw usage_error(option + " must be a size from 1 byte to 1e18 bytes (e.g. 4G, 512M), got '" + text + "'");
  return static_cast<std::uint64_t>(v * scale);
}

}  // namespace

/// The tiled request of `ced detect`'s options (checked by make_plan()).
ced::tiled_request request_from(const detect_options& o, detect_plan& plan) {
  if (!o.viewer.empty()) throw usage_error("--viewer writes the whole cloud: not with --tile-size or --memory-limit");
  if (!o.png.empty()) throw usage_error("--png draws the whole cloud: not with --tile-size or --memory-limit");
  if (!o.html.empty()) throw usage_error("--html shows the whole cloud: not with --tile-size or --memory-limit");
  if (o.voxel > 0) throw usage_error("--voxel is not available with --tile-size or --memory-limit");
  if (plan.auto_radius)
    throw usage_error("--radius auto needs the whole cloud: give --radius (or --preset) with --tile-size");
  ced::tiled_request r;
  r.input = o.input;
  r.read = plan.read_opts;
  r.params = plan.params;
  r.params.nms_radius = std::isnan(o.nms_radius) ? r.params.radius : o.nms_radius;
  try {
    if (!ced::unbounded_reach(r.params.neighborhood)) ced::exact_halo(r.params);  // else the plan finds a reach
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--neighborhood with tiles: ") + e.what());
  }
  try {
    if (!o.preset.empty()) r.modalities = ced::preset_specs(o.preset);
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  r.modalities.insert(r.modalities.end(), o.modalities.begin(), o.modalities.end());
  if (!o.memory_limit.empty()) {
    if (!o.tile_size.empty()) throw usage_error("give --tile-size or --memory-limit, not both");
    r.memory_limit = parse_size(o.memory_limit, "--memory-limit");
  } else {
    double v = std::nan("");
    try {
      v = ced::parse_number(o.tile_size, "--tile-size");
    } catch (const std::invalid_argument&) {
    }
    if (!(v > 0) || !std::isfinite(v))
      throw usage_error("--tile-size must be a positive number of metres, got '" + o.tile_size + "'");
    r.tile_size = v;
  }
  return r;
}

std::string work_dir_of(const detect_options& o) { return o.work_dir.empty() ? default_work_dir(o) : o.work_dir; }

void check_outside_work_dir(const detect_options& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  auto resolved = [&](const std::string& p) {
    fs::path r = fs::weakly_canonical(fs::absolute(p, ec), ec);
    return r.lexically_normal();
  };
  const fs::path dir = resolved(work_dir_of(o));
  for (const auto* p : {&o.input, &o.indices, &o.indices_original, &o.indices_global, &o.output, &o.summary}) {
    if (p->empty()) continue;
    const fs::path rel = resolved(*p).lexically_relative(dir);
    if (!rel.empty() && *rel.begin() != "..")
      throw usage_error("'" + *p + "' lies inside the work directory '" + work_dir_of(o) +
                        "', which ced empties of its own files: keep inputs and outputs outside it");
  }
}

std::string default_work_dir(const detect_options& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string key = fs::absolute(o.input, ec).string();
  for (const auto* p : {&o.indices, &o.indices_original, &o.indices_global, &o.output, &o.summary})
    key += "|" + (p->empty() ? std::string() : fs::absolute(*p, ec).string());
  const std::uint64_t h = ced::detail::fnv1a(key);
  char name[40];
  std::snprintf(name, sizeof name, "ced-tiles-%016llx", static_cast<unsigned long long>(h));
  return (fs::temp_directory_path(ec) / name).string();
}

std::function<void(double, double, double, std::size_t)> reach_grown_report(const char* program, bool quiet) {
  return [program, quiet](double tried, double needed, double next, std::size_t tiles) {
    if (quiet) return;
    const char* noun = tiles == 1 ? "tile" : "tiles";
    if (std::isfinite(needed))
      std::fprintf(stderr,
                   "%s: reach=%.4g was short for %zu %s (their points reach up to %.4g): those again with "
                   "reach=%.4g (give it in --neighborhood to start there next time)\n",
                   program, tried, tiles, noun, needed, next);
    else
      std::fprintf(stderr,
                   "%s: reach=%.4g was short for %zu %s (one held fewer than K points): those again with "
                   "reach=%.4g\n",
                   program, tried, tiles, noun, next);
  };
}

void report_plan(const ced::tile_plan& p, bool quiet, bool grows_reach) {
  std::uint64_t owned = 0, read = 0, largest = 0;
  for (const auto& t : p.tiles) {
    owned += t.core_points;
    read += t.points;
    largest = std::max(largest, t.points);
  }
  const double ratio = owned ? double(read) / double(owned) : 0;
  if (quiet) return;  // -q: nothing on stderr, warnings included (errors still are)
  if (!p.streamed)
    std::fprintf(stderr,
                 "ced: warning: %s is read whole before it is tiled (PLY ascii, PCD ascii and binary_compressed are "
                 "not streamed): memory is not bounded by the tile size\n",
                 p.request.input.c_str());
  if (ratio > 2)
    std::fprintf(stderr,
                 "ced: warning: the halo (%.3g) outweighs the tiles' cores (%.3g): every point is read %.1f times on "
                 "average (%llu points read for %llu), which costs as much more time and cache space\n",
                 p.grid.halo, p.grid.size, ratio, static_cast<unsigned long long>(read),
                 static_cast<unsigned long long>(owned));
  if (p.indexed)
    std::fprintf(stderr,
                 "ced: planned from %s's %s, without a pass over the points: the tiles' counts below are estimates "
                 "(ced plan --scan counts them)\n",
                 p.request.input.c_str(),
                 ced::io::names_catalogue(p.request.input) ? "headers (and COPC indexes)" : "COPC index and header");
  if (p.indexed && p.tile_fields && !p.tile_fields->empty()) {
    // The statistics a plan from the headers still needs the points for.
    std::string names, sampled;
    for (const auto& f : p.fields) {
      if (std::find(p.tile_fields->begin(), p.tile_fields->end(), f.name) == p.tile_fields->end()) continue;
      names += (names.empty() ? "" : ", ") + f.name;
      if (f.sample) sampled += (sampled.empty() ? "" : ", ") + f.name;
    }
    std::fprintf(stderr,
                 "ced: one pass read %s alone, for their ranges over every point (8-bit colour in 16 bits, "
                 "range=auto)%s%s\n",
                 names.c_str(), sampled.empty() ? "" : ", and the sample of ",
                 sampled.empty() ? "" : (sampled + " (range=zscore, percentiles, pca=)").c_str());
  }
  if (!p.runs.empty()) {
    const std::string what = p.details.rfind("LAZ", 0) == 0
                                 ? std::string("LAZ chunks")
                                 : "blocks of " + std::to_string(ced::io::point_stream::fixed_run_points) + " records";
    std::fprintf(stderr,
                 "ced: the plan records the file's %zu runs (%s) with their boxes: a tile reads those near it\n",
                 p.runs.size(), what.c_str());
  }
  if (p.request.reach_estimated)
    std::fprintf(stderr,
                 "ced: the neighbourhood reaches as far as the data make it, and no reach= was given: the tiles take "
                 "reach=%.4g, ced's own (%s)\n",
                 p.request.params.neighborhood.reach,
                 grows_reach ? "a tile that finds it short is detected again, farther"
                             : "a tile that finds it short stops, naming the reach= to give");
  std::fprintf(stderr,
               "ced: %zu tiles of %.4g (halo %.4g) own %s%llu points; %.2f points read a point, the largest tile reads "
               "%s%llu\n",
               p.tiles.size(), p.grid.size, p.grid.halo, p.indexed ? "about " : "",
               static_cast<unsigned long long>(owned), ratio, p.indexed ? "about " : "",
               static_cast<unsigned long long>(largest));
}

merged_writer::merged_writer(detect_outputs& out, ced::io::file_format format, const ced::tiled_request& request)
    : m_out(out), m_format(format) {
  if (ced::io::names_catalogue(request.input))
    m_first = ced::io::catalogue_first(ced::io::catalogue_files({request.input}), request.read);
}

file_places merged_writer::places(const ced::tile_part& c) const {
  file_places at;
  if (!m_first.empty())
    for (std::uint64_t g : c.file_index) at.push_back(ced::io::locate(m_first, g));
  return at;
}

ced::point_cloud merged_writer::records(const ced::tile_part& c, const file_places& at) const {
  // The fields in a whole run's order (write_keypoints): the input's, file_id and file_index, the saliencies.
  ced::point_cloud kp = c.keypoints;
  if (!m_first.empty()) add_file_fields(kp, at, m_first.back());
  return keypoint_cloud(std::move(kp), c.names, c.saliency);
}

ced::merge_sink merged_writer::sink() {
  ced::merge_sink s;
  s.begin = [this](const ced::tile_part& totals, std::uint64_t n) {
    m_count = n;
    if (m_out.keypoints)
      m_cloud = std::make_unique<ced::io::cloud_writer>(m_out.keypoints->stream(), records(totals, places(totals)), n,
                                                        m_format);
  };
  s.chunk = [this](const ced::tile_part& c) {
    std::string text;
    auto lines = [&](const std::vector<std::uint64_t>& v, std::ostream& os) {
      text.clear();
      for (std::uint64_t k : v) text += std::to_string(k) + '\n';
      os.write(text.data(), static_cast<std::streamsize>(text.size()));
    };
    // A catalogue: each keypoint's file and its index there.
    const file_places at = places(c);
    if (m_first.empty()) {
      if (m_out.indices) lines(c.index, m_out.indices->stream());
      if (m_out.original) lines(c.file_index, m_out.original->stream());
      if (m_out.files.empty() && m_out.per_file.empty()) lines(c.index, std::cout);
    } else {
      if (m_out.indices) write_file_places(m_out.indices->stream(), at);
      if (m_out.original) write_file_places(m_out.original->stream(), at);
      if (m_out.files.empty() && m_out.per_file.empty()) write_file_places(std::cout, at);
    }
    if (m_out.global) lines(c.file_index, m_out.global->stream());
    if (!m_out.per_file.empty()) m_per_file.insert(m_per_file.end(), at.begin(), at.end());
    if (m_cloud) ced::io::write_named(*m_out.keypoints, [&](std::ostream&) { m_cloud->write(records(c, at)); });
  };
  s.records = m_out.keypoints != nullptr;  // only a keypoint cloud needs the fields
  return s;
}

void merged_writer::finish(const ced::tile_plan& p, const ced::tile_part& m, double total_ms) {
  if (m_cloud) ced::io::write_named(*m_out.keypoints, [&](std::ostream&) { m_cloud->finish(); });
  if (!m_out.per_file.empty()) m_out.write_per_file(m_per_file);
  if (m_out.summary) {
    nlohmann::json j;
    j["input"] = {{"path", p.request.input},
                  {"details", p.details},
                  {"points_in_file", p.file_points},
                  {"nonfinite_removed", p.file_points - p.finite_points},
                  {"points_used", p.finite_points}};
    j["params"] = {{"radius", p.request.params.radius},
                   {"nms_radius", p.request.params.nms_radius},
                   {"min_neighbors", p.request.params.min_neighbors},
                   {"refine", p.request.params.refine},
                   {"max_keypoints", p.request.params.max_keypoints},
                   {"keypoint_share", p.request.params.keypoint_share}};
    auto& mods = j["modalities"] = nlohmann::json::array();
    for (std::size_t k = 0; k < m.names.size(); ++k)
      mods.push_back({{"name", m.names[k]}, {"threshold", m.thresholds[k]}, {"candidates", m.candidates[k]}});
    j["counts"] = {{"candidates", m.any_candidates}, {"keypoints", m_count}};
    std::uint64_t read = 0;
    for (const auto& t : p.tiles) read += t.points;
    j["tiles"] = {{"count", p.tiles.size()}, {"size", p.grid.size}, {"halo", p.grid.halo}, {"points_read", read}};
    j["times_ms"] = {{"detect_tiles", m.detect_ms}, {"total", total_ms}};
    m_out.summary->stream() << j.dump(2) << '\n';
  }
  // All or none: every file written out before any lands on its path.
  for (auto& f : m_out.files) f->finish();
  for (auto& f : m_out.files) f->commit();
}

/// Wraps the progress bar for the library's (step, fraction) reports.
ced::tiled_progress bar_progress(progress_bar& bar) {
  auto last = std::make_shared<std::string>();
  auto cb = std::make_shared<std::function<void(double)>>(bar.callback());
  return [&bar, last, cb](const std::string& step, double f) {
    if (step != *last) {
      *last = step;
      bar.stage(step);
    }
    if (*cb) (*cb)(f);
  };
}

bool wants_tiles(const detect_options& o) { return !o.tile_size.empty() || !o.memory_limit.empty(); }

tiled_setup setup_tiled(const detect_options& o) {
  tiled_setup s;
  s.plan = make_plan(o);
  check_outside_work_dir(o);
  s.out = std::make_unique<detect_outputs>(o, input_paths(o));
  s.request = request_from(o, s.plan);
  s.run.work_dir = work_dir_of(o);
  s.run.resume = o.resume;
  return s;
}

int run_detect_tiled(const detect_options& o) {
  tiled_setup s = setup_tiled(o);
  const detect_plan& plan = s.plan;
  const auto t_start = clock_type::now();
  ced::tiled_run_options& ro = s.run;
  ro.threads = plan.params.threads;
  progress_bar bar(progress_bar::mode_of(o.progress, o.quiet));
  ro.progress = bar_progress(bar);
  ro.planned = [&](const ced::tile_plan& p) {
    bar.pause();
    report_plan(p, o.quiet, /*grows_reach=*/true);
  };
  ro.tile_done = [&](std::size_t done, std::size_t total, double ms) { bar.tiles(done, total, ms); };
  ro.reach_grown = [&, say = reach_grown_report("ced", o.quiet)](double tried, double needed, double next,
                                                                 std::size_t tiles) {
    bar.pause();
    say(tried, needed, next, tiles);
  };
  ced::tile_plan p;
  ced::tiled_times times;
  ro.times = &times;
  merged_writer writer(*s.out, plan.out_format, s.request);
  const ced::merge_sink sink = writer.sink();
  ro.sink = &sink;
  ro.tile_done = [&, tile_done = ro.tile_done](std::size_t done, std::size_t total, double ms) {
    tile_done(done, total, ms);
    if (done == total) bar.stage("merging and writing");
  };
  ro.keep_work_dir = true;  // until the outputs are committed
  const ced::tile_part merged = naming_file_fields(o, plan, [&] {
    try {
      return ced::run_tiled(s.request, ro, &p);
    } catch (const ced::work_dir_error& e) {
      throw usage_error(e.what());
    }
  });
  writer.finish(p, merged, ms_since(t_start));
  ced::remove_work_dir(ro.work_dir);  // ced's own files only, once the outputs are committed
  bar.done();
  if (!o.quiet) {
    std::string mods;
    for (std::size_t m = 0; m < merged.names.size(); ++m)
      mods += (m ? " + " : "") + merged.names[m] + " (t=" + ced::detail::number_text(merged.thresholds[m]) + ")";
    std::fprintf(stderr, "ced: %s: %llu points (%s)\n", o.input.c_str(), static_cast<unsigned long long>(p.file_points),
                 p.details.c_str());
    const std::string strongest = keypoint_limit_text(p.request.params);
    std::fprintf(stderr, "ced: modalities %s; radius %g, nms radius %g, min neighbours %u%s%s, %u thread(s)\n",
                 mods.c_str(), p.request.params.radius, p.request.params.nms_radius, p.request.params.min_neighbors,
                 p.request.params.refine ? ", refined" : "", strongest.c_str(),
                 ced::resolve_threads(plan.params.threads));
    std::fprintf(stderr,
                 "ced: %zu keypoints; %zu tiles; plan and tile cache %.1f ms, tiles %.1f ms (detection %.1f), "
                 "merge %.1f ms; total %.1f ms\n",
                 static_cast<std::size_t>(writer.keypoints()), p.tiles.size(), times.plan_ms, times.tiles_ms,
                 merged.detect_ms, times.merge_ms, ms_since(t_start));
  }
  return exit_ok;
}

int run_detect_plan_tile(const detect_options& o) {
  if (o.tile < 0) throw usage_error("--plan needs --tile ID (a tile id of the plan)");
  if (o.output.empty()) throw usage_error("--plan --tile writes the tile's part: give -o PART");
  if (!o.indices.empty() || !o.indices_original.empty() || !o.indices_global.empty() || !o.viewer.empty() ||
      !o.png.empty() || !o.summary.empty() || !o.html.empty())
    throw usage_error("--plan --tile writes only the tile's part (-o); `ced merge` writes the outputs");
  if (!o.input.empty()) throw usage_error("--plan names the input: give no input file with it");
  if (!o.given_plan_options.empty()) {
    std::string list;
    for (const auto& g : o.given_plan_options) list += (list.empty() ? "" : ", ") + g;
    throw usage_error("--plan fixes the input, the modalities and the parameters: " + list +
                      " cannot be given with it (make a new plan with `ced plan`)");
  }
  load_plugins(o.plugins);
  const auto t0 = clock_type::now();
  const ced::tile_plan plan = ced::tile_plan::load(o.plan);
  check_paths({{"--plan", o.plan}, {"the plan's input", plan.request.input}}, {{"-o", o.output}});
  ced::io::atomic_output_file check(o.output);  // a bad output path fails before the work
  try {
    plan.tile(static_cast<std::uint64_t>(o.tile));
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--tile: ") + e.what());
  }
  const ced::tile_points pts = ced::read_tile(plan, static_cast<std::uint64_t>(o.tile));
  const ced::tile_part part = ced::detect_tile(plan, pts, static_cast<unsigned>(std::max(0, o.threads)));
  ced::write_part(o.output, plan, part);
  if (!o.quiet) {
    const std::string how =
        pts.runs_read
            ? ", " + std::to_string(pts.runs_read) + " of the file's " + std::to_string(plan.runs.size()) + " runs"
        : pts.indexed && ced::io::names_catalogue(plan.request.input) ? ", through the files' COPC indexes and headers"
        : pts.indexed                                                 ? ", through the file's COPC index"
        : pts.decoded > plan.file_points                              ? ": two passes over the file"
                                                                      : ": one pass over the file";
    std::fprintf(stderr, "ced: tile %lld: %zu points read (%llu decoded%s), %zu keypoints; %.1f ms\n", o.tile,
                 pts.cloud.size(), static_cast<unsigned long long>(pts.decoded), how.c_str(), part.index.size(),
                 ms_since(t0));
  }
  return exit_ok;
}

command add_plan_command(CLI::App& app) {
  auto o = std::make_shared<detect_options>();
  auto plan_path = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand("plan", "Plan the tiles of a cloud for `ced detect --plan --tile` and `ced merge`");
  add_input_options(cmd, o->input,
                    "Input cloud: .las, .ply, .pcd, .csv (streamed; PLY ascii and PCD ascii or binary_compressed "
                    "are read whole)",
                    o->format, o->columns)
      ->required();
  add_detector_options(cmd, *o, "Neighbourhood radius in metres (default 0.05 with --preset; needed with -m)");
  cmd->add_option("--tile-size", o->tile_size, "Edge of a tile's core, in metres");
  cmd->add_option("--memory-limit", o->memory_limit, "Or: the tile size chosen so that a tile fits, e.g. 4G");
  cmd->add_option("-o,--output", *plan_path, "The plan (JSON)")->required();
  auto scan = std::make_shared<bool>(false);
  cmd->add_flag("--scan", *scan,
                "COPC: plan by passes over the points (exact tile counts), not from the file's index and header");
  cmd->add_flag("-q,--quiet", o->quiet, "Print nothing on stderr");
  cmd->footer(
      "Example (Slurm array, or GNU parallel):\n"
      "  ced plan big.las --preset ced6d --tile-size 50 -o plan.json\n"
      "  ced detect --plan plan.json --tile ID -o part_ID.cedpart     # for every tile id in plan.json\n"
      "  ced merge plan.json part_*.cedpart -o keypoints.las --indices kp.txt");
  return {cmd, [o, plan_path, scan] {
            // As `ced detect`, whose -m without -r means --radius auto: a plan
            // cannot estimate it (the tiles are read later), so it asks.
            if (o->radius.empty() && o->preset.empty())
              throw usage_error(
                  "ced plan with -m needs -r R: the radius cannot be estimated from the whole cloud "
                  "(--radius auto) before the tiles are read");
            if (o->radius.empty()) o->radius = "0.05";
            detect_plan plan = make_plan(*o);
            plan.read_opts.fields = {};  // all: merge may write keypoint clouds
            ced::tiled_request r = request_from(*o, plan);
            r.scan = *scan;
            if (!wants_tiles(*o)) throw usage_error("give --tile-size or --memory-limit");
            check_paths(input_paths(*o), {{"-o", *plan_path}});
            ced::io::atomic_output_file out(*plan_path);
            progress_bar bar(progress_bar::mode_of(o->progress, o->quiet));
            const ced::tile_plan p = ced::plan_tiles(r, bar_progress(bar));
            bar.done();
            out.stream() << p.to_json();
            out.commit();
            report_plan(p, o->quiet, /*grows_reach=*/false);
            return exit_ok;
          }};
}

command add_merge_command(CLI::App& app) {
  auto o = std::make_shared<detect_options>();
  auto plan_path = std::make_shared<std::string>();
  auto parts = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand("merge", "Merge the tiles' parts of a plan into the whole cloud's outputs");
  cmd->add_option("plan", *plan_path, "The plan (from `ced plan`)")->required();
  cmd->add_option("parts", *parts, "The parts (from `ced detect --plan --tile`), one per tile")->required();
  cmd->add_option("--indices", o->indices, "Keypoint indices into the input's finite points (0-based, ascending)");
  cmd->add_option("--indices-original", o->indices_original,
                  "Keypoint indices into the input file's points ('FILE_ID INDEX' for a folder or @LIST)");
  cmd->add_option("--indices-global", o->indices_global,
                  "For a folder or @LIST: each keypoint's number in its files' points taken file after file");
  cmd->add_option("--indices-per-file", o->indices_per_file,
                  "For a folder or @LIST: in this folder, one file per input, <its name>.txt, its keypoints' indices");
  cmd->add_option("-o,--output", o->output,
                  "Keypoints with all fields + saliency_<modality>: .ply, .pcd, .las, .laz, .copc.laz, .csv");
  cmd->add_option("--summary", o->summary, "JSON summary");
  add_plugin_option(cmd, o->plugins);
  cmd->add_flag("-q,--quiet", o->quiet, "Print nothing on stderr");
  return {cmd, [o, plan_path, parts] {
            const auto t0 = clock_type::now();
            load_plugins(o->plugins);
            const ced::io::file_format format =
                o->output.empty() ? ced::io::file_format::automatic : ced::io::format_of(o->output);
            const ced::tile_plan p = ced::tile_plan::load(*plan_path);
            std::vector<ced::io::named_path> inputs{{"the plan", *plan_path}, {"the plan's input", p.request.input}};
            if (ced::io::names_catalogue(p.request.input))
              for (const auto& f : ced::io::catalogue_files({p.request.input})) inputs.push_back({"an input", f});
            for (const auto& part : *parts) inputs.push_back({"part", part});
            for (const auto& plugin : o->plugins) inputs.push_back({"--plugin", plugin});
            detect_outputs out(*o, inputs);
            merged_writer writer(out, format, p.request);
            ced::tile_part totals;
            ced::merge_sink sink = writer.sink();
            sink.begin = [&, begin = sink.begin](const ced::tile_part& t, std::uint64_t n) {
              totals = t;
              begin(t, n);
            };
            ced::merge_part_files(p, *parts, sink);
            writer.finish(p, totals, ms_since(t0));
            if (!o->quiet)
              std::fprintf(stderr, "ced: merged %zu parts: %llu keypoints\n", parts->size(),
                           static_cast<unsigned long long>(writer.keypoints()));
            return exit_ok;
          }};
}

}  // namespace ced_cli
