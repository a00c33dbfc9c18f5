// SPDX-License-Identifier: MIT
// `ced detect`: the keypoints of one cloud, to stdout or to output files.
#include "detect.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "../core/parallel.hpp"
#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "ced/preprocess.hpp"
#include "ced/render.hpp"
#include "commands.hpp"
#include "common.hpp"

namespace ced_cli {

detect_outputs::detect_outputs(const detect_options& o, const std::vector<ced::io::named_path>& inputs) {
  check_paths(inputs, {{"--indices", o.indices},
                       {"--indices-original", o.indices_original},
                       {"--indices-global", o.indices_global},
                       {"-o", o.output},
                       {"--viewer", o.viewer},
                       {"--png", o.png},
                       {"--summary", o.summary},
                       {"--html", o.html}});
  indices = open(o.indices);
  original = open(o.indices_original);
  global = open(o.indices_global);
  keypoints = open(o.output);
  viewer = open(o.viewer);
  png = open(o.png);
  summary = open(o.summary);
  html = open(o.html);
  if (o.indices_per_file.empty()) return;
  // One file an input: DIR/<its name>.txt.
  std::error_code ec;
  if (!std::filesystem::is_directory(o.indices_per_file, ec))
    throw usage_error("--indices-per-file: '" + o.indices_per_file + "' is not a folder");
  std::vector<ced::io::named_path> outs;
  for (const auto& in : inputs) {
    if (in.what != "an input") continue;
    const std::string name = std::filesystem::path(in.path).filename().string() + ".txt";
    const std::string path = (std::filesystem::path(o.indices_per_file) / name).string();
    for (std::size_t k = 0; k < per_file.size(); ++k)
      if (per_file[k] == path)
        throw usage_error("--indices-per-file: two inputs named '" +
                          std::filesystem::path(in.path).filename().string() + "' would write one file, " + path);
    per_file.push_back(path);
    outs.push_back({"--indices-per-file", path});
  }
  if (per_file.empty()) throw usage_error("--indices-per-file goes with several inputs (files, a folder or @LIST)");
  check_paths(inputs, outs);
}

void detect_outputs::write_per_file(const std::vector<std::pair<std::size_t, std::uint64_t>>& found) {
  std::vector<std::string> text(per_file.size());
  for (const auto& [f, i] : found) text.at(f) += std::to_string(i) + '\n';
  for (std::size_t f = 0; f < per_file.size(); ++f) {
    ced::io::atomic_output_file* file = open(per_file[f]);
    file->stream() << text[f];
    file->finish();  // closed: a catalogue of many files holds no descriptor each
  }
}

ced::io::atomic_output_file* detect_outputs::open(const std::string& path) {
  if (path.empty()) return nullptr;
  files.push_back(std::make_unique<ced::io::atomic_output_file>(path));
  return files.back().get();
}

namespace {

/// The radius (unless automatic), the numeric options and their validation.
void check_numbers(const detect_options& o, detect_plan& plan) {
  ced::detect_params& params = plan.params;
  plan.auto_radius = o.radius == "auto" || (o.radius.empty() && o.preset.empty());
  if (!plan.auto_radius) {
    try {
      params.radius = o.radius.empty() ? 0.05 : ced::parse_number(o.radius, "--radius");
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
  }
  if (!(o.radius_factor > 0) || !std::isfinite(o.radius_factor))
    throw usage_error("--radius-factor must be a positive number");
  if (o.radius_factor_given && !plan.auto_radius)
    throw usage_error("--radius-factor sets the radius of --radius auto, and this run's radius is " +
                      (o.radius.empty() ? "the preset's 0.05" : "'" + o.radius + "'") +
                      ": give --radius auto, or drop --radius-factor");
  if (o.png.empty() && !o.given_png_options.empty())
    throw usage_error(o.given_png_options.front() + " shapes the --png picture: give --png FILE, or drop it");
  check_counts(o.min_neighbors, o.threads);
  if (o.voxel < 0 || !std::isfinite(o.voxel)) throw usage_error("--voxel must be a positive size in metres");
  if (o.html_max_points < 1) throw usage_error("--html-max-points must be at least 1");
  params.min_neighbors = static_cast<std::uint32_t>(o.min_neighbors);
  params.threads = static_cast<unsigned>(o.threads);
  if (o.refine && o.no_refine) throw usage_error("give --refine or --no-refine, not both");
  params.refine = o.refine || (!o.no_refine && !o.preset.empty() && ced::preset_refines(o.preset));
  if (o.max_keypoints < 0)
    throw usage_error("--max-keypoints must be >= 0 (0: no limit), got " + std::to_string(o.max_keypoints));
  params.max_keypoints = static_cast<std::size_t>(o.max_keypoints);
  params.keypoint_share = o.preset.empty() ? 0 : ced::preset_keypoint_share(o.preset);
  if (!o.keypoint_share.empty()) {
    try {
      params.keypoint_share =
          parse_share(o.keypoint_share,
                      "--keypoint-share must be a share from 0 to 1 (0: no limit), got '" + o.keypoint_share + "'");
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
  }
  set_neighborhood(params, o.neighborhood, o.search);
  ced::detect_params check = params;
  check.nms_radius = std::isnan(o.nms_radius) ? check.radius : o.nms_radius;
  try {
    ced::validate(check);
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
}

/// --preset and --modality; empty when neither is given.
std::vector<ced::any_modality> chosen_modalities(const detect_options& o) {
  std::vector<ced::any_modality> modalities;
  load_plugins(o.plugins);
  try {
    if (!o.preset.empty()) modalities = ced::preset(o.preset);
    for (const auto& spec : o.modalities) modalities.push_back(ced::make_modality(spec));
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  return modalities;
}

/// --view and --png-size.
ced::render_options render_view(const detect_options& o) {
  ced::render_options view;
  if (o.view == "top")
    view.view = ced::view_direction::top;
  else if (o.view == "front")
    view.view = ced::view_direction::front;
  else if (o.view == "iso")
    view.view = ced::view_direction::iso;
  else
    throw usage_error("--view must be top, front or iso");
  // Digits, 'x', digits: nothing before, between or after.
  const auto x = o.png_size.find('x');
  const auto size = [&](std::size_t from, std::size_t to, int& v) {
    const char* end = o.png_size.data() + to;
    if (from >= to || !std::isdigit(static_cast<unsigned char>(o.png_size[from]))) return false;
    const auto r = std::from_chars(o.png_size.data() + from, end, v);
    return r.ec == std::errc() && r.ptr == end;
  };
  if (x == std::string::npos || !size(0, x, view.width) || !size(x + 1, o.png_size.size(), view.height) ||
      view.width < 16 || view.height < 16 || view.width > 16384 || view.height > 16384)
    throw usage_error("--png-size must be WIDTHxHEIGHT, 16..16384 each, got '" + o.png_size + "'");
  return view;
}

/// --png-color: rgb, height or saliency:NAME of a chosen modality (checked
/// again after detection when the default preset is chosen by the cloud).
void check_png_color(const detect_options& o, const std::vector<ced::any_modality>& modalities) {
  if (o.png_color == "rgb" || o.png_color == "height") return;
  if (o.png_color.rfind("saliency:", 0) != 0)
    throw usage_error("--png-color must be rgb, height or saliency:NAME, got '" + o.png_color + "'");
  std::vector<std::string> names;
  for (const auto& m : modalities) names.push_back(m.name());
  if (!modalities.empty()) png_saliency_index(o.png_color.substr(9), names);
}

/// The fields to read: those the modalities and the outputs need. -o and
/// --viewer write every field; --png and the default preset look for colour.
ced::field_selection needed_fields(const detect_options& o, const std::vector<ced::any_modality>& modalities) {
  if (!o.output.empty() || !o.viewer.empty()) return {};
  std::vector<std::string> names;
  if (modalities.empty() || !o.png.empty() || !o.html.empty()) names = ced::rgb_field_names();
  for (const auto& m : modalities) {
    const auto f = m.fields();
    if (!f) return {};  // a modality that does not say: everything
    names.insert(names.end(), f->begin(), f->end());
  }
  return ced::field_selection::only(std::move(names));
}

}  // namespace

/// Parameters first: a usage error must not cost a file read.
detect_plan make_plan(const detect_options& o) {
  detect_plan plan;
  check_numbers(o, plan);
  plan.modalities = chosen_modalities(o);
  if (!o.output.empty() || !o.viewer.empty()) {
    std::vector<std::string> names;
    for (const auto& m : plan.modalities) names.push_back(m.name());
    try {
      saliency_columns(names);
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
  }
  plan.view = render_view(o);
  check_png_color(o, plan.modalities);
  if (!o.output.empty()) plan.out_format = ced::io::format_of(o.output);
  if (!o.viewer.empty() && ced::io::format_of(o.viewer) != ced::io::file_format::ply)
    throw usage_error("--viewer writes PLY: give it a .ply file name");
  plan.read_opts = make_read_options(o.format, o.columns);
  plan.read_opts.fields = needed_fields(o, plan.modalities);
  // Non-finite points are dropped below (and by tiles), after their file
  // indices are known: --indices-original counts every point of the file.
  plan.read_opts.keep_nonfinite = true;
  if (!o.origin.empty()) {
    const auto v = parse_number_list(o.origin, "--origin", [](double x) {
      if (!std::isfinite(x)) throw std::invalid_argument("must be finite");
    });
    if (v.size() != 3) throw usage_error("--origin: give X,Y,Z, three numbers, got '" + o.origin + "'");
    plan.read_opts.origin = std::array<double, 3>{v[0], v[1], v[2]};
  }
  plan.read_opts.threads = static_cast<unsigned>(o.threads);
  return plan;
}

namespace {

/// Reads the input; drops non-finite points; voxel down-samples with --voxel.
detect_input read_input(const detect_options& o, const ced::io::read_options& read_opts, progress_bar& progress) {
  detect_input in;
  progress.stage("reading");
  const auto t_load = clock_type::now();
  if (is_catalogue(o)) in.catalogue.emplace();
  in.cloud = read_inputs(o.inputs, read_opts, in.report, in.catalogue ? &*in.catalogue : nullptr);
  in.load_ms = ms_since(t_load);
  in.n_file = in.cloud.size() + in.report.nonfinite_removed;
  in.original = ced::remove_nonfinite(in.cloud);
  in.n_finite = in.cloud.size();
  in.n_dropped = in.n_file - in.n_finite;  // by the reader (PCD) and just now
  if (in.cloud.empty()) throw ced::io::io_error(o.input + ": the cloud has no (finite) points");
  warn_float_precision(in.cloud, o.input);
  if (o.voxel > 0) {
    progress.stage("voxels");
    const auto t = clock_type::now();
    ced::voxel_result v = ced::voxel_downsample(in.cloud, o.voxel);
    for (auto& r : v.representative) r = in.original[r];
    in.original = std::move(v.representative);
    in.cloud = std::move(v.cloud);
    in.voxel_ms = ms_since(t);
  }
  // Only the file indices read the mapping: 4 bytes a point less for the detection.
  // (Several inputs: always, for each keypoint's file in every output.)
  if (o.indices_original.empty() && o.indices_global.empty() && !in.catalogue)
    std::vector<std::uint32_t>().swap(in.original);
  return in;
}

/// What depends on the cloud: the automatic radius, the NMS radius, the default modalities.
void complete_plan(const detect_options& o, const ced::point_cloud& cloud, detect_plan& plan) {
  if (plan.auto_radius) {
    plan.resolution = ced::estimate_resolution(cloud);
    if (!(plan.resolution > 0))
      throw ced::io::io_error(o.input +
                              ": cannot estimate the resolution (fewer than two distinct points); give --radius");
    plan.params.radius = o.radius_factor * plan.resolution;
  }
  plan.params.nms_radius = std::isnan(o.nms_radius) ? plan.params.radius : o.nms_radius;
  if (plan.modalities.empty()) plan.modalities = ced::preset(cloud.has_rgb() ? "ced6d" : "ced3d");
}

int run_detect(const detect_options& o) {
  const auto t_start = clock_type::now();
  if (!o.plan.empty()) return run_detect_plan_tile(o);
  if (o.input.empty()) throw usage_error("give an input file (or --plan and --tile)");
  if (o.inputs.size() > 1 && wants_tiles(o))
    throw usage_error("--tile-size and --memory-limit take one input: give several files as a folder or @LIST");
  if (!o.origin.empty() && wants_tiles(o))
    throw usage_error("--origin is for whole-cloud runs: a tile plan takes its origin from the input");
  if (wants_tiles(o)) return run_detect_tiled(o);
  detect_plan plan = make_plan(o);
  detect_outputs out(o, input_paths(o));
  progress_bar progress(progress_bar::mode_of(o.progress, o.quiet));
  const detect_input in = read_input(o, plan.read_opts, progress);
  complete_plan(o, in.cloud, plan);

  progress.stage("detecting", in.cloud.size());
  plan.params.progress = progress.callback();
  const ced::detection_result r =
      naming_file_fields(o, plan, [&] { return ced::detect(in.cloud, plan.params, plan.modalities); });
  progress.stage("writing");
  // The writers' parallel chunks take --threads as the reader and the detection do.
  ced::detail::with_thread_limit(static_cast<unsigned>(o.threads), [&] { write_outputs(o, plan, in, r, out); });
  progress.done();

  if (!o.quiet) print_report(o, plan, in, r, t_start);
  if (out.files.empty() && out.per_file.empty()) write_indices(std::cout, in, r);
  return exit_ok;
}

}  // namespace

bool is_catalogue(const detect_options& o) { return names_catalogue(o.inputs); }

std::vector<std::string> catalogue_inputs(const detect_options& o) { return ced::io::catalogue_files(o.inputs); }

std::vector<ced::io::named_path> input_paths(const detect_options& o) {
  std::vector<ced::io::named_path> in;
  if (is_catalogue(o))
    for (const auto& f : catalogue_inputs(o)) in.push_back({"an input", f});
  else
    in.push_back({"the input", o.input});
  for (const auto& p : o.plugins) in.push_back({"--plugin", p});
  return in;
}

void add_detector_options(CLI::App* cmd, detect_options& o, const std::string& radius_help) {
  cmd->add_option("--preset", o.preset,
                  "ced3d (xyz:0.2), ced6d (xyz:0.2 + rgb:0.1), robust3d (xyz:0.2,scale=2, refined), "
                  "robust6d (xyz:0.2,scale=2.25,inner=1 + rgb:0.5, refined) or corner3d (corner:0.05 + "
                  "corner:0.05,scale=1.5, refined); "
                  "radius 0.05 unless given")
      ->check(CLI::IsMember(ced::preset_names()));
  one_value_each(cmd->add_option(
      "-m,--modality", o.modalities,
      "Modality spec, repeatable: xyz:0.2, rgb:0.1, lab:0.1, intensity:0.05, bands(nir,red):0.1,range=0..255"
      " (default: ced6d when the cloud has colour, else ced3d)"));
  add_plugin_option(cmd, o.plugins);
  cmd->add_option("-r,--radius", o.radius, radius_help);
  cmd->add_option("--nms-radius", o.nms_radius, "Non-maximum-suppression radius (default: the radius)")
      ->check(CLI::Validator(
          [](std::string& s) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(s.c_str(), &end);
            return std::isfinite(v) && v > 0 ? "" : "must be a positive finite number, got '" + s + "'";
          },
          "POSITIVE"));
  cmd->add_option("-k,--min-neighbors", o.min_neighbors, "Minimum neighbours, the point included (default 5)");
  cmd->add_flag("--refine", o.refine,
                "Move each keypoint to the point nearest the score-weighted centroid of its NMS neighbourhood "
                "(more repeatable under noise; default with the robust presets)");
  cmd->add_flag("--no-refine", o.no_refine, "Keep the NMS maxima themselves, as the paper (default with ced3d/ced6d)");
  cmd->add_option("--neighborhood", o.neighborhood,
                  "Neighbourhood: radius (default: the ball of --radius), knn:K (the K nearest points) or "
                  "adaptive:K[,scale=a][,min=r0][,max=r1] (a x the distance to the K-th nearest, clamped); "
                  "under knn/adaptive the xyz threshold is a ratio of each point's own radius");
  cmd->add_option("--search", o.search,
                  "How fixed-radius neighbours are gathered: grid (default, fastest) or cgal (CGAL's Kd_tree, "
                  "the reference path; the same keypoints)");
  cmd->add_option("--max-keypoints", o.max_keypoints,
                  "Keep at most N keypoints: the highest scores (product of saliencies), ties to the smaller index "
                  "(default 0: no limit)");
  cmd->add_option(
         "--progress", o.progress,
         "Progress on stderr: bar (one line redrawn), lines (a line every five seconds), json (JSON lines: at each "
         "stage, every second, at the end) or none; default auto: bar on a terminal, else lines; -q: none")
      ->check(CLI::IsMember({"auto", "bar", "lines", "json", "none"}));
  cmd->add_option("--keypoint-share", o.keypoint_share,
                  "Keep at most this share of the candidate points as keypoints, the strongest, as --max-keypoints "
                  "ranks them (0 to 1; 0: no limit; robust3d, robust6d: 0.01): holds the count steady under noise");
}

command add_detect_command(CLI::App& app, std::function<int(const detect_options&)> run) {
  auto o = std::make_shared<detect_options>();
  auto* det = app.add_subcommand("detect", "Detect keypoints");
  add_input_options(det, o->inputs,
                    "Input cloud: .ply, .pcd, .las, .laz (COPC too), .csv/.xyz/.txt/.pts; several files, a folder "
                    "(its point files) or @LIST (a file of paths, one a line) are read as one cloud",
                    o->format, o->columns);
  add_detector_options(
      det, *o,
      "Neighbourhood radius in metres, or auto = factor x resolution (default: 0.05 with --preset, else auto)");
  det->add_option("--radius-factor", o->radius_factor, "For --radius auto: radius = factor x resolution (default 5)");
  det->add_option("--origin", o->origin,
                  "X,Y,Z: store positions relative to this point instead of the centre the reader rounds from the "
                  "bounds (so that a run over part of a catalogue computes in the frame of a run over all of it)");
  det->add_option("--voxel", o->voxel, "Down-sample first: average every channel per voxel of this size (metres)");
  det->add_option("-j,--threads", o->threads, "Threads (default 0 = all cores; the result does not depend on it)");
  det->add_option("--indices", o->indices,
                  "Keypoint indices into the cloud the detector saw (0-based, ascending); with several inputs, "
                  "'FILE_ID INDEX' a line: the file's number among the inputs and the point's in that file");
  det->add_option(
      "--indices-original", o->indices_original,
      "Keypoint indices into the input file's points (after --voxel: the point nearest each voxel centroid); "
      "with several inputs 'FILE_ID INDEX' as --indices");
  det->add_option("--indices-per-file", o->indices_per_file,
                  "With several inputs: in this folder, one file per input, <its name>.txt, its keypoints' indices "
                  "in it (empty when it has none)");
  det->add_option("--indices-global", o->indices_global,
                  "With several inputs: each keypoint's number in the inputs' points taken file after file "
                  "(the index in its file plus the points of the files before it)");
  det->add_option("-o,--output", o->output,
                  "Keypoints with all fields + saliency_<modality>: .ply, .pcd, .las, .laz, .copc.laz or .csv");
  det->add_option("--viewer", o->viewer, "Whole cloud as PLY, keypoints red, scalar_keypoint/scalar_saliency_* fields");
  det->add_option("--png", o->png, "Picture of the cloud with the keypoints as red discs");
  det->add_option("--view", o->view, "View for --png: top, front or iso (default iso)");
  det->add_option("--png-size", o->png_size, "Size for --png, WIDTHxHEIGHT (default 1280x960)");
  det->add_option("--png-color", o->png_color,
                  "Colours for --png: rgb (the cloud's, default), height, or saliency:NAME (a modality's, viridis)");
  det->add_flag("--png-top", o->png_top, "For --png: a second view, from above, beside the first");
  det->add_option("--html", o->html,
                  "Interactive page (one offline HTML file): orbit the cloud, colour it by saliency, inspect points");
  det->add_option("--html-max-points", o->html_max_points,
                  "For --html: draw at most this many points, subsampling larger clouds (keypoints always drawn; "
                  "default 2000000)");
  det->add_option("--summary", o->summary, "JSON summary: input, parameters used, counts, per-stage times");
  det->add_flag("-q,--quiet", o->quiet, "Print nothing on stderr");
  det->add_option("--tile-size", o->tile_size,
                  "Detect tile by tile (edge in metres; memory bounded by a tile and its halo), "
                  "exactly the whole-cloud keypoints");
  det->add_option("--memory-limit", o->memory_limit,
                  "Detect tile by tile, the tile size chosen so that a tile fits, e.g. 4G, 512M");
  det->add_option("--work-dir", o->work_dir,
                  "With --tile-size: the tile cache and finished tiles (default: a directory in $TMPDIR); "
                  "removed when the run succeeds");
  det->add_flag("--resume", o->resume, "With --tile-size: finish a stopped run, redoing only its unfinished tiles");
  det->add_option("--plan", o->plan, "A tile plan from `ced plan`: detect one tile of it (--tile), -o the part file");
  det->add_option("--tile", o->tile, "With --plan: the tile id to detect");
  det->add_option("--config", o->config,
                  "Read options from a file: JSON (.json) or TOML/INI, keys = long option names; flags override it");
  det->footer(
      "Examples:\n"
      "  ced detect scan.ply --preset ced6d --indices kp.txt --png kp.png\n"
      "  ced detect scan.ply --preset ced6d --html view.html\n"
      "  ced detect raw.pcd --voxel 0.01 --preset ced6d -o keypoints.ply\n"
      "  ced detect tile.las -m xyz:0.2 -m 'intensity:0.05' --radius auto --summary run.json\n"
      "  ced detect field.ply -m xyz:0.2 -m 'bands(NIR,RED,REG):0.1' --radius 0.5 --viewer view.ply\n"
      "  ced detect big.las --preset ced6d --tile-size 50 -o keypoints.las\n"
      "  ced detect --plan plan.json --tile 7 -o part_7.cedpart\n"
      "Without any output option the indices go to stdout. Exit codes: 0 ok, 1 bad input data or I/O, 2 usage.");
  // What a plan fixes: with --plan, these options would be silently ignored.
  auto note_given = [det, o] {
    o->input.clear();
    if (o->inputs.size() == 1) o->input = o->inputs[0];
    if (o->inputs.size() > 1) o->input = o->inputs[0] + " and " + std::to_string(o->inputs.size() - 1) + " more";
    o->given_plan_options.clear();
    for (const char* name :
         {"--radius", "--preset", "--modality", "--nms-radius", "--min-neighbors", "--refine", "--no-refine",
          "--max-keypoints", "--keypoint-share", "--neighborhood", "--search", "--format", "--columns", "--voxel",
          "--radius-factor", "--tile-size", "--memory-limit", "--work-dir", "--resume"})
      if (det->count(name) > 0) o->given_plan_options.push_back(name);
    o->radius_factor_given = det->count("--radius-factor") > 0;
    o->given_png_options.clear();
    for (const char* name : {"--view", "--png-size", "--png-color", "--png-top"})
      if (det->count(name) > 0) o->given_png_options.push_back(name);
  };
  if (run)
    return {det, [o, run, note_given] {
              note_given();
              return run(*o);
            }};
  return {det, [o, note_given] {
            note_given();
            return run_detect(*o);
          }};
}

}  // namespace ced_cli
