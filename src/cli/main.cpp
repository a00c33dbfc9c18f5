// SPDX-License-Identifier: MIT
// The `ced` command line: a thin shell over the library.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "core/parallel.hpp"
#include "ced/eval.hpp"
#include "ced/io/io.hpp"
#include "ced/io/rgbd.hpp"
#include "ced/preprocess.hpp"
#include "ced/render.hpp"
#ifdef CED_HAS_PCL
#include "pcl_bridge.hpp"
#endif

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
  std::string source, target, transform;  // a user-supplied pair instead of INPUT
  std::vector<std::string> detectors{"ced6d", "ced3d", "random"};
  int trials = 5;
  std::uint64_t seed = 1;
  std::string noise = "0,0.5";
  double epsilon = 2.0, resolution = 0, radius = 0, max_translation = 1.0;
  int min_neighbors = 5, threads = 0;
  std::string csv;
  bool quiet = false;
};

// PCL's detectors, available when ced is built with its PCL component.
const std::vector<std::string> pcl_detector_names = {"iss3d", "harris3d", "harris6d", "sift"};
const char* const no_pcl_message =
    "needs ced's PCL component (ced_pcl), and this ced was built without it: install PCL (Debian: libpcl-dev) and "
    "reconfigure with -DCED_WITH_PCL=ON";

/// A detector of the evaluation: "random", a preset, one of PCL's, or
/// modality specs joined by commas ("xyz:0.2,bands(nir):0.1,range=0..255").
struct eval_detector {
  enum class kind { ced, random, pcl };
  std::string name;
  kind type = kind::ced;
  std::vector<ced::any_modality> modalities;
};

