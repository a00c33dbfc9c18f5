// SPDX-License-Identifier: MIT
// What the subcommands share: plugins, paths, numbers, counts, progress, neighbourhoods.
#include "common.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <system_error>
#include <unordered_set>
#include <vector>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/io.hpp"
#include "ced/io/rgbd.hpp"
#include "ced/io/stream.hpp"
#include "ced/plugin.hpp"
#include "ced/preprocess.hpp"

namespace ced_cli {

CLI::Option* one_value_each(CLI::Option* opt) { return opt->expected(1)->allow_extra_args(false)->take_all(); }

void add_plugin_option(CLI::App* app, std::vector<std::string>& plugins) {
  one_value_each(app->add_option(
      "--plugin", plugins, "Load modalities from a plugin, a shared library built with ced/plugin.hpp (repeatable)"));
}

void check_paths(const std::vector<ced::io::named_path>& inputs, const std::vector<ced::io::named_path>& outputs) {
  try {
    ced::io::check_outputs_distinct(inputs, outputs);
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
}

void check_stdout() {
  std::cout.flush();
  if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout))
    throw std::runtime_error("error writing to standard output (disk full or closed?): the output is lost");
}

void load_plugins(const std::vector<std::string>& plugins) {
  for (const auto& p : plugins) ced::load_plugin(p);
}

std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::function<void(double)>& check) {
  std::vector<double> values;
  try {
    std::size_t at = 0;
    for (;;) {  // every value between commas, the empty ones too
      const std::size_t comma = text.find(',', at);
      values.push_back(ced::parse_number(text.substr(at, comma == std::string::npos ? comma : comma - at),
                                         option + " '" + text + "'"));
      check(values.back());
      if (comma == std::string::npos) break;
      at = comma + 1;
    }
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  return values;
}

void check_length(double v, const std::string& option, const std::string& zero) {
  if (std::isfinite(v) && v >= 0) return;
  std::ostringstream got;
  got << v;
  throw usage_error(option + " must be a finite number >= 0" + (zero.empty() ? "" : " (" + zero + ")") + ", got " +
                    got.str());
}

double parse_share(const std::string& text, const std::string& bad) {
  double share = 0;
  try {
    share = ced::parse_number(text, "share");
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument(bad);
  }
  if (!(share >= 0 && share <= 1)) throw std::invalid_argument(bad);
  return share;
}

std::string keypoint_limit_text(const ced::detect_params& params) {
  std::string out;
  if (params.max_keypoints) out += ", the " + std::to_string(params.max_keypoints) + " strongest";
  if (params.keypoint_share > 0) {
    char share[32];
    std::snprintf(share, sizeof share, "%g%%", 100 * params.keypoint_share);
    out += std::string(params.max_keypoints ? " and" : ",") + " the strongest " + share + " of the candidates";
  }
  return out;
}

void check_counts(int min_neighbors, int threads) {
  if (min_neighbors < 0) throw usage_error("--min-neighbors must be >= 0, got " + std::to_string(min_neighbors));
  if (threads < 0) throw usage_error("--threads must be >= 0 (0 = all cores), got " + std::to_string(threads));
}

void keep_freed_memory() noexcept {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 1 << 30);  // blocks below 1 GiB from the heap
  mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
#endif
}

progress_bar::mode progress_bar::mode_of(const std::string& option, bool quiet) {
  if (option != "auto" && option != "bar" && option != "lines" && option != "json" && option != "none")
    throw usage_error("--progress must be auto, bar, lines, json or none, got '" + option + "'");
  if (quiet || option == "none") return mode::none;
  if (option == "bar") return mode::bar;
  if (option == "lines") return mode::lines;
  if (option == "json") return mode::json;
  return isatty(STDERR_FILENO) ? mode::bar : mode::lines;
}

progress_bar::progress_bar(mode m) : m_mode(m), m_start(clock::now()), m_stage_start(m_start), m_last(m_start) {}

void progress_bar::stage(const std::string& name, std::uint64_t points) {
  if (m_mode == mode::none) return;
  std::lock_guard<std::mutex> lock(m_mutex);
  m_stage = name;
  m_points = points;
  m_stage_start = clock::now();
  update(0, m_mode != mode::lines);
}

std::function<void(double)> progress_bar::callback() {
  if (m_mode == mode::none) return {};
  return [this](double f) {
    std::unique_lock<std::mutex> lock(m_mutex, std::try_to_lock);
    if (lock) update(f, false);
  };
}

void progress_bar::pause() {
  std::lock_guard<std::mutex> lock(m_mutex);
  if (m_mode == mode::bar && !m_stage.empty()) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  m_stage.clear();
}

void progress_bar::tiles(std::size_t done, std::size_t total, double ms) {
  if (m_mode == mode::none) return;
  std::lock_guard<std::mutex> lock(m_mutex);
  const double left = done ? ms / double(done) * double(total - done) : 0;
  if (m_mode == mode::json) {
    if (done < total && ms - m_last_tiles_ms < 1000) return;
    m_last_tiles_ms = ms;
    std::fprintf(stderr, "{\"event\":\"tiles\",\"done\":%zu,\"tiles\":%zu,\"tiles_elapsed_s\":%.3f,\"eta_s\":%.1f}\n",
                 done, total, ms / 1000, left / 1000);
    std::fflush(stderr);
    return;
  }
  // About twenty lines a run, and one at least every ten seconds.
  if (done < total && done % std::max<std::size_t>(1, total / 20) != 0 && ms - m_last_tiles_ms < 10000) return;
  m_last_tiles_ms = ms;
  if (m_mode == mode::bar && !m_stage.empty()) std::fprintf(stderr, "\r\033[K");
  m_stage.clear();
  std::fprintf(stderr, "ced: tile %zu/%zu done; %.1f s elapsed, about %.0f s left\n", done, total, ms / 1000,
               left / 1000);
  std::fflush(stderr);
}

