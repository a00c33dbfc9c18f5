// SPDX-License-Identifier: MIT
// The `ced` command line: a thin shell over the library.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/detail/parallel.hpp"
#include "ced/eval.hpp"
#include "ced/io/io.hpp"
#include "ced/preprocess.hpp"
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

/// Reads `--config FILE.json`: a JSON object whose keys are the long option
/// names (without --), values numbers, strings, booleans or arrays.
class json_config : public CLI::Config {
 public:
  std::string to_config(const CLI::App*, bool, bool, std::string) const override { return {}; }
  std::vector<CLI::ConfigItem> from_config(std::istream& in) const override {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw CLI::ConversionError("--config: not valid JSON: " + std::string(e.what()));
    }
    if (!j.is_object()) throw CLI::ConversionError("--config: the JSON file must hold one object");
    std::vector<CLI::ConfigItem> items;
    auto text = [](const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
    for (const auto& [key, value] : j.items()) {
      CLI::ConfigItem item;
      item.name = key;
      if (value.is_array())
        for (const auto& v : value) item.inputs.push_back(text(v));
      else
        item.inputs.push_back(text(value));
      items.push_back(std::move(item));
    }
    return items;
  }
};

/// A one-line progress bar on stderr, only when stderr is a terminal.
class progress_bar {
 public:
  explicit progress_bar(bool enabled) : m_enabled(enabled && isatty(STDERR_FILENO)) {}
  ~progress_bar() { done(); }
  void stage(const std::string& name) {
    if (!m_enabled) return;
    std::lock_guard<std::mutex> lock(m_mutex);
    m_stage = name;
    draw(0);
  }
  std::function<void(double)> callback() {
    if (!m_enabled) return {};
    return [this](double f) {
      std::unique_lock<std::mutex> lock(m_mutex, std::try_to_lock);
      if (lock) draw(f);
    };
  }
  void done() {
    if (m_enabled && !m_stage.empty()) std::fprintf(stderr, "\r\033[K");
    m_stage.clear();
  }

 private:
  void draw(double f) {
    const int width = 30, filled = static_cast<int>(std::clamp(f, 0.0, 1.0) * width);
    std::fprintf(stderr, "\r\033[Kced: %-10s [%s%s] %3d%%", m_stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, ' ').c_str(), static_cast<int>(f * 100));
    std::fflush(stderr);
  }
  bool m_enabled;
  std::string m_stage;
  std::mutex m_mutex;
};

struct detect_options {
  std::string input, format = "auto", columns;
  std::string preset;
  std::vector<std::string> modalities;
  std::string radius = "";  // a number or "auto"; empty = default
  double nms_radius = std::nan("");
  double radius_factor = 5.0;
  double voxel = 0;
  int min_neighbors = 5;
  int threads = 0;
  std::string indices, indices_original, output, viewer, png, summary;
  std::string view = "iso", png_size = "1280x960";
  bool quiet = false;
};