eval_detector parse_detector(const std::string& text) {
  eval_detector d;
  d.name = text;
  if (text == "random") {
    d.type = eval_detector::kind::random;
    return d;
  }
  if (std::find(pcl_detector_names.begin(), pcl_detector_names.end(), text) != pcl_detector_names.end()) {
#ifdef CED_HAS_PCL
    d.type = eval_detector::kind::pcl;
    return d;
#else
    throw std::invalid_argument("--detector " + text + " " + no_pcl_message);
#endif
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

std::vector<eval_detector> parse_detectors(const std::vector<std::string>& names) {
  std::vector<eval_detector> out;
  try {
    for (const auto& d : names) out.push_back(parse_detector(d));
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  if (out.empty()) throw usage_error("--detector: no detector given");
  return out;
}

/// What the evaluated detectors share: the detector parameters and the resolution.
struct eval_setting {
  ced::detect_params params;
  double resolution = 0;
};

eval_setting make_setting(const ced::point_cloud& p, const std::string& name, double resolution, double radius,
                          int min_neighbors, int threads) {
  eval_setting s;
  s.resolution = resolution > 0 ? resolution : ced::estimate_resolution(p);
  if (!(s.resolution > 0)) throw ced::io::io_error(name + ": cannot estimate the resolution; give --resolution");
  s.params.radius = s.params.nms_radius = radius > 0 ? radius : 5 * s.resolution;
  s.params.min_neighbors = static_cast<std::uint32_t>(std::max(0, min_neighbors));
  s.params.threads = static_cast<unsigned>(std::max(0, threads));
  return s;
}

struct detection {
  std::vector<std::uint32_t> keypoints;
  double ms = 0;
};

/// Runs `d` on `cloud`. "random" picks `random_count` points.
detection run_detector(const eval_detector& d, const ced::point_cloud& cloud, const eval_setting& s,
                       std::size_t random_count, std::mt19937_64& rng) {
  const auto t0 = clock_type::now();
  detection out;
  switch (d.type) {
    case eval_detector::kind::random:
      out.keypoints = ced::eval::random_keypoints(cloud.size(), random_count, rng);
      break;
    case eval_detector::kind::ced: {
      const auto r = ced::detect(cloud, s.params, d.modalities);
      out.keypoints = r.keypoints;
      out.ms = r.times.total_ms();
      return out;
    }
    case eval_detector::kind::pcl: {
#ifdef CED_HAS_PCL
      ced::pcl_bridge::detector_params p;  // the CED paper's settings, scaled to the resolution
      p.radius = s.params.radius;
      p.nms_radius = s.params.nms_radius;
      p.min_neighbors = static_cast<int>(s.params.min_neighbors);
      p.sift_min_scale = s.resolution;
      p.threads = ced::detail::resolve_threads(s.params.threads);
      out.keypoints = ced::pcl_bridge::detect(cloud, *ced::pcl_bridge::parse_detector(d.name), p);
#endif
      break;
    }
  }
  out.ms = ms_since(t0);
  return out;
}

ced::point_cloud read_finite(const std::string& path, const std::string& format, const std::string& columns,
                             double voxel = 0) {
  ced::point_cloud c = ced::io::read_cloud(path, make_read_options(format, columns));
  ced::remove_nonfinite(c);
  if (c.empty()) throw ced::io::io_error(path + ": the cloud has no (finite) points");
  if (voxel > 0) c = ced::voxel_downsample(c, voxel).cloud;
  return c;
}

/// Mean and standard deviation of the relative repeatability per detector.
struct repeat_stats {
  double sum = 0, sum2 = 0, kp = 0, ms = 0;
  int n = 0;
  void add(const ced::eval::repeatability& r, std::size_t kp_count, double t_ms) {
    sum += r.relative();
    sum2 += r.relative() * r.relative();
    kp += double(kp_count);
    ms += t_ms;
    ++n;
  }
};

void print_repeat_header() {
  std::printf("%-28s %8s %10s %12s %10s %10s\n", "detector", "noise", "kp(P)", "rel.rep.", "sd", "ms");
}

void print_repeat_row(const std::string& name, const std::string& noise, const repeat_stats& st) {
  const double n = std::max(1, st.n), mean = st.sum / n;
  const double sd = std::sqrt(std::max(0.0, st.sum2 / n - mean * mean));
  std::printf("%-28s %8s %10.1f %12.3f %10.3f %10.1f\n", name.c_str(), noise.c_str(), st.kp / n, mean, sd, st.ms / n);
}

/// The columns of `ced eval repeatability --csv` (one row per repeat_once() measurement).
constexpr const char* repeat_csv_header =
    "detector,noise_resolution,noise_m,trial,source_keypoints,target_keypoints,repeated,relative_repeatability,"
    "detect_ms\n";

/// Runs every detector on P and Q and measures; one CSV row each.
void repeat_once(const std::vector<eval_detector>& detectors, const ced::point_cloud& p, const ced::point_cloud& q,
                 const ced::eval::rigid_transform& t, const eval_setting& s, double eps, std::mt19937_64& rng,
                 std::vector<repeat_stats>& stats, std::ostream* csv, const std::string& csv_prefix) {
  std::size_t last_count = std::max<std::size_t>(1, p.size() / 100);
  for (std::size_t d = 0; d < detectors.size(); ++d) {
    const detection a = run_detector(detectors[d], p, s, last_count, rng);
    const detection b = run_detector(detectors[d], q, s, last_count, rng);
    if (detectors[d].type != eval_detector::kind::random) last_count = std::max<std::size_t>(1, a.keypoints.size());
    const auto r = ced::eval::measure(p, a.keypoints, q, b.keypoints, t, eps);
    const double ms = (a.ms + b.ms) / 2;
    stats[d].add(r, a.keypoints.size(), ms);
    if (csv)
      *csv << '"' << detectors[d].name << "\"," << csv_prefix << ',' << r.source_keypoints << ',' << r.target_keypoints
           << ',' << r.repeated << ',' << r.relative() << ',' << ms << '\n';
  }
}

void check_eval_numbers(const eval_options& o) {
  if (o.trials < 1 || o.trials > 10000) throw usage_error("--trials must be 1..10000");
  if (!(o.epsilon > 0) || !std::isfinite(o.epsilon)) throw usage_error("--epsilon must be positive");
  if (o.resolution < 0 || o.radius < 0 || !(o.max_translation >= 0)) throw usage_error("negative length");
}

/// Chooses the mode: INPUT (synthetic transforms) or --source/--target (a user pair).
bool user_pair_mode(const std::string& input, const std::string& source, const std::string& target,
                    const std::string& transform) {
  const bool pair = !source.empty() || !target.empty();
  if (pair && !input.empty()) throw usage_error("give either INPUT or --source and --target, not both");
  if (pair && (source.empty() || target.empty())) throw usage_error("--source and --target go together");
  if (!pair && input.empty()) throw usage_error("give INPUT, or --source P --target Q [--transform T.txt]");
  if (!pair && !transform.empty()) throw usage_error("--transform goes with --source and --target");
  return pair;
}

/// `ced eval repeatability --source P --target Q [--transform T]`: the given
/// pair as it is (no synthetic transform, no noise); trials only redraw the
/// random baseline.
int run_eval_pair(const eval_options& o, const std::vector<eval_detector>& detectors, bool noise_given) {
  if (noise_given) throw usage_error("--noise applies to INPUT's synthetic pairs, not to --source/--target");
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);
  const ced::eval::rigid_transform absolute =
      o.transform.empty() ? ced::eval::rigid_transform{} : ced::eval::read_transform(o.transform);
  const ced::point_cloud p = read_finite(o.source, o.format, o.columns);
  const ced::point_cloud q = read_finite(o.target, o.format, o.columns);
  const auto t = ced::eval::to_local(absolute, p.origin(), q.origin());
  const eval_setting s = make_setting(p, o.source, o.resolution, o.radius, o.min_neighbors, o.threads);
  const double eps = o.epsilon * s.resolution;
  if (!o.quiet)
    std::fprintf(stderr, "ced eval: %s (%zu points) -> %s (%zu points), resolution %g, radius %g, epsilon %g\n",
                 o.source.c_str(), p.size(), o.target.c_str(), q.size(), s.resolution, s.params.radius, eps);
  if (csv) csv->stream() << repeat_csv_header;
  print_repeat_header();
  std::vector<repeat_stats> stats(detectors.size());
  std::mt19937_64 rng(o.seed);
  for (int trial = 0; trial < o.trials; ++trial)
    repeat_once(detectors, p, q, t, s, eps, rng, stats, csv ? &csv->stream() : nullptr, "0,0," + std::to_string(trial));
  for (std::size_t d = 0; d < detectors.size(); ++d) print_repeat_row(detectors[d].name, "pair", stats[d]);
  if (csv) csv->commit();
  return exit_ok;
}

int run_eval(const eval_options& o, bool noise_given) {
  const std::vector<eval_detector> detectors = parse_detectors(o.detectors);
  check_eval_numbers(o);
  if (user_pair_mode(o.input, o.source, o.target, o.transform)) return run_eval_pair(o, detectors, noise_given);
  std::vector<double> noise;
  try {
    std::stringstream ss(o.noise);
    for (std::string v; std::getline(ss, v, ',');) {
      noise.push_back(ced::parse_number(v, "--noise"));
      if (noise.back() < 0) throw std::invalid_argument("--noise values must be >= 0");
    }
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);

  const ced::point_cloud p = read_finite(o.input, o.format, o.columns);
  const eval_setting s = make_setting(p, o.input, o.resolution, o.radius, o.min_neighbors, o.threads);
  const double res = s.resolution, eps = o.epsilon * res;
  if (!o.quiet)
    std::fprintf(stderr, "ced eval: %s, %zu points, resolution %g, radius %g, epsilon %g, %d trial(s)\n",
                 o.input.c_str(), p.size(), res, s.params.radius, eps, o.trials);
  if (csv) csv->stream() << repeat_csv_header;
  print_repeat_header();
  std::mt19937_64 master(o.seed);
  for (double nr : noise) {
    std::vector<repeat_stats> stats(detectors.size());
    for (int trial = 0; trial < o.trials; ++trial) {
      std::mt19937_64 rng(master());
      const auto t = ced::eval::random_transform(rng, o.max_translation);
      const ced::point_cloud q = ced::eval::transform(p, t, nr * res, rng);
      std::ostringstream prefix;
      prefix << nr << ',' << nr * res << ',' << trial;
      repeat_once(detectors, p, q, t, s, eps, rng, stats, csv ? &csv->stream() : nullptr, prefix.str());
    }
    char label[32];
    std::snprintf(label, sizeof label, "%.2f", nr);
    for (std::size_t d = 0; d < detectors.size(); ++d) print_repeat_row(detectors[d].name, label, stats[d]);
  }
  if (csv) csv->commit();
  return exit_ok;
}

struct registration_options {
  std::string input, format = "auto", columns;
  std::string source, target, transform;  // a user pair
  std::string rgbd, intrinsics;           // consecutive RGB-D frames
  std::vector<std::string> detectors{"ced6d", "random", "ced3d", "iss3d", "harris3d", "harris6d", "sift"};
  std::string descriptor = "auto";
  int trials = 5, iterations = 20000, min_neighbors = 5, threads = 0;
  std::uint64_t seed = 1;
  double overlap = 0.4, noise = 0, max_translation = 1.0;
  double resolution = 0, radius = 0, voxel = 0, depth_max = 3.0;
  double normal_radius = 3, feature_radius = 5, inlier_distance = 2.5;  // in multiples of the resolution
  double inlier_fraction = 0.1;
  double max_rotation_error = 5, max_translation_error = 0.2;
  std::string csv;
  bool quiet = false;
};

#ifdef CED_HAS_PCL

/// One registration problem: register `source` onto `target`; `truth` maps
/// source positions to target positions (local frames).
struct registration_pair {
  std::string name;
  ced::point_cloud source, target;
  ced::eval::rigid_transform truth;
  std::array<double, 3> source_viewpoint{0, 0, 0}, target_viewpoint{0, 0, 0};  // local frames
};

/// The sensor at absolute (0, 0, 0), in a cloud's local frame.
std::array<double, 3> zero_viewpoint(const ced::point_cloud& c) {
  return {-c.origin()[0], -c.origin()[1], -c.origin()[2]};
}

/// Two crops of `cloud` along its longest axis sharing `overlap` of its
/// extent; the second moved by a random rigid transform (and noise).
registration_pair synthetic_pair(const ced::point_cloud& cloud, double overlap, double sigma, double max_translation,
                                 std::mt19937_64& rng) {
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], cloud.position(i)[k]);
      hi[k] = std::max(hi[k], cloud.position(i)[k]);
    }
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
  const double extent = hi[axis] - lo[axis];
  const double p_end = lo[axis] + extent * (1 + overlap) / 2, q_start = lo[axis] + extent * (1 - overlap) / 2;
  std::vector<std::uint8_t> in_p(cloud.size()), in_q(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    in_p[i] = cloud.position(i)[axis] <= p_end;
    in_q[i] = cloud.position(i)[axis] >= q_start;
  }
  registration_pair pair;
  pair.source = cloud;
  pair.source.filter(in_p);
  ced::point_cloud q = cloud;
  q.filter(in_q);
  pair.truth = ced::eval::random_transform(rng, max_translation);
  pair.target = ced::eval::transform(q, pair.truth, sigma, rng);
  pair.source_viewpoint = zero_viewpoint(cloud);
  pair.target_viewpoint = pair.truth.apply(pair.source_viewpoint);
  return pair;
}

