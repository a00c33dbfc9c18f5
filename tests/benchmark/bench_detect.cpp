// SPDX-License-Identifier: MIT
// Benchmarks: ced per stage against a straightforward per-point CGAL port
// (the baseline) and, when built with PCL, PCL's ISS3D, Harris3D and
// Harris6D, on the Redwood scans when ../shared/data is present and on
// generated clouds otherwise. Before timing, the baseline's keypoints are
// checked against ced's and the agreement is printed.
//
//   build/bin/bench_detect [--data DIR] [benchmark flags, e.g. --benchmark_repetitions=5]
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/preprocess.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "core/neighbor_index.hpp"
#ifdef CED_HAS_PCL
#include "pcl_bridge.hpp"  // ced's optional PCL component: PCL's own detectors
#endif

namespace {

// ---------------------------------------------------------------------------
// The baseline: the paper's algorithm ported to CGAL one point at a time,
// with two radius searches per point (saliency, then NMS for candidates).
// ---------------------------------------------------------------------------
std::vector<std::uint32_t> baseline(const ced::point_cloud& c, bool colour, const ced::detect_params& p) {
  const std::size_t n = c.size();
  const ced::neighbor_index index(c.positions().data(), n, 10);
  std::vector<float> geo(n, 0.0f), col(n, 0.0f);
  const auto f = ced::find_rgb_fields(c);
  std::vector<std::uint32_t> nb;
  for (std::size_t i = 0; i < n; ++i) {
    index.radius_search(c.position(i), p.radius, nb);
    if (nb.size() < p.min_neighbors) continue;
    float g[3] = {0, 0, 0};
    double s[3] = {0, 0, 0};
    for (std::uint32_t j : nb)
      for (int k = 0; k < 3; ++k) {
        g[k] += c.position(j)[k];
        if (colour) s[k] += f[std::size_t(k)]->values[j];
      }
    const float cnt = static_cast<float>(nb.size());
    float d2 = 0, l1 = 0;
    for (int k = 0; k < 3; ++k) {
      const float dk = g[k] / cnt - c.position(i)[k];
      d2 += dk * dk;
      if (colour) l1 += std::abs(static_cast<float>(s[k]) / cnt - static_cast<float>(f[std::size_t(k)]->values[i]));
    }
    geo[i] = std::sqrt(d2);
    col[i] = l1 / 255.0f;
  }
  std::vector<std::uint32_t> kp;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(geo[i] >= 0.2 * p.radius || (colour && col[i] >= 0.1))) continue;
    index.radius_search(c.position(i), p.nms_radius, nb);
    const float si = colour ? geo[i] * col[i] : geo[i];
    bool maximum = true;
    for (std::uint32_t j : nb)
      if (si < (colour ? geo[j] * col[j] : geo[j])) {
        maximum = false;
        break;
      }
    if (maximum) kp.push_back(static_cast<std::uint32_t>(i));
  }
  return kp;
}

// ---------------------------------------------------------------------------
// Inputs
// ---------------------------------------------------------------------------
std::map<std::string, ced::point_cloud>& clouds() {
  static std::map<std::string, ced::point_cloud> c;
  return c;
}

