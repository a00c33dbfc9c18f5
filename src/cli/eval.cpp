// SPDX-License-Identifier: MIT
// `ced eval repeatability`: relative repeatability under a random rigid
// transform and noise, or on a given pair. Also the `eval` group itself.
#include "ced/eval.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "commands.hpp"
#include "common.hpp"
#include "detectors.hpp"

namespace ced_cli {
namespace {

struct eval_options {
  std::string input, format = "auto", columns;
  std::string source, target, transform;  // a user-supplied pair instead of INPUT
  std::vector<std::string> detectors{"ced6d", "ced3d", "random"};
  int trials = 5;
  std::uint64_t seed = 1;
  std::string noise = "0,0.5";
  std::string counts;  // --counts: every detector at these keypoint counts
  double epsilon = 2.0, resolution = 0, radius = 0, max_translation = 1.0;
  int min_neighbors = 5, threads = 0;
  std::string csv;
  bool quiet = false;
};

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
  if (!(o.epsilon > 0) || !std::isfinite(o.epsilon)) throw usage_error("--epsilon must be a positive number");
  check_length(o.resolution, "--resolution", "0 = estimated");
  check_length(o.radius, "--radius", "0 = 5 x resolution");
  check_length(o.max_translation, "--max-translation");
  check_counts(o.min_neighbors, o.threads);
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

/// --noise: comma-separated levels, each a finite number >= 0; at least one.
std::vector<double> parse_noise(const std::string& text) {
  std::vector<double> noise;
  try {
    std::size_t at = 0;
    for (;;) {  // every value between commas, the empty ones too
      const std::size_t comma = text.find(',', at);
      noise.push_back(ced::parse_number(text.substr(at, comma == std::string::npos ? comma : comma - at),
                                        "--noise '" + text + "'"));
      if (noise.back() < 0) throw std::invalid_argument("--noise values must be >= 0, got '" + text + "'");
      if (comma == std::string::npos) break;
      at = comma + 1;
    }
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  return noise;
}

/// `ced eval repeatability INPUT`: INPUT against randomly moved, noisy copies of itself.
int run_eval_synthetic(const eval_options& o, const std::vector<eval_detector>& detectors) {
  const std::vector<double> noise = parse_noise(o.noise);
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

int run_eval(const eval_options& o, bool noise_given) {
  std::vector<eval_detector> detectors = parse_detectors(o.detectors);
  check_eval_numbers(o);
  if (!o.counts.empty()) {
    std::vector<std::string> natural;
    detectors = at_counts(detectors, parse_counts(o.counts), natural);
    if (!natural.empty() && !o.quiet) {
      std::string names;
      for (const auto& n : natural) names += (names.empty() ? "" : ", ") + n;
      std::fprintf(stderr,
                   "ced eval: %s: PCL gives no response to rank by, so at the natural count (rows '(natural)')\n",
                   names.c_str());
    }
  }
  if (user_pair_mode(o.input, o.source, o.target, o.transform)) return run_eval_pair(o, detectors, noise_given);
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
  rep->add_option("--source", o->source, "A given pair instead of INPUT: the source cloud P");
  rep->add_option("--target", o->target, "A given pair instead of INPUT: the target cloud Q");
  rep->add_option("--transform", o->transform,
                  "4x4 row-major matrix file mapping P's coordinates into Q's (default: the identity)");
  rep->add_option(
      "-d,--detector", o->detectors,
      "Repeatable: ced6d, ced3d, random, iss3d, harris3d, harris6d, sift (PCL builds), or modality specs "
      "joined by commas (default: ced6d ced3d random); a sweep: 'xyz:{0.1,0.2,0.3},rgb:0.1' is three detectors");
  rep->add_option("--trials", o->trials, "Random transforms per noise level (default 5)");
  rep->add_option("--seed", o->seed, "Seed (default 1): the same seed gives the same numbers");
  auto* noise_opt =
      rep->add_option("--noise", o->noise, "Gaussian noise levels, in multiples of the resolution (default 0,0.5)");
  rep->add_option("--epsilon", o->epsilon, "Match distance, in multiples of the resolution (default 2)");
  rep->add_option("--resolution", o->resolution, "Cloud resolution in metres (default: estimated)");
  rep->add_option("-r,--radius", o->radius, "Detector radius = NMS radius (default 5 x resolution)");
  rep->add_option("-k,--min-neighbors", o->min_neighbors, "Minimum neighbours (default 5)");
  rep->add_option("--max-translation", o->max_translation, "Translations uniform in +-this, metres (default 1)");
  rep->add_option("-j,--threads", o->threads, "Threads");
  rep->add_option("--counts", o->counts,
                  "Every detector at these keypoint counts, e.g. 64,128,256,512: the N strongest (random: N points; "
                  "Harris by its response; ISS3D and SIFT, which have none, at their natural count)");
  rep->add_option("--csv", o->csv, "Write one row per detector x noise x trial");
  rep->add_flag("-q,--quiet", o->quiet, "Print only the table");
  return {
      rep, [o, noise_opt] {
        check_paths(
            {{"the input", o->input}, {"--source", o->source}, {"--target", o->target}, {"--transform", o->transform}},
            {{"--csv", o->csv}});
        return run_eval(*o, noise_opt->count() > 0);
      }};
}

}  // namespace ced_cli