/// Consecutive frames of an Open3D RGB-D folder: color/NNNNN.jpg,
/// depth/NNNNN.png, odometry.log (camera-to-world poses) and the intrinsics.
std::vector<registration_pair> rgbd_pairs(const registration_options& o) {
  const std::string dir = o.rgbd;
  std::string intrinsics = o.intrinsics;
  if (intrinsics.empty()) intrinsics = dir + "/camera_primesense.json";
  const auto k = ced::io::read_intrinsics(intrinsics);
  const auto poses = ced::io::read_trajectory_log(dir + "/odometry.log");
  ced::io::rgbd_options ro;
  ro.depth_max = o.depth_max;
  std::vector<ced::point_cloud> frames;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    char stem[32];
    std::snprintf(stem, sizeof stem, "%05zu", i);
    ced::point_cloud c = ced::io::read_rgbd(dir + "/depth/" + stem + ".png", dir + "/color/" + stem + ".jpg", k, ro);
    if (o.voxel > 0) c = ced::voxel_downsample(c, o.voxel).cloud;
    frames.push_back(std::move(c));
  }
  std::vector<registration_pair> pairs;
  for (std::size_t i = 0; i + 1 < frames.size(); ++i) {
    registration_pair p;
    p.name = "rgbd " + std::to_string(i) + "-" + std::to_string(i + 1);
    p.source = frames[i];
    p.target = frames[i + 1];
    // camera i -> world -> camera i+1; the camera centre is each frame's (0,0,0)
    p.truth = ced::eval::compose(ced::eval::inverse(poses[i + 1]), poses[i]);
    pairs.push_back(std::move(p));
  }
  if (pairs.empty()) throw ced::io::io_error(dir + "/odometry.log: fewer than two frames");
  return pairs;
}