/// A noisy coloured room with `n` points at ~1 cm spacing, with a uint16
/// intensity and three uint8 bands. Deterministic.
ced::point_cloud generated_room(std::size_t n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.002f);
  const float side = std::sqrt(static_cast<float>(n) / 5.0f) * 0.01f;  // 5 faces of side² at 1 cm
  ced::point_cloud c;
  c.reserve(n);
  std::vector<double> r(n), g(n), b(n), in(n), b1(n), b2(n), b3(n);
  for (std::size_t i = 0; i < n; ++i) {
    float p[3] = {u(rng) * side, u(rng) * side, u(rng) * side};
    p[i % 3] = (i % 5 < 3) ? 0.0f : side;  // floor/walls/ceiling
    c.push_back(p[0] + noise(rng), p[1] + noise(rng), p[2] + noise(rng));
    const int tile = int(p[0] / 0.3f) + int(p[1] / 0.3f) + int(p[2] / 0.3f);
    r[i] = tile % 2 ? 200 : 60;
    g[i] = tile % 3 ? 150 : 40;
    b[i] = 80 + std::floor(u(rng) * 20);
    in[i] = std::floor(u(rng) * 1000) + (tile % 2) * 20000;
    b1[i] = tile % 4 ? 30 : 200;
    b2[i] = tile % 5 ? 100 : 20;
    b3[i] = std::floor(u(rng) * 255);
  }
  c.add_field("red", ced::scalar_type::uint8, std::move(r));
  c.add_field("green", ced::scalar_type::uint8, std::move(g));
  c.add_field("blue", ced::scalar_type::uint8, std::move(b));
  c.add_field("intensity", ced::scalar_type::uint16, std::move(in));
  c.add_field("b1", ced::scalar_type::uint8, std::move(b1));
  c.add_field("b2", ced::scalar_type::uint8, std::move(b2));
  c.add_field("b3", ced::scalar_type::uint8, std::move(b3));
  return c;
}

/// Adds the extra channels the 5-modality benchmark reads to a real scan.
void add_synthetic_channels(ced::point_cloud& c) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> u(0, 255);
  for (const char* name : {"intensity", "b1", "b2", "b3"}) {
    std::vector<double> v(c.size());
    for (auto& x : v) x = u(rng);
    c.add_field(name, ced::scalar_type::uint8, std::move(v));
  }
}

std::vector<ced::any_modality> five_modalities() {
  return {ced::make_modality("xyz"), ced::make_modality("rgb"), ced::make_modality("lab"),
          ced::make_modality("intensity,range=0..255"), ced::make_modality("bands(b1,b2,b3)")};
}

// ---------------------------------------------------------------------------
// Benchmarks
// ---------------------------------------------------------------------------
void report(benchmark::State& state, const ced::detection_result& r, std::size_t n) {
  state.counters["points"] = double(n);
  state.counters["keypoints"] = double(r.keypoints.size());
  state.counters["index_ms"] = r.times.index_ms;
  state.counters["saliency_ms"] = r.times.saliency_ms;
  state.counters["nms_ms"] = r.times.nms_ms;
}