void progress_bar::done() {
  std::lock_guard<std::mutex> lock(m_mutex);
  if (m_mode == mode::bar && !m_stage.empty()) std::fprintf(stderr, "\r\033[K");
  if (m_mode == mode::json && !m_finished)
    std::fprintf(stderr, "{\"event\":\"done\",\"elapsed_s\":%.3f}\n",
                 std::chrono::duration<double>(clock::now() - m_start).count());
  m_finished = true;
  std::fflush(stderr);
  m_stage.clear();
}

namespace {
/// 4200000 as "4.20 M", 950 as "950".
std::string short_count(double v) {
  char buf[32];
  if (v >= 1e9)
    std::snprintf(buf, sizeof buf, "%.2f G", v / 1e9);
  else if (v >= 1e6)
    std::snprintf(buf, sizeof buf, "%.2f M", v / 1e6);
  else if (v >= 1e4)
    std::snprintf(buf, sizeof buf, "%.1f k", v / 1e3);
  else
    std::snprintf(buf, sizeof buf, "%.0f", v);
  return buf;
}
}  // namespace

void progress_bar::update(double f, bool forced) {
  f = std::clamp(f, 0.0, 1.0);
  const clock::time_point now = clock::now();
  const double since_last = std::chrono::duration<double>(now - m_last).count();
  const double every = m_mode == mode::bar ? 0.1 : m_mode == mode::json ? 1.0 : 5.0;
  if (!forced && since_last < every && !(m_mode == mode::bar && !m_printed)) return;
  m_last = now;
  m_printed = true;
  const double elapsed = std::chrono::duration<double>(now - m_stage_start).count();
  const double total = std::chrono::duration<double>(now - m_start).count();
  const double done_points = f * double(m_points);
  const double rate = elapsed > 0 ? done_points / elapsed : 0;
  // The time left, from this stage's pace so far (once it has some).
  const double left = f >= 0.01 && f < 1 ? elapsed * (1 - f) / f : -1;
  if (m_mode == mode::json) {
    std::fprintf(stderr, "{\"event\":\"progress\",\"stage\":\"%s\",\"fraction\":%.4f,\"elapsed_s\":%.3f",
                 m_stage.c_str(), f, total);
    if (m_points > 0)
      std::fprintf(stderr, ",\"points\":%llu,\"points_done\":%.0f,\"points_per_s\":%.0f",
                   static_cast<unsigned long long>(m_points), done_points, rate);
    if (left >= 0) std::fprintf(stderr, ",\"eta_s\":%.1f", left);
    std::fprintf(stderr, "}\n");
    std::fflush(stderr);
    return;
  }
  std::string text;
  char buf[160];
  if (m_mode == mode::bar) {
    const int width = 20, filled = static_cast<int>(f * width);
    text = "\r\033[Kced: " + m_stage + " [" + std::string(filled, '#') + std::string(width - filled, ' ') + "]";
  } else {
    text = "ced: " + m_stage;
  }
  std::snprintf(buf, sizeof buf, " %3d%%", static_cast<int>(f * 100));
  text += buf;
  if (m_points > 0)
    text += ", " + short_count(done_points) + " of " + short_count(double(m_points)) + " points, " + short_count(rate) +
            " points/s";
  if (left >= 0) {
    std::snprintf(buf, sizeof buf, ", %.0f s left", std::ceil(left));
    text += buf;
  }
  if (m_mode == mode::lines) {
    std::snprintf(buf, sizeof buf, " (%.0f s in)\n", total);
    text += buf;
  }
  std::fputs(text.c_str(), stderr);
  std::fflush(stderr);
}

void set_neighborhood(ced::detect_params& params, const std::string& neighborhood, const std::string& search) {
  try {
    params.neighborhood = ced::parse_neighborhood(neighborhood);
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--neighborhood: ") + e.what());
  }
  try {
    params.search = ced::parse_search_kind(search);
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--search ") + e.what());
  }
}

void warn_float_precision(const ced::point_cloud& cloud, const std::string& input) {
  // Half a float ulp above 1 cm: |x| > 2^24 x 0.01 m. A test that vectorises
  // first (NaN fails it); the largest only when one passes.
  constexpr float limit = 167772.16f;
  const float* p = cloud.positions().data();
  const std::size_t m = 3 * cloud.size();
  int beyond = 0;
  for (std::size_t i = 0; i < m; ++i) beyond |= std::fabs(p[i]) > limit;
  if (!beyond) return;
  // The farthest finite coordinate: a non-finite point is no far point (it is
  // dropped, or refused, on its own).
  float far = 0;
  for (std::size_t i = 0; i < m; ++i)
    if (std::fabs(p[i]) > far && std::isfinite(p[i])) far = std::fabs(p[i]);
  if (!(far > limit)) return;
  const auto& o = cloud.origin();
  std::fprintf(stderr,
               "ced: warning: %s: points lie up to %.0f m from the cloud's origin (%.3f, %.3f, %.3f) on an axis, so "
               "their positions, stored as floats relative to it, keep only about %.2g m. A few points far from the "
               "others (such as a stray one at (0, 0, 0) in georeferenced data) do this: remove them, or crop the "
               "cloud\n",
               input.c_str(), static_cast<double>(far), o[0], o[1], o[2],
               static_cast<double>(far) * 5.9604644775390625e-08);
}

}  // namespace ced_cli