void check_registration_numbers(const registration_options& o) {
  if (o.trials < 1 || o.trials > 10000) throw usage_error("--trials must be 1..10000");
  if (o.iterations < 1) throw usage_error("--iterations must be >= 1");
  if (!(o.overlap > 0 && o.overlap < 1)) throw usage_error("--overlap must be in (0, 1)");
  for (double v : {o.normal_radius, o.feature_radius, o.inlier_distance, o.max_rotation_error, o.max_translation_error})
    if (!(v > 0) || !std::isfinite(v))
      throw usage_error(
          "--normal-radius, --feature-radius, --inlier-distance and the error thresholds must be positive");
  if (o.noise < 0 || o.resolution < 0 || o.radius < 0 || o.voxel < 0 || !(o.max_translation >= 0) ||
      !(o.depth_max >= 0))
    throw usage_error("negative length");
  if (!(o.inlier_fraction >= 0 && o.inlier_fraction <= 1)) throw usage_error("--inlier-fraction must be in [0, 1]");
  if (o.descriptor != "auto" && o.descriptor != "fpfh" && o.descriptor != "pfhrgb")
    throw usage_error("--descriptor must be fpfh, pfhrgb or auto");
  const int modes = !o.input.empty() + (!o.source.empty() || !o.target.empty()) + !o.rgbd.empty();
  if (modes != 1) throw usage_error("give exactly one of INPUT, --source P --target Q, or --rgbd DIR");
  if ((!o.source.empty() || !o.target.empty()) && (o.source.empty() || o.target.empty()))
    throw usage_error("--source and --target go together");
  if (!o.transform.empty() && o.source.empty()) throw usage_error("--transform goes with --source and --target");
  if (!o.intrinsics.empty() && o.rgbd.empty()) throw usage_error("--intrinsics goes with --rgbd");
}