void bm_ced(benchmark::State& state, const std::string& name, const std::string& preset) {
  const auto& c = clouds().at(name);
  ced::detect_params p;
  p.threads = static_cast<unsigned>(state.range(0));
  p.refine = preset != "five" && ced::preset_refines(preset);  // as `ced detect --preset` does
  p.keypoint_share = preset == "five" ? 0 : ced::preset_keypoint_share(preset);
  const auto mods = preset == "five" ? five_modalities() : ced::preset(preset);
  ced::detection_result r;
  for (auto _ : state) {
    r = ced::detect(c, p, mods);
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  report(state, r, c.size());
}

/// ced6d with another neighbourhood or search (docs/ALGORITHM.md#neighbourhoods).
void bm_neighborhood(benchmark::State& state, const std::string& name, const std::string& spec,
                     ced::search_kind search) {
  const auto& c = clouds().at(name);
  ced::detect_params p;
  p.threads = static_cast<unsigned>(state.range(0));
  p.neighborhood = ced::parse_neighborhood(spec);
  p.search = search;
  const auto mods = ced::preset("ced6d");
  ced::detection_result r;
  for (auto _ : state) {
    r = ced::detect(c, p, mods);
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  report(state, r, c.size());
}

void bm_ced_static(benchmark::State& state, const std::string& name) {
  const auto& c = clouds().at(name);
  ced::detect_params p;
  p.threads = static_cast<unsigned>(state.range(0));
  ced::detection_result r;
  for (auto _ : state) {
    r = ced::detect(c, p, ced::xyz{}, ced::rgb{});
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  report(state, r, c.size());
}

void bm_block_scale(benchmark::State& state, const std::string& name) {
  const auto& c = clouds().at(name);
  ced::detect_params p;
  p.threads = 1;
  p.block_scale = double(state.range(0)) / 100.0;
  ced::detection_result r;
  for (auto _ : state) {
    r = ced::detect(c, p, ced::xyz{}, ced::rgb{});
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  report(state, r, c.size());
}

void bm_baseline(benchmark::State& state, const std::string& name, bool colour) {
  const auto& c = clouds().at(name);
  ced::detect_params p;
  std::vector<std::uint32_t> kp;
  for (auto _ : state) {
    kp = baseline(c, colour, p);
    benchmark::DoNotOptimize(kp.data());
  }
  state.counters["points"] = double(c.size());
  state.counters["keypoints"] = double(kp.size());
}

#ifdef CED_HAS_PCL
/// PCL's detectors with the CED paper's settings, one thread, same cloud.
void bm_pcl(benchmark::State& state, const std::string& name, ced::pcl_bridge::detector d) {
  const auto& c = clouds().at(name);
  ced::pcl_bridge::detector_params p;
  p.threads = 1;
  std::vector<std::uint32_t> kp;
  for (auto _ : state) {
    kp = ced::pcl_bridge::detect(c, d, p);
    benchmark::DoNotOptimize(kp.data());
  }
  state.counters["points"] = double(c.size());
  state.counters["keypoints"] = double(kp.size());
}
#endif

void bm_generated(benchmark::State& state) {
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  const std::string name = "room_" + std::to_string(n);
  if (!clouds().count(name)) clouds()[name] = generated_room(n);
  const auto& c = clouds().at(name);
  ced::detect_params p;
  p.threads = static_cast<unsigned>(state.range(1));
  ced::detection_result r;
  for (auto _ : state) {
    r = ced::detect(c, p, ced::xyz{}, ced::rgb{});
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  report(state, r, c.size());
  state.counters["ns_per_point"] =
      benchmark::Counter(double(n), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// A hyperspectral surface (issue #60): 100,000 points on a gently waved
/// 10 x 10 m sheet (about 31 neighbours within 0.1 m), with `bands` float
/// bands b0000, b0001, ... in [0, 1]: a smooth spectrum per patch plus
/// noise. Deterministic; made once per band count.
const ced::point_cloud& spectral_surface(std::size_t bands) {
  static std::map<std::size_t, ced::point_cloud> made;
  auto it = made.find(bands);
  if (it != made.end()) return it->second;
  constexpr std::size_t n = 100000;
  std::mt19937 rng(60);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ced::point_cloud c;
  c.reserve(n);
  std::vector<int> patch(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float x = 10 * u(rng), y = 10 * u(rng);
    c.push_back(x, y, 0.2f * std::sin(x) * std::cos(0.7f * y));
    patch[i] = int(x / 0.7f) * 31 + int(y / 0.9f);
  }
  for (std::size_t b = 0; b < bands; ++b) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i)
      v[i] = 0.5 + 0.3 * std::sin(0.05 * double(b) + 0.37 * double(patch[i] % 17)) + 0.05 * (u(rng) - 0.5);
    char name[32];
    std::snprintf(name, sizeof name, "b%04zu", b);
    c.add_field(name, ced::scalar_type::float32, std::move(v));
  }
  return made.emplace(bands, std::move(c)).first->second;
}

/// xyz alone (0 bands) or xyz + bands(all of them) on spectral_surface, one
/// thread: the saliency stage's time a band (#60: flat from 4 to 1024).
void bm_bands(benchmark::State& state) {
  const auto bands = static_cast<std::size_t>(state.range(0));
  const auto& c = spectral_surface(bands);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.1;
  p.threads = 1;
  std::vector<ced::any_modality> mods = {ced::make_modality("xyz:0.2")};
  if (bands > 0) mods.push_back(ced::make_modality("bands(b\?\?\?\?):0.1,range=0..1"));
  ced::detection_result r;
  double saliency = 0;
  for (auto _ : state) {
    r = ced::detect(c, p, mods);
    saliency += r.times.saliency_ms;
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  report(state, r, c.size());
  state.counters["saliency_ms"] = saliency / double(state.iterations());
  double neighbours = 0;
  for (auto k : r.neighbor_count) neighbours += k;
  state.counters["mean_neighbours"] = neighbours / double(c.size());
}

/// 10,000 points spread over 10 x 10 x 1 m, and with `crowd` 50,000 more
/// at (0, 0, 0), as LiDAR stores invalid returns (#57).
const ced::point_cloud& crowded_cloud(bool crowd) {
  static ced::point_cloud clouds[2];
  ced::point_cloud& c = clouds[crowd];
  if (!c.empty()) return c;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 60000; ++i)
    if (i % 6 == 0)
      c.push_back(u(rng) * 10, u(rng) * 10, u(rng));
    else if (crowd)
      c.push_back(0, 0, 0);
  return c;
}

/// What coincident points cost (#57): the resolution estimate and the
/// detection at r = 0.5 by each neighbourhood, with the 50,000 points at the
/// origin (arg 1) and without them (arg 0). Before, the estimate crashed and
/// knn:8 took over 20 s with them; the other points took 0.1 s.
void bm_crowded(benchmark::State& state, const std::string& what) {
  const ced::point_cloud& c = crowded_cloud(state.range(0) != 0);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.5;
  p.threads = 1;
  if (what != "resolution" && what != "radius")
    p.neighborhood = ced::parse_neighborhood(what.substr(0, what.find('_')));
  if (what.find("_cgal") != std::string::npos) p.search = ced::search_kind::cgal;
  for (auto _ : state) {
    if (what == "resolution") {
      benchmark::DoNotOptimize(ced::estimate_resolution(c));
      continue;
    }
    const auto r = ced::detect(c, p, ced::xyz{});
    benchmark::DoNotOptimize(r.keypoints.data());
  }
  state.counters["points"] = double(c.size());
}

}  // namespace

/// Resident memory now (`VmRSS`) or at its peak since the last reset
/// (`VmHWM`), in bytes, from /proc/self/status; 0 when unavailable.
double status_bytes(const char* key) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return 0;
  char line[256];
  double kb = 0;
  const std::size_t n = std::strlen(key);
  while (std::fgets(line, sizeof line, f))
    if (std::strncmp(line, key, n) == 0) kb = std::atof(line + n + 1);
  std::fclose(f);
  return kb * 1024.0;
}

/// `--memory N`: generates an N-point room, runs ced6d once with all cores,
/// and prints the time and the peak memory beyond the input cloud: the peak
/// is reset after the cloud is made (/proc/self/clear_refs), so what making
/// it cost does not count.
int memory_mode(std::size_t n) {
  const ced::point_cloud c = generated_room(n);
  if (std::FILE* f = std::fopen("/proc/self/clear_refs", "w")) {  // resets VmHWM to VmRSS
    std::fputs("5", f);
    std::fclose(f);
  }
  const double before = status_bytes("VmRSS:");
  ced::detect_params p;
  const auto r = ced::detect(c, p, ced::xyz{}, ced::rgb{});
  const double after = std::max(status_bytes("VmHWM:"), before);
  std::printf(
      "points %zu keypoints %zu detect_ms %.1f (index %.1f saliency %.1f nms %.1f) "
      "input_bytes_per_point %.0f peak_extra_bytes_per_point %.0f peak_rss_MB %.0f\n",
      n, r.keypoints.size(), r.times.total_ms(), r.times.index_ms, r.times.saliency_ms, r.times.nms_ms,
      before / double(n), (after - before) / double(n), after / 1e6);
  return 0;
}

/// `--write-las N PATH`: the N-point room as a LAS 1.2 file of point format 3
/// (34 bytes a point: the usual airborne fields, gps_time and 16-bit colour
/// holding 8-bit values), for measuring the whole CLI on a large LAS file.
/// Deterministic (seeded).
int write_las_mode(std::size_t n, const std::string& path) {
  ced::point_cloud c = generated_room(n);
  std::mt19937 rng(1234);
  std::uniform_int_distribution<int> u(0, 255);
  auto add = [&](const char* name, ced::scalar_type t, auto value) {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = value(i);
    c.add_field(name, t, std::move(v));
  };
  add("return_number", ced::scalar_type::uint8, [](std::size_t) { return 1.0; });
  add("number_of_returns", ced::scalar_type::uint8, [](std::size_t) { return 1.0; });
  add("classification", ced::scalar_type::uint8, [](std::size_t i) { return i % 5 < 3 ? 2.0 : 6.0; });
  add("scan_angle", ced::scalar_type::int8, [&](std::size_t) { return double(u(rng) % 41 - 20); });
  add("user_data", ced::scalar_type::uint8, [](std::size_t) { return 0.0; });
  add("point_source_id", ced::scalar_type::uint16, [](std::size_t i) { return double(1 + i / 1000000); });
  add("gps_time", ced::scalar_type::float64, [](std::size_t i) { return 1e5 + double(i) * 1e-5; });
  for (const char* name : {"red", "green", "blue"}) {  // LAS colour: 16-bit fields
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = c.get_field(name).values[i];
    c.add_field(name, ced::scalar_type::uint16, std::move(v));
  }
  ced::point_cloud out;  // the LAS fields only
  out.positions() = c.positions();
  for (const char* name : {"intensity", "return_number", "number_of_returns", "classification", "scan_angle",
                           "user_data", "point_source_id", "gps_time", "red", "green", "blue"}) {
    const auto& f = c.get_field(name);
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = f.values[i];
    out.add_field(name, f.type(), std::move(v));
  }
  ced::io::las_write_options o;
  o.version_minor = 2;
  ced::io::write_las(path, out, o);
  std::printf("wrote %zu points to %s\n", n, path.c_str());
  return 0;
}

/// The Redwood scans in `data` (a generated room when none is there), with
/// their synthetic channels; their names.
std::vector<std::string> load_clouds(const std::string& data) {
  std::vector<std::string> names;
  for (const char* f : {"apartment_mesh_213", "apartment_mesh_214", "loft_mesh_240"}) {
    const std::string path = data + "/" + f + ".ply";
    if (std::filesystem::exists(path)) {
      clouds()[f] = ced::io::read_ply(path);
      add_synthetic_channels(clouds()[f]);
      names.push_back(f);
    }
  }
  if (names.empty()) {
    std::fprintf(stderr, "bench_detect: no Redwood scans in %s; using a generated 100k-point room\n", data.c_str());
    clouds()["room_100k"] = generated_room(100000);
    names.push_back("room_100k");
  }
  return names;
}

/// Prints how the baseline's keypoints and ced's compare on each cloud.
void check_against_baseline(const std::vector<std::string>& names) {
  // Check: the baseline and ced agree on keypoints.
  for (const auto& name : names) {
    const auto& c = clouds().at(name);
    ced::detect_params p;
    for (const char* preset : {"ced6d", "ced3d"}) {
      const auto mine = ced::detect(c, p, ced::preset(preset)).keypoints;
      const auto base = baseline(c, std::string(preset) == "ced6d", p);
      std::size_t common = 0;
      for (std::size_t a = 0, b = 0; a < mine.size() && b < base.size();) {
        if (mine[a] == base[b])
          ++common, ++a, ++b;
        else if (mine[a] < base[b])
          ++a;
        else
          ++b;
      }
      std::fprintf(stderr, "check %-20s %s: ced %zu keypoints, baseline %zu, common %zu\n", name.c_str(), preset,
                   mine.size(), base.size(), common);
    }
  }
}

void register_benchmarks(const std::vector<std::string>& names) {
  for (const char* what : {"resolution", "knn:8", "adaptive:8", "knn:8_cgal", "radius"})
    benchmark::RegisterBenchmark((std::string("crowded/") + what).c_str(), bm_crowded, std::string(what))
        ->Arg(0)
        ->Arg(1)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  for (const auto& name : names) {
    for (int t : {1, 2}) {
      benchmark::RegisterBenchmark(("ced6d/" + name).c_str(), bm_ced, name, std::string("ced6d"))
          ->Arg(t)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
    benchmark::RegisterBenchmark(("ced6d_static/" + name).c_str(), bm_ced_static, name)
        ->Arg(1)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("ced3d/" + name).c_str(), bm_ced, name, std::string("ced3d"))
        ->Arg(1)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    for (const char* robust : {"robust6d", "robust3d", "corner3d"})  // robust: ≤ 3 × ced6d / ced3d (#16)
      benchmark::RegisterBenchmark((std::string(robust) + "/" + name).c_str(), bm_ced, name, std::string(robust))
          ->Arg(1)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    for (const char* spec : {"knn:16", "adaptive:16"})  // ≤ 3 × ced6d (#30)
      benchmark::RegisterBenchmark(("ced6d_" + std::string(spec) + "/" + name).c_str(), bm_neighborhood, name,
                                   std::string(spec), ced::search_kind::grid)
          ->Arg(1)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    benchmark::RegisterBenchmark(("ced6d_search_cgal/" + name).c_str(), bm_neighborhood, name, std::string("radius"),
                                 ced::search_kind::cgal)
        ->Arg(1)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("five_modalities/" + name).c_str(), bm_ced, name, std::string("five"))
        ->Arg(1)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("block_scale_x100/" + name).c_str(), bm_block_scale, name)
        ->Arg(100)
        ->Arg(200)
        ->Arg(300)
        ->Arg(400)
        ->Arg(600)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("baseline_cgal_per_point_6d/" + name).c_str(), bm_baseline, name, true)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
#ifdef CED_HAS_PCL
    using ced::pcl_bridge::detector;
    for (auto [label, d] : {std::pair{"pcl_iss3d/", detector::iss3d}, std::pair{"pcl_harris3d/", detector::harris3d},
                            std::pair{"pcl_harris6d/", detector::harris6d}})
      benchmark::RegisterBenchmark((label + name).c_str(), bm_pcl, name, d)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
#endif
  }
  benchmark::RegisterBenchmark("bands", bm_bands)
      ->ArgsProduct({{0, 1, 4, 16, 64, 192, 1024}})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("generated_room_ced6d", bm_generated)
      ->ArgsProduct({{10000, 100000, 1000000}, {1, 2}})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
}

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--memory") == 0) return memory_mode(std::stoul(argv[2]));
  if (argc == 4 && std::strcmp(argv[1], "--write-las") == 0) return write_las_mode(std::stoul(argv[2]), argv[3]);
  std::string data = "../shared/data/redwood_scan";
  bool check = true;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--no-check") == 0) {
      check = false;
      continue;
    }
    if (std::strcmp(argv[i], "--data") == 0 && i + 1 < argc) {
      data = argv[++i];
      continue;
    }
    if (std::strcmp(argv[i], "--isa") == 0 && i + 1 < argc) {  // e.g. avx2 on an AVX-512 machine
      ced::detail::force_kernel_isa(argv[++i]);
      continue;
    }
    args.push_back(argv[i]);
  }
  int nargs = static_cast<int>(args.size());
  const std::vector<std::string> names = load_clouds(data);
  if (check) check_against_baseline(names);
  register_benchmarks(names);
  benchmark::AddCustomContext("ced_kernel", ced::detail::kernel_isa());
  benchmark::Initialize(&nargs, args.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
