// SPDX-License-Identifier: MIT
// `ced eval repeatability`: relative repeatability under a random rigid
// transform and noise, or on a given pair. Also the `eval` group itself.
#include "ced/eval.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "commands.hpp"
#include "common.hpp"
#include "detectors.hpp"

namespace ced_cli {
namespace {

struct eval_options : pair_options {  // --rgbd: frame 0 against each later one
  std::string input, format = "auto", columns;
  std::vector<std::string> detectors{"ced6d", "ced3d", "random"};
  int trials = 5;
  std::uint64_t seed = 1;
  std::string noise = "0,0.5";
  std::string counts;  // --counts: every detector at these keypoint counts
  double epsilon = 2.0, resolution = 0, radius = 0, nms_radius = 0, max_translation = 1.0;
  // A given pair (--source/--target): both voxelised to this size first (the
  // paper's 1 cm when not given; 0: as they are); epsilon at least the
  // ground truth's error; the random baseline's number of draws.
  double voxel = -1, gt_error = 0.01;
  int random_draws = 100;
  bool noise_given = false, epsilon_given = false, pair_options_given = false, depth_max_given = false;
  int min_neighbors = 5, threads = 0;
  std::string csv;
  bool quiet = false;
};

/// Mean and standard deviation of the relative repeatability per detector.
struct repeat_stats {
  double sum = 0, sum2 = 0, kp = 0, ms = 0;
  int n = 0;
  std::string not_available;  ///< why the detector cannot run on the cloud (its row is "n/a")
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
  if (!st.not_available.empty()) {
    std::printf("%-28s %8s %10s %12s %10s %10s\n", name.c_str(), noise.c_str(), "n/a", "n/a", "", "");
    return;
  }
  const double n = std::max(1, st.n), mean = st.sum / n;
  const double sd = std::sqrt(std::max(0.0, st.sum2 / n - mean * mean));
  std::printf("%-28s %8s %10.1f %12.3f %10.3f %10.1f\n", name.c_str(), noise.c_str(), st.kp / n, mean, sd, st.ms / n);
}

/// The columns of `ced eval repeatability --csv` (one row per repeat_once() measurement).
constexpr const char* repeat_csv_header =
    "detector,noise_resolution,noise_m,trial,source_keypoints,target_keypoints,repeated,relative_repeatability,"
    "detect_ms\n";

/// Runs `d` on P and Q; nullopt, and the reason in `why`, when it cannot run
/// on them (a modality whose fields a cloud lacks, colour for a colourless
/// cloud): its row is "n/a" and the table goes on.
std::optional<std::pair<detection, detection>> try_detector(const eval_detector& d, const ced::point_cloud& p,
                                                            const ced::point_cloud& q, const eval_setting& s,
                                                            std::size_t random_count, std::mt19937_64& rng,
                                                            std::string& why) {
  try {
    detection a = run_detector(d, p, s, random_count, rng);
    detection b = run_detector(d, q, s, random_count, rng);
    return std::make_pair(std::move(a), std::move(b));
  } catch (const std::invalid_argument& e) {
    why = e.what();
    return std::nullopt;
  }
}

/// Says once on stderr why a detector's row is n/a.
void report_not_available(const std::string& name, const std::string& why, bool quiet) {
  if (!quiet) std::fprintf(stderr, "ced eval: %s: n/a: %s\n", name.c_str(), why.c_str());
}

/// Runs every detector on P and Q and measures; one CSV row each.
void repeat_once(const std::vector<eval_detector>& detectors, const ced::point_cloud& p, const ced::point_cloud& q,
                 const ced::eval::rigid_transform& t, const eval_setting& s, double eps, std::mt19937_64& rng,
                 std::vector<repeat_stats>& stats, std::ostream* csv, const std::string& csv_prefix, bool quiet) {
  std::size_t last_count = std::max<std::size_t>(1, p.size() / 100);
  for (std::size_t d = 0; d < detectors.size(); ++d) {
    if (!stats[d].not_available.empty()) continue;
    std::string why;
    const auto ab = try_detector(detectors[d], p, q, s, last_count, rng, why);
    if (!ab) {
      stats[d].not_available = why;
      report_not_available(detectors[d].name, why, quiet);
      continue;
    }
    const auto& [a, b] = *ab;
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
  if (o.random_draws < 1 || o.random_draws > 100000) throw usage_error("--random-draws must be 1..100000");
  if (o.voxel != -1) check_length(o.voxel, "--voxel", "0 = as they are");
  check_length(o.gt_error, "--gt-error", "0 = no floor");
  check_length(o.depth_max, "--depth-max", "0 = none");
  if (!(o.epsilon > 0) || !std::isfinite(o.epsilon)) throw usage_error("--epsilon must be a positive number");
  check_length(o.resolution, "--resolution", "0 = estimated");
  check_length(o.radius, "--radius", "0 = 5 x resolution");
  check_length(o.nms_radius, "--nms-radius", "0 = the radius");
  check_length(o.max_translation, "--max-translation");
  check_counts(o.min_neighbors, o.threads);
}

/// Chooses the mode: INPUT (synthetic transforms), or given pairs
/// (--source/--target, or --rgbd).
bool user_pair_mode(const eval_options& o) {
  const bool pair = !o.source.empty() || !o.target.empty();
  const int modes = !o.input.empty() + pair + !o.rgbd.empty();
  if (modes == 0) throw usage_error("give INPUT, or --source P --target Q [--transform T.txt], or --rgbd DIR");
  if (modes > 1) throw usage_error("give exactly one of INPUT, --source P --target Q, or --rgbd DIR");
  if (pair && (o.source.empty() || o.target.empty())) throw usage_error("--source and --target go together");
  if (!pair && !o.transform.empty()) throw usage_error("--transform goes with --source and --target");
  if (o.rgbd.empty() && (!o.intrinsics.empty() || o.depth_max_given))
    throw usage_error("--intrinsics and --depth-max go with --rgbd");
  return pair || !o.rgbd.empty();
}

/// The columns of `ced eval repeatability --source --target --csv` (and --rgbd).
constexpr const char* pair_csv_header =
    "detector,pair,source_keypoints,target_keypoints,overlap_keypoints,repeated,relative_repeatability,"
    "random_relative,lift,detect_ms\n";

/// One real pair: P, Q and the ground truth, P's local frame to Q's.
struct pair_input {
  std::string name;
  ced::point_cloud p, q;
  ced::eval::rigid_transform t;
};

/// What every detector of a given pair shares.
struct pair_setup {
  const pair_input& in;
  const ced::eval::real_pair& pair;
  const eval_setting& s;
  int draws;
  bool quiet;
  std::uint64_t seed;
  std::size_t index;  ///< of the pair
};

/// The random numbers of one use on one pair: seeded from --seed, the pair,
/// the use and its counts alone, so that a row's figures do not depend on
/// which detectors came before it (the same counts give the same chance).
std::mt19937_64 pair_draws(const pair_setup& ps, std::uint32_t use, std::size_t source_count,
                           std::size_t target_count) {
  std::seed_seq seq{std::uint32_t(ps.seed),      std::uint32_t(ps.seed >> 32), std::uint32_t(ps.index), use,
                    std::uint32_t(source_count), std::uint32_t(target_count)};
  return std::mt19937_64(seq);
}

/// Each detector's lifts over the pairs (for the mean) and its n/a pairs.
struct lift_stats {
  double sum = 0;
  int n = 0, not_available = 0;
};

/// One detector on the pair: a table row and a CSV row; "n/a" when it cannot
/// run on the clouds. `last_count`: the count random draws (the previous detector's).
void pair_row(const eval_detector& d, const pair_setup& ps, std::size_t& last_count, lift_stats& st,
              std::ostream* csv) {
  std::string why;
  std::mt19937_64 picks = pair_draws(ps, 1, last_count, last_count);  // (the random detector's keypoints)
  const auto ab = try_detector(d, ps.in.p, ps.in.q, ps.s, last_count, picks, why);
  const char* pair = ps.in.name.c_str();
  if (!ab) {
    report_not_available(d.name + " on " + ps.in.name, why, ps.quiet);
    std::printf("%-28s %-10s %7s %7s %8s %8s %8s %6s %8s\n", d.name.c_str(), pair, "n/a", "n/a", "n/a", "n/a", "n/a",
                "n/a", "");
    if (csv) *csv << '"' << d.name << "\",\"" << ps.in.name << "\",,,,,n/a,,,\n";
    ++st.not_available;
    return;
  }
  const auto& [a, b] = *ab;
  if (d.type != eval_detector::kind::random) last_count = std::max<std::size_t>(1, a.keypoints.size());
  const auto r = ps.pair.measure(a.keypoints, b.keypoints);
  std::mt19937_64 draws = pair_draws(ps, 2, a.keypoints.size(), b.keypoints.size());
  const double chance = ps.pair.random_relative(a.keypoints.size(), b.keypoints.size(), std::size_t(ps.draws), draws);
  const double lift = chance > 0 ? r.relative() / chance : std::nan("");
  const double ms = (a.ms + b.ms) / 2;
  // No lift without a chance to beat: no keypoint in the overlap (the clouds
  // do not overlap), or none that a random detector repeats.
  const std::string no_lift = r.overlap_keypoints == 0 ? "no overlap" : "n/a";
  char lift_text[32];
  std::snprintf(lift_text, sizeof lift_text, "%6.2f", lift);
  std::printf("%-28s %-10s %7zu %7zu %8zu %8.3f %8.3f %6s %8.1f\n", d.name.c_str(), pair, r.source_keypoints,
              r.overlap_keypoints, r.repeated, r.relative(), chance, std::isfinite(lift) ? lift_text : no_lift.c_str(),
              ms);
  if (std::isfinite(lift)) {
    st.sum += lift;
    ++st.n;
  }
  if (r.overlap_keypoints < 50 && !ps.quiet)
    std::fprintf(stderr,
                 "ced eval: warning: %s on %s: only %zu keypoints lie in the overlap (fewer than 50): its "
                 "figures are noisy\n",
                 d.name.c_str(), pair, r.overlap_keypoints);
  if (csv) {
    *csv << '"' << d.name << "\",\"" << ps.in.name << "\"," << r.source_keypoints << ',' << r.target_keypoints << ','
         << r.overlap_keypoints << ',' << r.repeated << ',' << r.relative() << ',' << chance << ',';
    if (std::isfinite(lift))
      *csv << lift;
    else
      *csv << no_lift;
    *csv << ',' << ms << '\n';
  }
}

/// The match distance of a given pair: --epsilon × resolution when given,
/// else 2 × resolution but at least the ground truth's error (--gt-error);
/// a warning when a given epsilon is below that error.
double pair_epsilon(const eval_options& o, double res) {
  if (!o.epsilon_given) return std::max(2 * res, o.gt_error);
  const double eps = o.epsilon * res;
  if (eps < o.gt_error && !o.quiet)
    std::fprintf(stderr,
                 "ced eval: warning: epsilon %g m is below the ground truth's error (--gt-error %g m): a "
                 "repeated keypoint may not be found where the pose puts it, for any detector\n",
                 eps, o.gt_error);
  return eps;
}

/// --source/--target (one pair) or --rgbd (frame 0 with each later frame),
/// voxelised to `voxel`.
std::vector<pair_input> real_pairs(const eval_options& o, double voxel) {
  std::vector<pair_input> pairs;
  if (!o.rgbd.empty()) {
    const rgbd_frames f = load_rgbd_frames(o.rgbd, o.intrinsics, o.depth_max, voxel);
    for (std::size_t j = 1; j < f.clouds.size(); ++j) {
      pair_input in{"rgbd 0-" + std::to_string(j), f.clouds[0], f.clouds[j], {}};
      in.t = ced::eval::to_local(f.source_to_target(0, j), in.p.origin(), in.q.origin());
      pairs.push_back(std::move(in));
    }
    return pairs;
  }
  const ced::eval::rigid_transform absolute =
      o.transform.empty() ? ced::eval::rigid_transform{} : ced::eval::read_transform(o.transform);
  pair_input in{
      "pair", read_finite(o.source, o.format, o.columns, voxel), read_finite(o.target, o.format, o.columns, voxel), {}};
  in.t = ced::eval::to_local(absolute, in.p.origin(), in.q.origin());
  pairs.push_back(std::move(in));
  return pairs;
}

/// Each detector's mean lift over the pairs (with more than one pair).
void print_mean_lifts(const std::vector<eval_detector>& detectors, const std::vector<lift_stats>& stats) {
  std::printf("\n%-28s %9s %6s %6s\n", "detector", "mean lift", "pairs", "n/a");
  for (std::size_t d = 0; d < detectors.size(); ++d) {
    if (stats[d].n)
      std::printf("%-28s %9.2f %6d %6d\n", detectors[d].name.c_str(), stats[d].sum / stats[d].n, stats[d].n,
                  stats[d].not_available);
    else
      std::printf("%-28s %9s %6d %6d\n", detectors[d].name.c_str(), "n/a", 0, stats[d].not_available);
  }
}

/// `ced eval repeatability --source P --target Q [--transform T]` or
/// `--rgbd DIR`: real scans and their ground-truth poses. Both clouds are
/// voxelised to a common size (default 1 cm, the paper's resolution), the
/// radius and epsilon follow from it, only keypoints of P in the overlap
/// count, and each detector's lift over random detectors with its counts is
/// reported.
int run_eval_pairs(const eval_options& o, const std::vector<eval_detector>& detectors) {
  if (o.noise_given) throw usage_error("--noise applies to INPUT's synthetic pairs, not to given pairs");
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);
  const double voxel = o.voxel < 0 ? 0.01 : o.voxel;
  const std::vector<pair_input> pairs = real_pairs(o, voxel);
  for (const pair_input& in : pairs)  // before any output
    if (in.p.empty() || in.q.empty())
      throw ced::io::io_error(in.name + ": a cloud of the pair has no points (after --depth-max and --voxel)");
  if (csv) csv->stream() << pair_csv_header;
  std::printf("%-28s %-10s %7s %7s %8s %8s %8s %6s %8s\n", "detector", "pair", "kp(P)", "overlap", "repeated",
              "rel.rep.", "random", "lift", "ms");
  std::vector<lift_stats> stats(detectors.size());
  for (std::size_t pi = 0; pi < pairs.size(); ++pi) {
    const pair_input& in = pairs[pi];
    const double resolution = o.resolution > 0 ? o.resolution : voxel;
    const eval_setting s = make_setting(in.p, in.name, resolution, o.radius, o.min_neighbors, o.threads, o.nms_radius);
    const double eps = pair_epsilon(o, s.resolution);
    const ced::eval::real_pair pair(in.p, in.q, in.t, eps);
    if (!o.quiet)
      std::fprintf(stderr,
                   "ced eval: %s: %zu -> %zu points, voxel %g, resolution %g, radius %g, epsilon %g; %zu points "
                   "of the source (%.0f%%) lie in the overlap\n",
                   in.name.c_str(), in.p.size(), in.q.size(), voxel, s.resolution, s.params.radius, eps,
                   pair.overlap_points(), 100.0 * double(pair.overlap_points()) / double(in.p.size()));
    std::size_t last_count = std::max<std::size_t>(1, in.p.size() / 100);
    const pair_setup ps{in, pair, s, o.random_draws, o.quiet, o.seed, pi};
    for (std::size_t d = 0; d < detectors.size(); ++d)
      pair_row(detectors[d], ps, last_count, stats[d], csv ? &csv->stream() : nullptr);
  }
  if (pairs.size() > 1) print_mean_lifts(detectors, stats);
  if (csv) csv->commit();
  return exit_ok;
}

/// --noise: comma-separated levels, each a finite number >= 0; at least one.
std::vector<double> parse_noise(const std::string& text) {
  return parse_number_list(text, "--noise", [&](double v) {
    if (v < 0) throw std::invalid_argument("--noise values must be >= 0, got '" + text + "'");
  });
}

/// `ced eval repeatability INPUT`: INPUT against randomly moved, noisy copies of itself.
int run_eval_synthetic(const eval_options& o, const std::vector<eval_detector>& detectors) {
  const std::vector<double> noise = parse_noise(o.noise);
  std::unique_ptr<ced::io::atomic_output_file> csv;
  if (!o.csv.empty()) csv = std::make_unique<ced::io::atomic_output_file>(o.csv);

  const ced::point_cloud p = read_finite(o.input, o.format, o.columns);
  const eval_setting s = make_setting(p, o.input, o.resolution, o.radius, o.min_neighbors, o.threads, o.nms_radius);
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
      repeat_once(detectors, p, q, t, s, eps, rng, stats, csv ? &csv->stream() : nullptr, prefix.str(), o.quiet);
    }
    char label[32];
    std::snprintf(label, sizeof label, "%.2f", nr);
    for (std::size_t d = 0; d < detectors.size(); ++d) print_repeat_row(detectors[d].name, label, stats[d]);
  }
  if (csv) csv->commit();
  return exit_ok;
}