/// The pairs to register; `repeats` = how often each is run (with new seeds).
std::vector<registration_pair> registration_pairs(const registration_options& o, int& repeats) {
  repeats = o.trials;
  if (!o.rgbd.empty()) return rgbd_pairs(o);
  if (!o.source.empty()) {
    const ced::eval::rigid_transform absolute =
        o.transform.empty() ? ced::eval::rigid_transform{} : ced::eval::read_transform(o.transform);
    registration_pair p;
    p.name = "pair";
    p.source = read_finite(o.source, o.format, o.columns, o.voxel);
    p.target = read_finite(o.target, o.format, o.columns, o.voxel);
    p.truth = ced::eval::to_local(absolute, p.source.origin(), p.target.origin());
    p.source_viewpoint = zero_viewpoint(p.source);
    p.target_viewpoint = zero_viewpoint(p.target);
    return {p};
  }
  const ced::point_cloud cloud = read_finite(o.input, o.format, o.columns, o.voxel);
  const double res = o.resolution > 0 ? o.resolution : ced::estimate_resolution(cloud);
  std::vector<registration_pair> pairs;
  std::mt19937_64 master(o.seed);
  for (int trial = 0; trial < o.trials; ++trial) {
    std::mt19937_64 rng(master());
    pairs.push_back(synthetic_pair(cloud, o.overlap, o.noise * res, o.max_translation, rng));
    pairs.back().name = "synthetic " + std::to_string(trial);
  }
  repeats = 1;
  return pairs;
}

