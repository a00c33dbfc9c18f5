// SPDX-License-Identifier: MIT
// The `ced` command line: a thin shell over the library.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/detail/parallel.hpp"
#include "ced/io/output_file.hpp"
#include "ced/render.hpp"

namespace {

// Exit codes (documented in docs/CLI.md).
constexpr int exit_ok = 0;
constexpr int exit_failure = 1;  // bad input data, I/O error
constexpr int exit_usage = 2;    // bad command line or parameters

struct usage_error : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

using clock_type = std::chrono::steady_clock;
double ms_since(clock_type::time_point t) {
  return std::chrono::duration<double, std::milli>(clock_type::now() - t).count();
}

struct detect_options {
  std::string input;
  std::string preset;
  std::vector<std::string> modalities;
  double radius = 0.05;
  double nms_radius = std::nan("");
  int min_neighbors = 5;
  int threads = 0;
  std::string indices, output, viewer, png, summary;
  std::string view = "iso";
  bool quiet = false;
};

ced::point_cloud load(const std::string& path) {
  const auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == "ply") return ced::io::read_ply(path);
  if (ext == "laz" || ext == "e57")
    throw ced::io::io_error(path + ": ." + ext +
                            " is not supported; convert it to PLY first (e.g. with CloudCompare or PDAL)");
  throw ced::io::io_error(path + ": unsupported file type '." + ext + "' (this version reads .ply)");
}

/// Drops points with a non-finite coordinate; returns the original index of
/// each kept point (empty when nothing was dropped).
std::vector<std::uint32_t> drop_nonfinite(ced::point_cloud& cloud) {
  const auto& p = cloud.positions();
  std::vector<std::uint8_t> keep(cloud.size(), 1);
  bool any = false;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!std::isfinite(p[3 * i]) || !std::isfinite(p[3 * i + 1]) || !std::isfinite(p[3 * i + 2])) {
      keep[i] = 0;
      any = true;
    }
  if (!any) return {};
  std::vector<std::uint32_t> original;
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) original.push_back(static_cast<std::uint32_t>(i));
  cloud.filter(keep);
  return original;
}

std::string column_name(const std::string& modality) {
  std::string s;
  for (char c : modality) s += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  while (!s.empty() && s.back() == '_') s.pop_back();
  return s;
}

