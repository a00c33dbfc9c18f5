// SPDX-License-Identifier: MIT
// `ced eval registration`: registration success with keypoints, FPFH/PFHRGB,
// mutual matching and RANSAC. Needs ced's PCL component (CED_HAS_PCL).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <ostream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/io.hpp"
#include "ced/io/rgbd.hpp"
#include "ced/preprocess.hpp"
#include "commands.hpp"
#include "common.hpp"
#include "detectors.hpp"
#ifdef CED_HAS_PCL
#include "pcl_bridge.hpp"
#endif

namespace ced_cli {
namespace {

struct registration_options : pair_options {  // --rgbd: consecutive frames
  std::string input, format = "auto", columns;
  std::vector<std::string> detectors{"ced6d", "random", "ced3d", "iss3d", "harris3d", "harris6d", "sift"};
  std::string descriptor = "auto";
  int trials = 5, iterations = 20000, min_neighbors = 5, threads = 0;
  std::uint64_t seed = 1;
  double overlap = 0.4, noise = 0, max_translation = 1.0;
  double resolution = 0, radius = 0, nms_radius = 0, voxel = 0;
  double normal_radius = 3, feature_radius = 5, inlier_distance = 2.5;  // in multiples of the resolution
  double inlier_fraction = 0.1;
  double max_rotation_error = 5, max_translation_error = 0.2;
  double max_rmse = 0.2;  // 3DMatch's registration recall: RMSE over the overlap below this, metres
  std::string counts;     // --counts: every detector at these keypoint counts
  std::string csv;
  bool quiet = false;
};

/// The numbers and modes: usage errors before anything is read (with or
/// without PCL).
void check_registration_numbers(const registration_options& o) {
  if (o.trials < 1 || o.trials > 10000) throw usage_error("--trials must be 1..10000");
  if (o.iterations < 1) throw usage_error("--iterations must be >= 1");
  if (!(o.overlap > 0 && o.overlap < 1)) throw usage_error("--overlap must be in (0, 1)");
  const std::pair<double, const char*> positive[] = {{o.normal_radius, "--normal-radius"},
                                                     {o.feature_radius, "--feature-radius"},
                                                     {o.inlier_distance, "--inlier-distance"},
                                                     {o.max_rotation_error, "--max-rotation-error"},
                                                     {o.max_translation_error, "--max-translation-error"}};
  for (const auto& [v, name] : positive)
    if (!(v > 0) || !std::isfinite(v)) throw usage_error(std::string(name) + " must be a positive number");
  check_length(o.noise, "--noise");
  check_length(o.resolution, "--resolution", "0 = estimated");
  check_length(o.radius, "--radius", "0 = 5 x resolution");
  check_length(o.nms_radius, "--nms-radius", "0 = the radius");
  check_length(o.voxel, "--voxel", "0 = none");
  check_length(o.max_translation, "--max-translation");
  check_length(o.depth_max, "--depth-max", "0 = none");
  check_counts(o.min_neighbors, o.threads);
  check_length(o.max_rmse, "--max-rmse");
  if (!(o.max_rmse > 0)) throw usage_error("--max-rmse must be > 0");
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

/// Consecutive frames of an Open3D RGB-D folder (load_rgbd_frames).
std::vector<registration_pair> rgbd_pairs(const registration_options& o) {
  const rgbd_frames f = load_rgbd_frames(o.rgbd, o.intrinsics, o.depth_max, o.voxel);
  std::vector<registration_pair> pairs;
  for (std::size_t i = 0; i + 1 < f.clouds.size(); ++i) {
    registration_pair p;
    p.name = "rgbd " + std::to_string(i) + "-" + std::to_string(i + 1);
    p.source = f.clouds[i];
    p.target = f.clouds[i + 1];
    p.truth = f.source_to_target(i, i + 1);
    pairs.push_back(std::move(p));
  }
  return pairs;
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
  r.threads = ced::resolve_threads(static_cast<unsigned>(std::max(0, o.threads)));
  return r;
}

struct registration_stats {
  int runs = 0, successes = 0, recalled = 0;
  double kp = 0, matches = 0, inliers = 0, inlier_ratio = 0, ms = 0;
};

/// What every run on one pair shares.
struct pair_setup {
  const registration_pair& pair;
  const eval_setting& setting;
  const ced::pcl_bridge::registration_params& params;
  const char* descriptor;
  ced::eval::rigid_transform truth;           // absolute
  const std::vector<std::uint32_t>& overlap;  // the source's points in the overlap (rmse_over)
};

/// The source points (local frame) whose ground-truth image lies within
/// `distance` of a target point: where an estimate's RMSE is measured.
std::vector<std::uint32_t> overlap_points(const registration_pair& pair, double distance) {
  const ced::eval::real_pair rp(pair.source, pair.target, pair.truth, distance);
  std::vector<std::uint32_t> out;
  for (std::uint32_t i = 0; i < pair.source.size(); ++i)
    if (rp.in_overlap(i)) out.push_back(i);
  return out;
}

/// 3DMatch's registration error: the RMSE, over the source's points in the
/// overlap, between their images under the estimate and under the truth
/// (both local maps); infinity when there is no overlap.
double rmse_over(const registration_pair& pair, const std::vector<std::uint32_t>& overlap,
                 const ced::eval::rigid_transform& estimate) {
  if (overlap.empty()) return std::numeric_limits<double>::infinity();
  double sum = 0;
  for (const std::uint32_t i : overlap) {
    const float* p = pair.source.position(i);
    const std::array<double, 3> x{p[0], p[1], p[2]};
    const auto a = estimate.apply(x), b = pair.truth.apply(x);
    for (int k = 0; k < 3; ++k) sum += (a[k] - b[k]) * (a[k] - b[k]);
  }
  return std::sqrt(sum / double(overlap.size()));
}

/// Detects with `detector` on both clouds of the pair, registers them, and
/// reports the run: a table row, a CSV row, the detector's statistics.
void register_once(const registration_options& o, const eval_detector& detector, const pair_setup& ps, int trial,
                   std::size_t& last_count, std::mt19937_64& rng, registration_stats& st, std::ostream* csv) {
  const registration_pair& pair = ps.pair;
  const detection a = run_detector(detector, pair.source, ps.setting, last_count, rng);
  const detection b = run_detector(detector, pair.target, ps.setting, last_count, rng);
  if (detector.type != eval_detector::kind::random) last_count = std::max<std::size_t>(1, a.keypoints.size());
  const auto r = ced::pcl_bridge::register_keypoints(pair.source, a.keypoints, pair.source_viewpoint, pair.target,
                                                     b.keypoints, pair.target_viewpoint, ps.params);
  const auto estimate = ced::eval::to_absolute(r.transform, pair.source.origin(), pair.target.origin());
  const double rot = ced::eval::rotation_error_deg(estimate, ps.truth);
  const double trans = ced::eval::translation_error(estimate, ps.truth);
  const bool success = r.converged && rot < o.max_rotation_error && trans < o.max_translation_error;
  const double rmse = r.converged ? rmse_over(pair, ps.overlap, r.transform) : std::numeric_limits<double>::infinity();
  const bool recalled = r.converged && rmse < o.max_rmse;
  const double inlier_ratio = r.matches ? double(r.inliers) / double(r.matches) : 0.0;
  const double detect_ms = (a.ms + b.ms) / 2, register_ms = r.features_ms + r.ransac_ms;
  ++st.runs;
  st.successes += success;
  st.recalled += recalled;
  st.inlier_ratio += inlier_ratio;
  st.kp += double(a.keypoints.size());
  st.matches += double(r.matches);
  st.inliers += double(r.inliers);
  st.ms += detect_ms + register_ms;
  std::printf("%-28s %-14s %5d %8zu %8zu %8zu %9.2f %9.3f %9.3f %7s %9.1f\n", detector.name.c_str(), pair.name.c_str(),
              trial, a.keypoints.size(), r.matches, r.inliers, rot, trans, rmse, success ? "yes" : "no",
              detect_ms + register_ms);
  if (csv)
    *csv << '"' << detector.name << "\",\"" << pair.name << "\"," << trial << ',' << ps.descriptor << ','
         << a.keypoints.size() << ',' << b.keypoints.size() << ',' << r.matches << ',' << r.inliers << ',' << rot << ','
         << trans << ',' << (success ? 1 : 0) << ',' << detect_ms << ',' << register_ms << ',' << rmse << ','
         << (recalled ? 1 : 0) << ',' << inlier_ratio << '\n';
}

/// Every detector on `pair`, `repeats` times (new seeds each time).
void register_pair(const registration_options& o, const std::vector<eval_detector>& detectors,
                   const registration_pair& pair, int repeats, std::mt19937_64& master,
                   std::vector<registration_stats>& stats, std::ostream* csv) {
  const eval_setting s =
      make_setting(pair.source, pair.name, o.resolution, o.radius, o.min_neighbors, o.threads, o.nms_radius);
  auto params = make_registration_params(o, pair, s.resolution);
  const char* descriptor = params.feature == ced::pcl_bridge::descriptor::pfhrgb ? "pfhrgb" : "fpfh";
  if (!o.quiet)
    std::fprintf(stderr, "ced eval: %s: %zu -> %zu points, resolution %g, %s, normal radius %g, feature radius %g\n",
                 pair.name.c_str(), pair.source.size(), pair.target.size(), s.resolution, descriptor,
                 params.normal_radius, params.feature_radius);
  const auto truth = ced::eval::to_absolute(pair.truth, pair.source.origin(), pair.target.origin());
  const std::vector<std::uint32_t> overlap = overlap_points(pair, params.inlier_distance);
  for (int trial = 0; trial < repeats; ++trial) {
    std::mt19937_64 rng(master());
    params.seed = static_cast<unsigned>(rng());
    const pair_setup ps{pair, s, params, descriptor, truth, overlap};
    std::size_t last_count = std::max<std::size_t>(1, pair.source.size() / 100);
    for (std::size_t d = 0; d < detectors.size(); ++d)
      register_once(o, detectors[d], ps, trial, last_count, rng, stats[d], csv);
  }
}

void print_registration_summary(const std::vector<eval_detector>& detectors,
                                const std::vector<registration_stats>& stats, double max_rmse) {
  std::printf("\n%-28s %8s %8s %8s %8s %8s %10s %8s %9s\n", "detector", "runs", "success", "recall", "kp(P)", "matches",
              "inliers", "ratio", "ms");
  for (std::size_t d = 0; d < detectors.size(); ++d) {
    const auto& st = stats[d];
    const double n = std::max(1, st.runs);
    std::printf("%-28s %8d %7.0f%% %7.0f%% %8.1f %8.1f %10.1f %8.3f %9.1f\n", detectors[d].name.c_str(), st.runs,
                100.0 * st.successes / n, 100.0 * st.recalled / n, st.kp / n, st.matches / n, st.inliers / n,
                st.inlier_ratio / n, st.ms / n);
  }
  std::printf(
      "(success: rotation and translation errors below their bounds; recall: RMSE over the overlap below %g m, "
      "3DMatch's; ratio: inliers / matches)\n",
      max_rmse);
}

int run_registration(const registration_options& o) {
  std::vector<eval_detector> detectors = parse_detectors(o.detectors, o.neighborhood, o.search);
  check_registration_numbers(o);
  detectors = detectors_at_counts(std::move(detectors), o.counts, o.quiet);
  ced::pcl_bridge::require_pcl();  // registration is PCL's: a missing module stops here, before any work
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);
  int repeats = 1;
  const std::vector<registration_pair> pairs = registration_pairs(o, repeats);
  if (csv)
    csv->stream()
        << "detector,pair,trial,descriptor,source_keypoints,target_keypoints,matches,inliers,"
           "rotation_error_deg,translation_error_m,success,detect_ms,register_ms,rmse_m,recall,inlier_ratio\n";
  std::printf("%-28s %-14s %5s %8s %8s %8s %9s %9s %9s %7s %9s\n", "detector", "pair", "trial", "kp(P)", "matches",
              "inliers", "rot.err", "trans.err", "rmse", "success", "ms");
  std::vector<registration_stats> stats(detectors.size());
  std::mt19937_64 master(o.seed ^ 0x5eedULL);
  for (const auto& pair : pairs)
    register_pair(o, detectors, pair, repeats, master, stats, csv ? &csv->stream() : nullptr);
  print_registration_summary(detectors, stats, o.max_rmse);
  if (csv) csv->commit();
  return exit_ok;
}

#else

int run_registration(const registration_options& o) {
  check_registration_numbers(o);
  throw usage_error(std::string("ced eval registration ") + no_pcl_message);
}

#endif

}  // namespace

command add_registration_command(CLI::App& eval) {
  auto o = std::make_shared<registration_options>();
  auto* reg = eval.add_subcommand(
      "registration", "Registration success: keypoints, FPFH/PFHRGB, mutual matching, RANSAC (needs a PCL build)");
  add_input_options(reg, o->input, "Cloud to cut into two overlapping crops (or --source/--target, or --rgbd)",
                    o->format, o->columns);
  add_pair_options(reg, *o, "consecutive frame pairs");
  one_value_each(
      reg->add_option("-d,--detector", o->detectors,
                      "Repeatable, as for repeatability (default: ced6d random ced3d iss3d harris3d harris6d sift; "
                      "'ced3d|knn:16' gives a ced detector its own neighbourhood)"));
  reg->add_option("--descriptor", o->descriptor, "fpfh, pfhrgb, or auto = pfhrgb when both clouds have colour");
  reg->add_option("--trials", o->trials, "Synthetic pairs for INPUT; runs per pair (new seeds) otherwise (default 5)");
  reg->add_option("--seed", o->seed, "Seed (default 1)");
  reg->add_option("--overlap", o->overlap, "INPUT: the crops share this fraction of the longest extent (default 0.4)");
  reg->add_option("--noise", o->noise, "INPUT: Gaussian noise on the moved crop, x resolution (default 0)");
  reg->add_option("--max-translation", o->max_translation, "INPUT: translations uniform in +-this, metres (default 1)");
  reg->add_option("--voxel", o->voxel, "Voxel down-sampling of the input clouds, metres (default none)");
  reg->add_option("--resolution", o->resolution, "Resolution in metres (default: estimated on the source)");
  reg->add_option("-r,--radius", o->radius, "Detector radius, metres (default 5 x resolution)");
  reg->add_option("--nms-radius", o->nms_radius,
                  "NMS radius of ced's detectors and ISS3D, metres (default: the radius)");
  reg->add_option("-k,--min-neighbors", o->min_neighbors, "Minimum neighbours (default 5)");
  reg->add_option("--normal-radius", o->normal_radius, "Normal estimation radius, x resolution (default 3)");
  reg->add_option("--feature-radius", o->feature_radius, "Descriptor radius, x resolution (default 5)");
  reg->add_option("--inlier-distance", o->inlier_distance, "RANSAC inlier distance, x resolution (default 2.5)");
  reg->add_option("--inlier-fraction", o->inlier_fraction, "RANSAC: minimum inliers / matches (default 0.1)");
  reg->add_option("--iterations", o->iterations, "RANSAC iterations (default 20000)");
  reg->add_option("--max-rotation-error", o->max_rotation_error, "Success: rotation error below, degrees (default 5)");
  reg->add_option("--max-translation-error", o->max_translation_error,
                  "Success: translation error below, metres (default 0.2)");
  reg->add_option("--max-rmse", o->max_rmse,
                  "Recall: the RMSE of the estimate over the source's points in the overlap below this, metres "
                  "(default 0.2, 3DMatch's)");
  reg->add_option("--counts", o->counts,
                  "Every detector at these keypoint counts, e.g. 250,500,1000: the N strongest (random: N points; "
                  "ISS3D and SIFT, which have no response, at their natural count)");
  reg->add_option("-j,--threads", o->threads, "Threads");
  reg->add_option("--csv", o->csv, "Write one row per detector x pair x trial");
  reg->add_flag("-q,--quiet", o->quiet, "Print only the tables");
  return {reg, [o] {
            check_paths(eval_input_paths(o->input, o->source, o->target, o->transform, o->rgbd, o->intrinsics),
                        {{"--csv", o->csv}});
            return run_registration(*o);
          }};
}

}  // namespace ced_cli