ced::pcl_bridge::registration_params make_registration_params(const registration_options& o,
                                                              const registration_pair& pair, double res) {
  ced::pcl_bridge::registration_params r;
  const bool colour = pair.source.has_rgb() && pair.target.has_rgb();
  if (o.descriptor == "pfhrgb" || (o.descriptor == "auto" && colour)) r.feature = ced::pcl_bridge::descriptor::pfhrgb;
  r.normal_radius = o.normal_radius * res;
  r.feature_radius = o.feature_radius * res;
  r.inlier_distance = o.inlier_distance * res;
  r.max_iterations = o.iterations;
  r.inlier_fraction = o.inlier_fraction;
  r.threads = ced::detail::resolve_threads(static_cast<unsigned>(std::max(0, o.threads)));
  return r;
}

struct registration_stats {
  int runs = 0, successes = 0;
  double kp = 0, matches = 0, inliers = 0, ms = 0;
};

int run_registration(const registration_options& o) {
  const std::vector<eval_detector> detectors = parse_detectors(o.detectors);
  check_registration_numbers(o);
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);
  int repeats = 1;
  const std::vector<registration_pair> pairs = registration_pairs(o, repeats);
  if (csv)
    csv->stream() << "detector,pair,trial,descriptor,source_keypoints,target_keypoints,matches,inliers,"
                     "rotation_error_deg,translation_error_m,success,detect_ms,register_ms\n";
  std::printf("%-28s %-14s %5s %8s %8s %8s %9s %9s %7s %9s\n", "detector", "pair", "trial", "kp(P)", "matches",
              "inliers", "rot.err", "trans.err", "success", "ms");
  std::vector<registration_stats> stats(detectors.size());
  std::mt19937_64 master(o.seed ^ 0x5eedULL);
  for (const auto& pair : pairs) {
    const eval_setting s = make_setting(pair.source, pair.name, o.resolution, o.radius, o.min_neighbors, o.threads);
    auto params = make_registration_params(o, pair, s.resolution);
    const char* descriptor = params.feature == ced::pcl_bridge::descriptor::pfhrgb ? "pfhrgb" : "fpfh";
    if (!o.quiet)
      std::fprintf(stderr, "ced eval: %s: %zu -> %zu points, resolution %g, %s, normal radius %g, feature radius %g\n",
                   pair.name.c_str(), pair.source.size(), pair.target.size(), s.resolution, descriptor,
                   params.normal_radius, params.feature_radius);
    const auto truth = ced::eval::to_absolute(pair.truth, pair.source.origin(), pair.target.origin());
    for (int trial = 0; trial < repeats; ++trial) {
      std::mt19937_64 rng(master());
      params.seed = static_cast<unsigned>(rng());
      std::size_t last_count = std::max<std::size_t>(1, pair.source.size() / 100);
      for (std::size_t d = 0; d < detectors.size(); ++d) {
        const detection a = run_detector(detectors[d], pair.source, s, last_count, rng);
        const detection b = run_detector(detectors[d], pair.target, s, last_count, rng);
        if (detectors[d].type != eval_detector::kind::random) last_count = std::max<std::size_t>(1, a.keypoints.size());
        const auto r = ced::pcl_bridge::register_keypoints(pair.source, a.keypoints, pair.source_viewpoint, pair.target,
                                                           b.keypoints, pair.target_viewpoint, params);
        const auto estimate = ced::eval::to_absolute(r.transform, pair.source.origin(), pair.target.origin());
        const double rot = ced::eval::rotation_error_deg(estimate, truth);
        const double trans = ced::eval::translation_error(estimate, truth);
        const bool success = r.converged && rot < o.max_rotation_error && trans < o.max_translation_error;
        const double detect_ms = (a.ms + b.ms) / 2, register_ms = r.features_ms + r.ransac_ms;
        auto& st = stats[d];
        ++st.runs;
        st.successes += success;
        st.kp += double(a.keypoints.size());
        st.matches += double(r.matches);
        st.inliers += double(r.inliers);
        st.ms += detect_ms + register_ms;
        std::printf("%-28s %-14s %5d %8zu %8zu %8zu %9.2f %9.3f %7s %9.1f\n", detectors[d].name.c_str(),
                    pair.name.c_str(), trial, a.keypoints.size(), r.matches, r.inliers, rot, trans,
                    success ? "yes" : "no", detect_ms + register_ms);
        if (csv)
          csv->stream() << '"' << detectors[d].name << "\",\"" << pair.name << "\"," << trial << ',' << descriptor
                        << ',' << a.keypoints.size() << ',' << b.keypoints.size() << ',' << r.matches << ','
                        << r.inliers << ',' << rot << ',' << trans << ',' << (success ? 1 : 0) << ',' << detect_ms
                        << ',' << register_ms << '\n';
      }
    }
  }
  std::printf("\n%-28s %8s %8s %8s %8s %10s %9s\n", "detector", "runs", "success", "kp(P)", "matches", "inliers", "ms");
  for (std::size_t d = 0; d < detectors.size(); ++d) {
    const auto& st = stats[d];
    const double n = std::max(1, st.runs);
    std::printf("%-28s %8d %7.0f%% %8.1f %8.1f %10.1f %9.1f\n", detectors[d].name.c_str(), st.runs,
                100.0 * st.successes / n, st.kp / n, st.matches / n, st.inliers / n, st.ms / n);
  }
  if (csv) csv->commit();
  return exit_ok;
}