int run_eval(const eval_options& o) {
  std::vector<eval_detector> detectors = parse_detectors(o.detectors, o.neighborhood, o.search);
  check_eval_numbers(o);
  detectors = detectors_at_counts(std::move(detectors), o.counts, o.quiet);
  if (user_pair_mode(o)) return run_eval_pairs(o, detectors);
  if (o.pair_options_given)
    throw usage_error("--voxel, --gt-error and --random-draws apply to given pairs (--source and --target, or --rgbd)");
  return run_eval_synthetic(o, detectors);
}

}  // namespace

CLI::App* add_eval_command(CLI::App& app) {
  auto* eval = app.add_subcommand("eval", "Evaluate detectors");
  eval->require_subcommand(1);
  return eval;
}

command add_repeatability_command(CLI::App& eval) {
  auto o = std::make_shared<eval_options>();
  auto* rep = eval.add_subcommand("repeatability", "Relative repeatability under a random rigid transform and noise");
  add_input_options(rep, o->input, "Input point cloud (or --source and --target)", o->format, o->columns);
  auto* depth_opt = add_pair_options(rep, *o, "frame 0 against each later frame");
  one_value_each(rep->add_option(
      "-d,--detector", o->detectors,
      "Repeatable: ced6d, ced3d, random, iss3d, harris3d, harris6d, sift (PCL builds), or modality specs "
      "joined by commas (default: ced6d ced3d random); a sweep: 'xyz:{0.1,0.2,0.3},rgb:0.1' is three detectors; "
      "'ced3d|adaptive:16,max=0.2' gives a ced detector its own neighbourhood"));
  rep->add_option("--trials", o->trials, "Random transforms per noise level (default 5)");
  rep->add_option("--seed", o->seed, "Seed (default 1): the same seed gives the same numbers");
  auto* noise_opt =
      rep->add_option("--noise", o->noise, "Gaussian noise levels, in multiples of the resolution (default 0,0.5)");
  auto* epsilon_opt = rep->add_option(
      "--epsilon", o->epsilon,
      "Match distance, in multiples of the resolution (default 2; for a given pair at least --gt-error)");
  auto* voxel_opt =
      rep->add_option("--voxel", o->voxel,
                      "A given pair: voxelise both clouds to this size first, metres; it is then the resolution "
                      "(default 0.01, the paper's; 0: as they are)");
  auto* gt_opt = rep->add_option("--gt-error", o->gt_error,
                                 "A given pair: the ground truth's error, metres; the default epsilon is at least this "
                                 "(default 0.01)");
  auto* draws_opt = rep->add_option("--random-draws", o->random_draws,
                                    "A given pair: random detectors drawn for each detector's lift (default 100)");
  rep->add_option("--resolution", o->resolution, "Cloud resolution in metres (default: estimated)");
  rep->add_option("-r,--radius", o->radius, "Detector radius, metres (default 5 x resolution)");
  rep->add_option("--nms-radius", o->nms_radius,
                  "NMS radius of ced's detectors and ISS3D, metres (default: the radius)");
  rep->add_option("-k,--min-neighbors", o->min_neighbors, "Minimum neighbours (default 5)");
  rep->add_option("--max-translation", o->max_translation, "Translations uniform in +-this, metres (default 1)");
  rep->add_option("-j,--threads", o->threads, "Threads");
  rep->add_option("--counts", o->counts,
                  "Every detector at these keypoint counts, e.g. 64,128,256,512: the N strongest (random: N points; "
                  "Harris by its response; ISS3D and SIFT, which have none, at their natural count)");
  rep->add_option("--csv", o->csv, "Write one row per detector x noise x trial");
  rep->add_flag("-q,--quiet", o->quiet, "Print only the table");
  return {rep, [o, noise_opt, epsilon_opt, voxel_opt, gt_opt, draws_opt, depth_opt] {
            check_paths(eval_input_paths(o->input, o->source, o->target, o->transform, o->rgbd, o->intrinsics),
                        {{"--csv", o->csv}});
            o->noise_given = noise_opt->count() > 0;
            o->epsilon_given = epsilon_opt->count() > 0;
            o->pair_options_given = voxel_opt->count() + gt_opt->count() + draws_opt->count() > 0;
            o->depth_max_given = depth_opt->count() > 0;
            return run_eval(*o);
          }};
}

}  // namespace ced_cli