int run_detect(const detect_options& o) {
  const auto t_start = clock_type::now();
  // Parameters first: a usage error must not cost a file read.
  ced::detect_params params;
  params.radius = o.radius;
  params.nms_radius = std::isnan(o.nms_radius) ? o.radius : o.nms_radius;
  if (o.min_neighbors < 0) throw usage_error("--min-neighbors must be >= 0");
  if (o.threads < 0) throw usage_error("--threads must be >= 0");
  params.min_neighbors = static_cast<std::uint32_t>(o.min_neighbors);
  params.threads = static_cast<unsigned>(o.threads);
  try {
    ced::validate(params);
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  std::vector<ced::any_modality> modalities;
  try {
    if (!o.preset.empty()) modalities = ced::preset(o.preset);
    for (const auto& spec : o.modalities) modalities.push_back(ced::make_modality(spec));
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  ced::render_options view;
  if (o.view == "top")
    view.view = ced::view_direction::top;
  else if (o.view == "front")
    view.view = ced::view_direction::front;
  else if (o.view == "iso")
    view.view = ced::view_direction::iso;
  else
    throw usage_error("--view must be top, front or iso");

  // Open every output first (temporary files beside the targets), so that a
  // bad output path fails before the work and no output is half-written.
  std::vector<std::unique_ptr<ced::io::atomic_output_file>> outputs;
  auto open_output = [&](const std::string& path) -> ced::io::atomic_output_file* {
    if (path.empty()) return nullptr;
    outputs.push_back(std::make_unique<ced::io::atomic_output_file>(path));
    return outputs.back().get();
  };
  auto* out_indices = open_output(o.indices);
  auto* out_keypoints = open_output(o.output);
  auto* out_viewer = open_output(o.viewer);
  auto* out_png = open_output(o.png);
  auto* out_summary = open_output(o.summary);

  const auto t_load = clock_type::now();
  ced::point_cloud cloud = load(o.input);
  const double load_ms = ms_since(t_load);
  const std::size_t n_input = cloud.size();
  const std::vector<std::uint32_t> original = drop_nonfinite(cloud);
  if (!o.quiet && !original.empty())
    std::cerr << "ced: dropped " << (n_input - cloud.size())
              << " points with non-finite coordinates; indices refer to the input file\n";
  if (cloud.empty()) throw ced::io::io_error(o.input + ": the cloud has no (finite) points");
  if (modalities.empty()) modalities = ced::preset(cloud.has_rgb() ? "ced6d" : "ced3d");

  const ced::detection_result r = ced::detect(cloud, params, modalities);
  auto to_input = [&](std::uint32_t i) { return original.empty() ? i : original[i]; };

  if (out_indices) {
    auto& s = out_indices->stream();
    for (std::uint32_t k : r.keypoints) s << to_input(k) << '\n';
  }
  auto add_saliency = [&](ced::point_cloud& c, const std::vector<std::uint32_t>* subset, const std::string& prefix) {
    for (std::size_t m = 0; m < r.names.size(); ++m) {
      std::vector<double> v;
      if (subset)
        for (std::uint32_t k : *subset) v.push_back(r.saliency[m][k]);
      else
        v.assign(r.saliency[m].begin(), r.saliency[m].end());
      c.add_field(prefix + column_name(r.names[m]), ced::scalar_type::float32, std::move(v));
    }
  };
  if (out_keypoints) {
    std::vector<std::uint8_t> keep(cloud.size(), 0);
    for (std::uint32_t k : r.keypoints) keep[k] = 1;
    ced::point_cloud kp = cloud;
    kp.filter(keep);
    add_saliency(kp, &r.keypoints, "saliency_");
    ced::io::write_ply(out_keypoints->stream(), kp, ced::io::ply_format::binary_little_endian);
  }
  if (out_viewer) {
    ced::point_cloud v = cloud;
    std::vector<std::array<std::uint8_t, 3>> colours(cloud.size(), {170, 170, 170});
    const auto f = ced::find_rgb_fields(cloud);
    if (f[0]) {
      const auto s = ced::rgb::scale(f, std::nullopt);
      for (std::size_t i = 0; i < cloud.size(); ++i)
        for (std::size_t c = 0; c < 3; ++c)
          colours[i][c] = static_cast<std::uint8_t>(std::clamp(f[c]->values[i] * s[c] * 255.0 + 0.5, 0.0, 255.0));
    }
    std::vector<double> is_kp(cloud.size(), 0.0);
    for (std::uint32_t k : r.keypoints) {
      colours[k] = {255, 0, 0};
      is_kp[k] = 1.0;
    }
    for (auto* name : {"red", "green", "blue", "r", "g", "b", "Red", "Green", "Blue", "R", "G", "B"}) {
      auto& fs = v.fields();
      fs.erase(std::remove_if(fs.begin(), fs.end(), [&](const ced::field& x) { return x.name == name; }), fs.end());
    }
    v.add_rgb(colours);
    v.add_field("scalar_keypoint", ced::scalar_type::float32, std::move(is_kp));
    add_saliency(v, nullptr, "scalar_saliency_");
    ced::io::write_ply(out_viewer->stream(), v, ced::io::ply_format::binary_little_endian);
  }
  if (out_png) {
    int w = 0, h = 0;
    const auto rgb = ced::render_rgb(cloud, r.keypoints, view, w, h);
    out_png->stream() << ced::encode_png(rgb, w, h);
  }
  if (out_summary) {
    nlohmann::json j;
    j["input"] = {{"path", o.input}, {"points", n_input}, {"points_used", cloud.size()}};
    j["params"] = {{"radius", params.radius},
                   {"nms_radius", params.nms_radius},
                   {"min_neighbors", params.min_neighbors},
                   {"threads", ced::detail::resolve_threads(params.threads)}};
    auto& mods = j["modalities"] = nlohmann::json::array();
    for (std::size_t m = 0; m < r.names.size(); ++m) {
      std::size_t cand = 0;
      for (std::size_t i = 0; i < cloud.size(); ++i) cand += r.saliency[m][i] >= r.thresholds[m];
      mods.push_back({{"name", r.names[m]}, {"threshold", r.thresholds[m]}, {"candidates", cand}});
    }
    std::size_t candidates = 0;
    for (auto c : r.candidate) candidates += c;
    j["counts"] = {{"candidates", candidates}, {"keypoints", r.keypoints.size()}};
    j["times_ms"] = {{"load", load_ms},
                     {"index", r.times.index_ms},
                     {"saliency", r.times.saliency_ms},
                     {"nms", r.times.nms_ms},
                     {"detect", r.times.total_ms()}};
    out_summary->stream() << j.dump(2) << '\n';
  }
  for (auto& out : outputs) out->commit();

  if (!o.quiet) {
    std::fprintf(stderr, "ced: %zu points from %s (%.1f ms)\n", cloud.size(), o.input.c_str(), load_ms);
    std::string mods;
    for (std::size_t m = 0; m < r.names.size(); ++m)
      mods += (m ? " + " : "") + r.names[m] + " (t=" + std::to_string(r.thresholds[m]) + ")";
    std::fprintf(stderr, "ced: modalities %s; radius %g, nms radius %g, min neighbours %u, %u thread(s)\n",
                 mods.c_str(), params.radius, params.nms_radius, params.min_neighbors,
                 ced::detail::resolve_threads(params.threads));
    std::fprintf(stderr, "ced: %zu keypoints; detect %.1f ms (index %.1f, saliency %.1f, nms %.1f); total %.1f ms\n",
                 r.keypoints.size(), r.times.total_ms(), r.times.index_ms, r.times.saliency_ms, r.times.nms_ms,
                 ms_since(t_start));
  }
  if (o.indices.empty() && o.output.empty() && o.viewer.empty() && o.png.empty() && o.summary.empty())
    for (std::uint32_t k : r.keypoints) std::cout << to_input(k) << '\n';
  return exit_ok;
}

int run_info(const std::string& path) {
  ced::point_cloud cloud = load(path);
  std::cout << path << ": " << cloud.size() << " points\n";
  const auto& o = cloud.origin();
  if (o[0] != 0 || o[1] != 0 || o[2] != 0)
    std::cout << "origin: " << o[0] << " " << o[1] << " " << o[2] << " (positions stored relative to it)\n";
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  std::size_t nonfinite = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float* p = cloud.position(i);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      ++nonfinite;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  if (nonfinite) std::cout << "non-finite points: " << nonfinite << "\n";
  if (cloud.size() > nonfinite)
    std::cout << "bounds: x " << lo[0] + o[0] << " .. " << hi[0] + o[0] << ", y " << lo[1] + o[1] << " .. "
              << hi[1] + o[1] << ", z " << lo[2] + o[2] << " .. " << hi[2] + o[2] << "\n";
  std::cout << "fields:\n";
  for (const auto& f : cloud.fields()) {
    double mn = INFINITY, mx = -INFINITY;
    for (double v : f.values) {
      mn = std::min(mn, v);
      mx = std::max(mx, v);
    }
    std::cout << "  " << f.name << " (" << ced::name_of(f.type) << ") " << mn << " .. " << mx << "\n";
  }
  std::cout << "colour: " << (cloud.has_rgb() ? "yes (default preset ced6d)" : "no (default preset ced3d)") << "\n";
  return exit_ok;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ced " CED_VERSION_STRING
               ": N-modal CEntroid Distance keypoint detection in point clouds (Teng et al., WACV 2023)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", CED_VERSION_STRING);

  detect_options d;
  auto* det = app.add_subcommand("detect", "Detect keypoints");
  det->add_option("input", d.input, "Input point cloud (.ply)")->required();
  det->add_option("--preset", d.preset, "ced3d (xyz:0.2) or ced6d (xyz:0.2 + rgb:0.1)")
      ->check(CLI::IsMember({"ced3d", "ced6d"}));
  det->add_option(
      "-m,--modality", d.modalities,
      "Modality spec, repeatable: xyz:0.2, rgb:0.1, lab:0.1, intensity:0.05, bands(nir,red):0.1,range=0..255"
      " (default: ced6d when the cloud has colour, else ced3d)");
  det->add_option("-r,--radius", d.radius, "Neighbourhood radius in metres (default 0.05)");
  det->add_option("--nms-radius", d.nms_radius, "Non-maximum-suppression radius (default: the radius)");
  det->add_option("-k,--min-neighbors", d.min_neighbors, "Minimum neighbours, the point included (default 5)");
  det->add_option("-j,--threads", d.threads, "Threads (default 0 = all cores; the result does not depend on it)");
  det->add_option("--indices", d.indices, "Write keypoint indices (0-based, ascending, one per line)");
  det->add_option("-o,--output", d.output, "Write the keypoints as PLY with all fields + saliency_<modality>");
  det->add_option("--viewer", d.viewer, "Write the whole cloud as PLY, keypoints red, scalar_keypoint/_saliency_*");
  det->add_option("--png", d.png, "Write a picture of the cloud with the keypoints as red discs");
  det->add_option("--view", d.view, "View for --png: top, front or iso (default iso)");
  det->add_option("--summary", d.summary, "Write a JSON summary: input, parameters, counts, times");
  det->add_flag("-q,--quiet", d.quiet, "Print nothing on stderr");
  det->footer(
      "Examples:\n"
      "  ced detect scan.ply --preset ced6d --indices kp.txt --png kp.png\n"
      "  ced detect field.ply -m xyz:0.2 -m 'bands(nir,red,red_edge):0.1' --radius 0.5 -o kp.ply\n"
      "Without --indices/-o/--viewer/--png/--summary the indices go to stdout.");

  std::string info_input;
  auto* info = app.add_subcommand("info", "Print a cloud's fields, point count and bounds");
  info->add_option("input", info_input, "Input point cloud")->required();

  auto* mods = app.add_subcommand("modalities", "List the modalities that --modality accepts");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? exit_ok : exit_usage;
  }
  try {
    if (*det) return run_detect(d);
    if (*info) return run_info(info_input);
    if (*mods) {
      for (const auto& [name, help] : ced::registered_modalities()) std::cout << name << "\t" << help << "\n";
      return exit_ok;
    }
  } catch (const usage_error& e) {
    std::cerr << "ced: error: " << e.what() << "\n";
    return exit_usage;
  } catch (const std::exception& e) {
    std::cerr << "ced: error: " << e.what() << "\n";
    return exit_failure;
  }
  return exit_usage;
}