#else

int run_registration(const registration_options&) {
  throw usage_error(std::string("ced eval registration ") + no_pcl_message);
}

#endif

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
  rep->add_option("input", ev.input, "Input point cloud (or --source and --target)");
  rep->add_option("--source", ev.source, "A given pair instead of INPUT: the source cloud P");
  rep->add_option("--target", ev.target, "A given pair instead of INPUT: the target cloud Q");
  rep->add_option("--transform", ev.transform,
                  "4x4 row-major matrix file mapping P's coordinates into Q's (default: the identity)");
  rep->add_option("--format", ev.format, "Input format");
  rep->add_option("--columns", ev.columns, "CSV column names");
  rep->add_option("-d,--detector", ev.detectors,
                  "Repeatable: ced6d, ced3d, random, iss3d, harris3d, harris6d, sift (PCL builds), or modality specs "
                  "joined by commas (default: ced6d ced3d random)");
  rep->add_option("--trials", ev.trials, "Random transforms per noise level (default 5)");
  rep->add_option("--seed", ev.seed, "Seed (default 1): the same seed gives the same numbers");
  auto* noise_opt =
      rep->add_option("--noise", ev.noise, "Gaussian noise levels, in multiples of the resolution (default 0,0.5)");
  rep->add_option("--epsilon", ev.epsilon, "Match distance, in multiples of the resolution (default 2)");
  rep->add_option("--resolution", ev.resolution, "Cloud resolution in metres (default: estimated)");
  rep->add_option("-r,--radius", ev.radius, "Detector radius = NMS radius (default 5 x resolution)");
  rep->add_option("-k,--min-neighbors", ev.min_neighbors, "Minimum neighbours (default 5)");
  rep->add_option("--max-translation", ev.max_translation, "Translations uniform in +-this, metres (default 1)");
  rep->add_option("-j,--threads", ev.threads, "Threads");
  rep->add_option("--csv", ev.csv, "Write one row per detector x noise x trial");
  rep->add_flag("-q,--quiet", ev.quiet, "Print only the table");

  registration_options rg;
  auto* reg = eval->add_subcommand(
      "registration", "Registration success: keypoints, FPFH/PFHRGB, mutual matching, RANSAC (needs a PCL build)");
  reg->add_option("input", rg.input, "Cloud to cut into two overlapping crops (or --source/--target, or --rgbd)");
  reg->add_option("--source", rg.source, "A given pair: the source cloud P");
  reg->add_option("--target", rg.target, "A given pair: the target cloud Q");
  reg->add_option("--transform", rg.transform, "4x4 row-major matrix file mapping P into Q (default: the identity)");
  reg->add_option("--rgbd", rg.rgbd,
                  "Open3D RGB-D folder (color/NNNNN.jpg, depth/NNNNN.png, odometry.log): consecutive frame pairs");
  reg->add_option("--intrinsics", rg.intrinsics, "Camera JSON for --rgbd (default DIR/camera_primesense.json)");
  reg->add_option("--depth-max", rg.depth_max, "For --rgbd: drop depths beyond this, metres (default 3; 0 = none)");
  reg->add_option("--format", rg.format, "Input format");
  reg->add_option("--columns", rg.columns, "CSV column names");
  reg->add_option("-d,--detector", rg.detectors,
                  "Repeatable, as for repeatability (default: ced6d random ced3d iss3d harris3d harris6d sift)");
  reg->add_option("--descriptor", rg.descriptor, "fpfh, pfhrgb, or auto = pfhrgb when both clouds have colour");
  reg->add_option("--trials", rg.trials, "Synthetic pairs for INPUT; runs per pair (new seeds) otherwise (default 5)");
  reg->add_option("--seed", rg.seed, "Seed (default 1)");
  reg->add_option("--overlap", rg.overlap, "INPUT: the crops share this fraction of the longest extent (default 0.4)");
  reg->add_option("--noise", rg.noise, "INPUT: Gaussian noise on the moved crop, x resolution (default 0)");
  reg->add_option("--max-translation", rg.max_translation, "INPUT: translations uniform in +-this, metres (default 1)");
  reg->add_option("--voxel", rg.voxel, "Voxel down-sampling of the input clouds, metres (default none)");
  reg->add_option("--resolution", rg.resolution, "Resolution in metres (default: estimated on the source)");
  reg->add_option("-r,--radius", rg.radius, "Detector radius = NMS radius (default 5 x resolution)");
  reg->add_option("-k,--min-neighbors", rg.min_neighbors, "Minimum neighbours (default 5)");
  reg->add_option("--normal-radius", rg.normal_radius, "Normal estimation radius, x resolution (default 3)");
  reg->add_option("--feature-radius", rg.feature_radius, "Descriptor radius, x resolution (default 5)");
  reg->add_option("--inlier-distance", rg.inlier_distance, "RANSAC inlier distance, x resolution (default 2.5)");
  reg->add_option("--inlier-fraction", rg.inlier_fraction, "RANSAC: minimum inliers / matches (default 0.1)");
  reg->add_option("--iterations", rg.iterations, "RANSAC iterations (default 20000)");
  reg->add_option("--max-rotation-error", rg.max_rotation_error, "Success: rotation error below, degrees (default 5)");
  reg->add_option("--max-translation-error", rg.max_translation_error,
                  "Success: translation error below, metres (default 0.2)");
  reg->add_option("-j,--threads", rg.threads, "Threads");
  reg->add_option("--csv", rg.csv, "Write one row per detector x pair x trial");
  reg->add_flag("-q,--quiet", rg.quiet, "Print only the tables");

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
    if (*rep) return run_eval(ev, noise_opt->count() > 0);
    if (*reg) return run_registration(rg);
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