ced::io::read_options make_read_options(const std::string& format, const std::string& columns) {
  ced::io::read_options r;
  try {
    r.format = ced::io::parse_format(format);
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--format: ") + e.what());
  }
  if (!columns.empty()) {
    std::stringstream ss(columns);
    for (std::string c; std::getline(ss, c, ',');) r.csv.columns.push_back(c);
  }
  return r;
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
  const bool auto_radius = o.radius == "auto" || (o.radius.empty() && o.preset.empty());
  if (!auto_radius) {
    try {
      params.radius = o.radius.empty() ? 0.05 : ced::parse_number(o.radius, "--radius");
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
  }
  if (!(o.radius_factor > 0) || !std::isfinite(o.radius_factor))
    throw usage_error("--radius-factor must be a positive number");
  if (o.min_neighbors < 0) throw usage_error("--min-neighbors must be >= 0");
  if (o.threads < 0) throw usage_error("--threads must be >= 0");
  if (o.voxel < 0 || !std::isfinite(o.voxel)) throw usage_error("--voxel must be a positive size in metres");
  params.min_neighbors = static_cast<std::uint32_t>(o.min_neighbors);
  params.threads = static_cast<unsigned>(o.threads);
  {
    ced::detect_params check = params;
    check.nms_radius = std::isnan(o.nms_radius) ? check.radius : o.nms_radius;
    try {
      ced::validate(check);
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
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
  if (std::sscanf(o.png_size.c_str(), "%dx%d", &view.width, &view.height) != 2 || view.width < 16 || view.height < 16 ||
      view.width > 16384 || view.height > 16384)
    throw usage_error("--png-size must be WIDTHxHEIGHT, 16..16384 each, got '" + o.png_size + "'");
  ced::io::file_format out_format = ced::io::file_format::automatic;
  if (!o.output.empty()) out_format = ced::io::format_of(o.output);
  if (!o.viewer.empty() && ced::io::format_of(o.viewer) != ced::io::file_format::ply)
    throw usage_error("--viewer writes PLY: give it a .ply file name");
  const ced::io::read_options read_opts = make_read_options(o.format, o.columns);

  // Open every output first (temporary files beside the targets), so that a
  // bad output path fails before the work and no output is half-written.
  std::vector<std::unique_ptr<ced::io::atomic_output_file>> outputs;
  auto open_output = [&](const std::string& path) -> ced::io::atomic_output_file* {
    if (path.empty()) return nullptr;
    outputs.push_back(std::make_unique<ced::io::atomic_output_file>(path));
    return outputs.back().get();
  };
  auto* out_indices = open_output(o.indices);
  auto* out_original = open_output(o.indices_original);
  auto* out_keypoints = open_output(o.output);
  auto* out_viewer = open_output(o.viewer);
  auto* out_png = open_output(o.png);
  auto* out_summary = open_output(o.summary);

  progress_bar progress(!o.quiet);
  progress.stage("reading");
  const auto t_load = clock_type::now();
  ced::io::read_report report;
  ced::point_cloud cloud = ced::io::read_cloud(o.input, read_opts, &report);
  const double load_ms = ms_since(t_load);
  const std::size_t n_file = cloud.size() + report.nonfinite_removed;
  // original[i]: index in the input file's (finite) points of detector point i.
  std::vector<std::uint32_t> original = ced::remove_nonfinite(cloud);
  const std::size_t n_finite = cloud.size();
  const std::size_t n_dropped = n_file - n_finite;  // by the reader (PCD) and just now
  if (cloud.empty()) throw ced::io::io_error(o.input + ": the cloud has no (finite) points");
  double voxel_ms = 0;
  if (o.voxel > 0) {
    progress.stage("voxels");
    const auto t = clock_type::now();
    ced::voxel_result v = ced::voxel_downsample(cloud, o.voxel);
    for (auto& r : v.representative) r = original[r];
    original = std::move(v.representative);
    cloud = std::move(v.cloud);
    voxel_ms = ms_since(t);
  }
  double resolution = 0;
  if (auto_radius) {
    resolution = ced::estimate_resolution(cloud);
    if (!(resolution > 0))
      throw ced::io::io_error(o.input +
                              ": cannot estimate the resolution (fewer than two distinct points); give --radius");
    params.radius = o.radius_factor * resolution;
  }
  params.nms_radius = std::isnan(o.nms_radius) ? params.radius : o.nms_radius;
  if (modalities.empty()) modalities = ced::preset(cloud.has_rgb() ? "ced6d" : "ced3d");

  progress.stage("detecting");
  params.progress = progress.callback();
  const ced::detection_result r = ced::detect(cloud, params, modalities);
  progress.stage("writing");

  if (out_indices)
    for (std::uint32_t k : r.keypoints) out_indices->stream() << k << '\n';
  if (out_original)
    for (std::uint32_t k : r.keypoints) out_original->stream() << original[k] << '\n';
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
    ced::io::write_cloud(out_keypoints->stream(), kp, out_format);
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
    if (f[0]) {  // replace the colour fields by the keypoint-marked colours
      const std::string names[3] = {f[0]->name, f[1]->name, f[2]->name};
      auto& fs = v.fields();
      fs.erase(std::remove_if(
                   fs.begin(), fs.end(),
                   [&](const ced::field& x) { return x.name == names[0] || x.name == names[1] || x.name == names[2]; }),
               fs.end());
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
    j["input"] = {{"path", o.input},
                  {"format", ced::io::format_name(report.format)},
                  {"details", report.details},
                  {"points_in_file", n_file},
                  {"nonfinite_removed", n_dropped},
                  {"points_after_voxel", cloud.size()},
                  {"points_used", cloud.size()}};
    j["params"] = {{"radius", params.radius},
                   {"radius_auto", auto_radius},
                   {"resolution", resolution},
                   {"nms_radius", params.nms_radius},
                   {"min_neighbors", params.min_neighbors},
                   {"voxel", o.voxel},
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
    j["times_ms"] = {{"read", load_ms},           {"voxel", voxel_ms},
                     {"index", r.times.index_ms}, {"saliency", r.times.saliency_ms},
                     {"nms", r.times.nms_ms},     {"detect", r.times.total_ms()}};
    out_summary->stream() << j.dump(2) << '\n';
  }
  for (auto& out : outputs) out->commit();
  progress.done();

  if (!o.quiet) {
    std::fprintf(stderr, "ced: %s: %zu points (%s, %.1f ms)\n", o.input.c_str(), n_file, report.details.c_str(),
                 load_ms);
    if (n_dropped) std::fprintf(stderr, "ced: dropped %zu points with non-finite coordinates\n", n_dropped);
    if (o.voxel > 0)
      std::fprintf(stderr, "ced: voxel %g: %zu -> %zu points (%.1f ms)\n", o.voxel, n_finite, cloud.size(), voxel_ms);
    if (auto_radius)
      std::fprintf(stderr, "ced: radius auto = %g x resolution %g = %g\n", o.radius_factor, resolution, params.radius);
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
  if (outputs.empty())
    for (std::uint32_t k : r.keypoints) std::cout << k << '\n';
  return exit_ok;
}

int run_info(const std::string& path, const std::string& format, const std::string& columns) {
  ced::io::read_report report;
  ced::point_cloud cloud = ced::io::read_cloud(path, make_read_options(format, columns), &report);
  std::cout << path << ": " << cloud.size() << " points (" << report.details << ")\n";
  if (report.nonfinite_removed)
    std::cout << "non-finite points dropped while reading: " << report.nonfinite_removed << "\n";
  const auto& o = cloud.origin();
  if (o[0] != 0 || o[1] != 0 || o[2] != 0)
    std::cout << "origin: " << o[0] << " " << o[1] << " " << o[2] << " (positions are stored relative to it)\n";
  const std::size_t before = cloud.size();
  ced::remove_nonfinite(cloud);
  if (cloud.size() != before) std::cout << "non-finite points: " << before - cloud.size() << "\n";
  if (!cloud.empty()) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (std::size_t i = 0; i < cloud.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], cloud.position(i)[k]);
        hi[k] = std::max(hi[k], cloud.position(i)[k]);
      }
    std::cout.precision(10);
    std::cout << "bounds: x " << lo[0] + o[0] << " .. " << hi[0] + o[0] << ", y " << lo[1] + o[1] << " .. "
              << hi[1] + o[1] << ", z " << lo[2] + o[2] << " .. " << hi[2] + o[2] << "\n";
    std::cout.precision(6);
    const double res = ced::estimate_resolution(cloud);
    std::cout << "resolution (median nearest-neighbour distance): " << res << "  -> --radius auto = " << 5 * res
              << "\n";
  }
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

struct eval_options {
  std::string input, format = "auto", columns;
  std::vector<std::string> detectors{"ced6d", "ced3d", "random"};
  int trials = 5;
  std::uint64_t seed = 1;
  std::string noise = "0,0.5";
  double epsilon = 2.0, resolution = 0, radius = 0, max_translation = 1.0;
  int min_neighbors = 5, threads = 0;
  std::string csv;
  bool quiet = false;
};

/// A detector of the evaluation: "random", a preset, or modality specs
/// joined by commas ("xyz:0.2,bands(nir):0.1,range=0..255").
struct eval_detector {
  std::string name;
  bool random = false;
  std::vector<ced::any_modality> modalities;
};

eval_detector parse_detector(const std::string& text) {
  eval_detector d;
  d.name = text;
  if (text == "random") {
    d.random = true;
    return d;
  }
  if (text == "ced6d" || text == "ced3d") {
    d.modalities = ced::preset(text);
    return d;
  }
  // Split at top-level commas; a piece of the form key=value (before any
  // ':' or '(') is an option of the modality before it.
  std::vector<std::string> specs;
  std::string cur;
  int depth = 0;
  auto flush = [&] {
    const auto eq = cur.find('='), colon = cur.find_first_of(":(");
    if (!specs.empty() && eq != std::string::npos && (colon == std::string::npos || eq < colon))
      specs.back() += "," + cur;
    else if (!cur.empty())
      specs.push_back(cur);
    cur.clear();
  };
  for (char c : text) {
    depth += c == '(' ? 1 : c == ')' ? -1 : 0;
    if (c == ',' && depth == 0)
      flush();
    else
      cur += c;
  }
  flush();
  for (const auto& s : specs) d.modalities.push_back(ced::make_modality(s));
  if (d.modalities.empty()) throw std::invalid_argument("--detector '" + text + "' names no modality");
  return d;
}

int run_eval(const eval_options& o) {
  std::vector<eval_detector> detectors;
  std::vector<double> noise;
  try {
    for (const auto& d : o.detectors) detectors.push_back(parse_detector(d));
    std::stringstream ss(o.noise);
    for (std::string v; std::getline(ss, v, ',');) {
      noise.push_back(ced::parse_number(v, "--noise"));
      if (noise.back() < 0) throw std::invalid_argument("--noise values must be >= 0");
    }
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  if (o.trials < 1 || o.trials > 10000) throw usage_error("--trials must be 1..10000");
  if (!(o.epsilon > 0) || !std::isfinite(o.epsilon)) throw usage_error("--epsilon must be positive");
  if (o.resolution < 0 || o.radius < 0 || !(o.max_translation >= 0)) throw usage_error("negative length");
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);

  ced::point_cloud p = ced::io::read_cloud(o.input, make_read_options(o.format, o.columns));
  ced::remove_nonfinite(p);
  if (p.empty()) throw ced::io::io_error(o.input + ": the cloud has no (finite) points");
  const double res = o.resolution > 0 ? o.resolution : ced::estimate_resolution(p);
  if (!(res > 0)) throw ced::io::io_error(o.input + ": cannot estimate the resolution; give --resolution");
  ced::detect_params params;
  params.radius = params.nms_radius = o.radius > 0 ? o.radius : 5 * res;
  params.min_neighbors = static_cast<std::uint32_t>(std::max(0, o.min_neighbors));
  params.threads = static_cast<unsigned>(std::max(0, o.threads));
  const double eps = o.epsilon * res;
  if (!o.quiet)
    std::fprintf(stderr, "ced eval: %s, %zu points, resolution %g, radius %g, epsilon %g, %d trial(s)\n",
                 o.input.c_str(), p.size(), res, params.radius, eps, o.trials);
  if (csv)
    csv->stream() << "detector,noise_resolution,noise_m,trial,source_keypoints,target_keypoints,repeated,"
                     "relative_repeatability,detect_ms\n";
  std::printf("%-28s %8s %10s %12s %10s %10s\n", "detector", "noise", "kp(P)", "rel.rep.", "sd", "ms");
  std::mt19937_64 master(o.seed);
  for (double nr : noise) {
    struct acc {
      double sum = 0, sum2 = 0, kp = 0, ms = 0;
    };
    std::vector<acc> stats(detectors.size());
    for (int trial = 0; trial < o.trials; ++trial) {
      std::mt19937_64 rng(master());
      const auto t = ced::eval::random_transform(rng, o.max_translation);
      const ced::point_cloud q = ced::eval::transform(p, t, nr * res, rng);
      std::size_t last_count = std::max<std::size_t>(1, p.size() / 100);
      for (std::size_t d = 0; d < detectors.size(); ++d) {
        std::vector<std::uint32_t> kp, kq;
        double ms = 0;
        if (detectors[d].random) {
          const auto t0 = clock_type::now();
          kp = ced::eval::random_keypoints(p.size(), last_count, rng);
          kq = ced::eval::random_keypoints(q.size(), last_count, rng);
          ms = ms_since(t0) / 2;
        } else {
          const auto a = ced::detect(p, params, detectors[d].modalities);
          const auto b = ced::detect(q, params, detectors[d].modalities);
          kp = a.keypoints;
          kq = b.keypoints;
          ms = (a.times.total_ms() + b.times.total_ms()) / 2;
          last_count = std::max<std::size_t>(1, kp.size());
        }
        const auto r = ced::eval::measure(p, kp, q, kq, t, eps);
        stats[d].sum += r.relative();
        stats[d].sum2 += r.relative() * r.relative();
        stats[d].kp += double(kp.size());
        stats[d].ms += ms;
        if (csv)
          csv->stream() << '"' << detectors[d].name << "\"," << nr << ',' << nr * res << ',' << trial << ','
                        << r.source_keypoints << ',' << r.target_keypoints << ',' << r.repeated << ',' << r.relative()
                        << ',' << ms << '\n';
      }
    }
    for (std::size_t d = 0; d < detectors.size(); ++d) {
      const double n = o.trials, mean = stats[d].sum / n;
      const double sd = std::sqrt(std::max(0.0, stats[d].sum2 / n - mean * mean));
      std::printf("%-28s %8.2f %10.1f %12.3f %10.3f %10.1f\n", detectors[d].name.c_str(), nr, stats[d].kp / n, mean, sd,
                  stats[d].ms / n);
    }
  }
  if (csv) csv->commit();
  return exit_ok;
}

/// Replaces `detect ... --config FILE ...` by the file's options, inserted
/// right after `detect`; options also given on the command line win (the
/// file's value is dropped).
std::vector<std::string> expand_config(const std::vector<std::string>& args, CLI::App& det) {
  const auto sub = std::find(args.begin(), args.end(), "detect");
  if (sub == args.end()) return args;
  std::string path;
  std::vector<std::string> rest;
  for (auto it = sub + 1; it != args.end(); ++it) {
    if (*it == "--config" && it + 1 != args.end()) {
      path = *++it;
    } else if (it->rfind("--config=", 0) == 0) {
      path = it->substr(9);
    } else {
      rest.push_back(*it);
    }
  }
  if (path.empty()) return args;
  std::ifstream in(path);
  if (!in) throw usage_error("--config: cannot open '" + path + "'");
  const bool json = path.size() > 5 && path.compare(path.size() - 5, 5, ".json") == 0;
  std::vector<CLI::ConfigItem> items;
  try {
    items = json ? json_config().from_config(in) : CLI::ConfigTOML().from_config(in);
  } catch (const std::exception& e) {
    throw usage_error("--config " + path + ": " + e.what());
  }
  auto given = [&](const CLI::Option* opt) {
    for (const auto& a : rest) {
      for (const auto& l : opt->get_lnames())
        if (a == "--" + l || a.rfind("--" + l + "=", 0) == 0) return true;
      for (const auto& sn : opt->get_snames())
        if (a == "-" + sn) return true;
    }
    return false;
  };
  std::vector<std::string> out(args.begin(), sub + 1);
  for (const auto& item : items) {
    if (item.name == "++" || item.name == "--") continue;  // TOML section markers
    const CLI::Option* opt = det.get_option_no_throw("--" + item.name);
    if (!opt || item.name == "config") throw usage_error("--config " + path + ": unknown key '" + item.name + "'");
    if (given(opt)) continue;
    if (opt->get_type_size() == 0) {  // a flag
      if (!item.inputs.empty() && (item.inputs[0] == "true" || item.inputs[0] == "1")) out.push_back("--" + item.name);
      continue;
    }
    for (const auto& v : item.inputs) {
      out.push_back("--" + item.name);
      out.push_back(v);
    }
  }
  out.insert(out.end(), rest.begin(), rest.end());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ced " CED_VERSION_STRING
               ": N-modal CEntroid Distance keypoint detection in point clouds (Teng et al., WACV 2023)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", CED_VERSION_STRING);

  detect_options d;
  auto* det = app.add_subcommand("detect", "Detect keypoints");
  det->add_option("input", d.input, "Input cloud: .ply, .pcd, .las, .csv/.xyz/.txt/.pts")->required();
  det->add_option("--format", d.format, "Input format when the extension does not say: ply, pcd, las, csv, auto");
  det->add_option("--columns", d.columns, "CSV column names, e.g. x,y,z,intensity (the file then has no header)");
  det->add_option("--preset", d.preset, "ced3d (xyz:0.2) or ced6d (xyz:0.2 + rgb:0.1), with the paper's radius 0.05")
      ->check(CLI::IsMember({"ced3d", "ced6d"}));
  det->add_option(
      "-m,--modality", d.modalities,
      "Modality spec, repeatable: xyz:0.2, rgb:0.1, lab:0.1, intensity:0.05, bands(nir,red):0.1,range=0..255"
      " (default: ced6d when the cloud has colour, else ced3d)");
  det->add_option(
      "-r,--radius", d.radius,
      "Neighbourhood radius in metres, or auto = factor x resolution (default: 0.05 with --preset, else auto)");
  det->add_option("--radius-factor", d.radius_factor, "For --radius auto: radius = factor x resolution (default 5)");
  det->add_option("--nms-radius", d.nms_radius, "Non-maximum-suppression radius (default: the radius)");
  det->add_option("-k,--min-neighbors", d.min_neighbors, "Minimum neighbours, the point included (default 5)");
  det->add_option("--voxel", d.voxel, "Down-sample first: average every channel per voxel of this size (metres)");
  det->add_option("-j,--threads", d.threads, "Threads (default 0 = all cores; the result does not depend on it)");
  det->add_option("--indices", d.indices, "Keypoint indices into the cloud the detector saw (0-based, ascending)");
  det->add_option(
      "--indices-original", d.indices_original,
      "Keypoint indices into the input file's points (after --voxel: the point nearest each voxel centroid)");
  det->add_option("-o,--output", d.output, "Keypoints with all fields + saliency_<modality>: .ply, .pcd, .las or .csv");
  det->add_option("--viewer", d.viewer, "Whole cloud as PLY, keypoints red, scalar_keypoint/scalar_saliency_* fields");
  det->add_option("--png", d.png, "Picture of the cloud with the keypoints as red discs");
  det->add_option("--view", d.view, "View for --png: top, front or iso (default iso)");
  det->add_option("--png-size", d.png_size, "Size for --png, WIDTHxHEIGHT (default 1280x960)");
  det->add_option("--summary", d.summary, "JSON summary: input, parameters used, counts, per-stage times");
  det->add_flag("-q,--quiet", d.quiet, "Print nothing on stderr");
  std::string config_path;
  det->add_option("--config", config_path,
                  "Read options from a file: JSON (.json) or TOML/INI, keys = long option names; flags override it");
  det->footer(
      "Examples:\n"
      "  ced detect scan.ply --preset ced6d --indices kp.txt --png kp.png\n"
      "  ced detect raw.pcd --voxel 0.01 --preset ced6d -o keypoints.ply\n"
      "  ced detect tile.las -m xyz:0.2 -m 'intensity:0.05' --radius auto --summary run.json\n"
      "  ced detect field.ply -m xyz:0.2 -m 'bands(NIR,RED,REG):0.1' --radius 0.5 --viewer view.ply\n"
      "Without any output option the indices go to stdout. Exit codes: 0 ok, 1 bad input data or I/O, 2 usage.");

  std::string info_input, info_format = "auto", info_columns;
  auto* info = app.add_subcommand("info", "Print a cloud's fields, point count, bounds and resolution");
  info->add_option("input", info_input, "Input point cloud")->required();
  info->add_option("--format", info_format, "Input format: ply, pcd, las, csv, auto");
  info->add_option("--columns", info_columns, "CSV column names");

  auto* mods = app.add_subcommand("modalities", "List the modalities that --modality accepts");

  eval_options ev;
  auto* eval = app.add_subcommand("eval", "Evaluate detectors");
  auto* rep = eval->add_subcommand("repeatability", "Relative repeatability under a random rigid transform and noise");
  eval->require_subcommand(1);
  rep->add_option("input", ev.input, "Input point cloud")->required();
  rep->add_option("--format", ev.format, "Input format");
  rep->add_option("--columns", ev.columns, "CSV column names");
  rep->add_option("-d,--detector", ev.detectors,
                  "Repeatable: ced6d, ced3d, random, or modality specs joined by commas (default: ced6d ced3d random)");
  rep->add_option("--trials", ev.trials, "Random transforms per noise level (default 5)");
  rep->add_option("--seed", ev.seed, "Seed (default 1): the same seed gives the same numbers");
  rep->add_option("--noise", ev.noise, "Gaussian noise levels, in multiples of the resolution (default 0,0.5)");
  rep->add_option("--epsilon", ev.epsilon, "Match distance, in multiples of the resolution (default 2)");
  rep->add_option("--resolution", ev.resolution, "Cloud resolution in metres (default: estimated)");
  rep->add_option("-r,--radius", ev.radius, "Detector radius = NMS radius (default 5 x resolution)");
  rep->add_option("-k,--min-neighbors", ev.min_neighbors, "Minimum neighbours (default 5)");
  rep->add_option("--max-translation", ev.max_translation, "Translations uniform in +-this, metres (default 1)");
  rep->add_option("-j,--threads", ev.threads, "Threads");
  rep->add_option("--csv", ev.csv, "Write one row per detector x noise x trial");
  rep->add_flag("-q,--quiet", ev.quiet, "Print only the table");

  std::string conv_in, conv_out, conv_format = "auto", conv_columns;
  double conv_voxel = 0;
  auto* conv = app.add_subcommand("convert", "Convert between formats (by extension), optionally voxel down-sampled");
  conv->add_option("input", conv_in, "Input point cloud")->required();
  conv->add_option("output", conv_out, "Output: .ply, .pcd, .las or .csv")->required();
  conv->add_option("--format", conv_format, "Input format: ply, pcd, las, csv, auto");
  conv->add_option("--columns", conv_columns, "CSV column names");
  conv->add_option("--voxel", conv_voxel, "Voxel size for down-sampling (metres)");

  ced::io::remove_temporaries_on_signals();  // an interrupted run leaves no partial output
  std::vector<std::string> args(argv + 1, argv + argc);
  try {
    args = expand_config(args, *det);
  } catch (const std::exception& e) {
    std::cerr << "ced: error: " << e.what() << "\n";
    return exit_usage;
  }
  try {
    std::reverse(args.begin(), args.end());  // CLI11 takes a reversed vector
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? exit_ok : exit_usage;
  }
  try {
    if (*det) return run_detect(d);
    if (*info) return run_info(info_input, info_format, info_columns);
    if (*rep) return run_eval(ev);
    if (*conv) {
      if (conv_voxel < 0 || !std::isfinite(conv_voxel)) throw usage_error("--voxel must be a positive size");
      const auto fmt = ced::io::format_of(conv_out);
      ced::io::atomic_output_file out(conv_out);
      ced::point_cloud c = ced::io::read_cloud(conv_in, make_read_options(conv_format, conv_columns));
      if (conv_voxel > 0) {
        ced::remove_nonfinite(c);
        c = ced::voxel_downsample(c, conv_voxel).cloud;
      }
      ced::io::write_cloud(out.stream(), c, fmt);
      out.commit();
      return exit_ok;
    }
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
