// SPDX-License-Identifier: MIT
#include "detectors.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/io.hpp"
#include "common.hpp"
#ifdef CED_HAS_PCL
#include "pcl_bridge.hpp"
#endif

namespace ced_cli {

const std::vector<std::string> pcl_detector_names = {"iss3d", "harris3d", "harris6d", "sift"};
const char* const no_pcl_message =
    "needs ced's PCL component (ced_pcl), and this ced was built without it: install PCL (Debian: libpcl-dev) and "
    "reconfigure with -DCED_WITH_PCL=ON";

eval_detector parse_detector(const std::string& text, const ced::neighborhood_spec& neighborhood,
                             ced::search_kind search) {
  const std::size_t bar = text.find('|');
  if (bar != std::string::npos) {  // DETECTOR|SPEC: a ced detector with its own neighbourhood
    eval_detector d = parse_detector(text.substr(0, bar), neighborhood, search);
    if (d.type != eval_detector::kind::ced)
      throw std::invalid_argument("--detector '" + text +
                                  "': a neighbourhood (|SPEC) applies to ced's detectors, not " + d.text);
    try {
      d.neighborhood = ced::parse_neighborhood(text.substr(bar + 1));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("--detector '" + text + "': " + e.what());
    }
    d.name = d.text = text;
    return d;
  }
  eval_detector d;
  d.name = d.text = text;
  d.neighborhood = neighborhood;
  d.search = search;
  if (text == "random") {
    d.type = eval_detector::kind::random;
    return d;
  }
  if (std::find(pcl_detector_names.begin(), pcl_detector_names.end(), text) != pcl_detector_names.end()) {
#ifdef CED_HAS_PCL
    ced::pcl_bridge::require_pcl();  // a missing PCL module stops the command here, before any work
    d.type = eval_detector::kind::pcl;
    return d;
#else
    throw std::invalid_argument("--detector " + text + " " + no_pcl_message);
#endif
  }
  for (const auto& p : ced::preset_names())
    if (text == p) {
      d.modalities = ced::preset(text);
      d.refine = ced::preset_refines(text);
      d.keypoint_share = ced::preset_keypoint_share(text);
      return d;
    }
  for (const auto& s : ced::split_modality_specs(text)) {
    if (s == "refine") {
      d.refine = true;
    } else if (s.rfind("share:", 0) == 0) {
      d.keypoint_share =
          parse_share(s.substr(6), "--detector '" + text + "': share:Q takes a share from 0 to 1, got '" + s + "'");
    } else {
      d.modalities.push_back(ced::make_modality(s));
    }
  }
  if (d.modalities.empty()) throw std::invalid_argument("--detector '" + text + "' names no modality");
  return d;
}

std::vector<std::string> expand_sweep(const std::string& text) {
  const std::size_t open = text.find('{');
  const std::size_t close = text.find('}');
  if (open == std::string::npos && close == std::string::npos) return {text};
  if (open == std::string::npos || close == std::string::npos || close < open)
    throw std::invalid_argument("'" + text + "': unbalanced braces (a sweep is written {A,B,...})");
  const std::string list = text.substr(open + 1, close - open - 1);
  if (list.find('{') != std::string::npos) throw std::invalid_argument("'" + text + "': braces cannot be nested");
  std::vector<std::string> values;
  std::size_t at = 0;
  for (;;) {
    const std::size_t comma = list.find(',', at);
    values.push_back(list.substr(at, comma == std::string::npos ? std::string::npos : comma - at));
    if (values.back().empty()) throw std::invalid_argument("'" + text + "': an empty value in {...}");
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  std::vector<std::string> out;
  const std::string head = text.substr(0, open);
  for (const auto& v : values)
    for (const auto& rest : expand_sweep(text.substr(close + 1))) out.push_back(head + v + rest);
  if (out.size() > 10000) throw std::invalid_argument("'" + text + "': more than 10000 settings");
  return out;
}

std::vector<eval_detector> parse_detectors(const std::vector<std::string>& names, const std::string& neighborhood,
                                           const std::string& search) {
  ced::detect_params shared;
  set_neighborhood(shared, neighborhood, search);
  std::vector<eval_detector> out;
  try {
    for (const auto& spec : names)
      for (const auto& d : expand_sweep(spec)) out.push_back(parse_detector(d, shared.neighborhood, shared.search));
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  if (out.empty()) throw usage_error("--detector: no detector given");
  return out;
}

std::vector<std::size_t> parse_counts(const std::string& text) {
  const std::vector<double> values = parse_number_list(text, "--counts", [&](double v) {
    if (!(v >= 1 && v <= 1e9) || v != std::floor(v))
      throw std::invalid_argument("--counts values must be whole numbers from 1 to 10^9, got '" + text + "'");
  });
  return std::vector<std::size_t>(values.begin(), values.end());
}

std::vector<eval_detector> at_counts(const std::vector<eval_detector>& detectors,
                                     const std::vector<std::size_t>& counts, std::vector<std::string>& natural) {
  std::vector<eval_detector> out;
  for (const auto& d : detectors) {
#ifdef CED_HAS_PCL
    if (d.type == eval_detector::kind::pcl &&
        !ced::pcl_bridge::ranks_by_response(*ced::pcl_bridge::parse_detector(d.text))) {
      natural.push_back(d.name);
      out.push_back(d);
      out.back().name += " (natural)";
      continue;
    }
#else
    (void)natural;
#endif
    for (std::size_t n : counts) {
      out.push_back(d);
      out.back().count = n;
      out.back().keypoint_share = 0;  // exactly N, as every row (a robust preset's share would cap it)
      // The N strongest NMS maxima, whatever their saliency: thresholds would
      // stop a detector at its natural count (the top-N protocol of D3Feat).
      for (auto& m : out.back().modalities) m = m.with_threshold(0);
      out.back().name += "@" + std::to_string(n);
    }
  }
  return out;
}

std::vector<eval_detector> detectors_at_counts(std::vector<eval_detector> detectors, const std::string& counts,
                                               bool quiet) {
  if (counts.empty()) return detectors;
  std::vector<std::string> natural;
  detectors = at_counts(detectors, parse_counts(counts), natural);
  if (!natural.empty() && !quiet) {
    std::string names;
    for (const auto& n : natural) names += (names.empty() ? "" : ", ") + n;
    std::fprintf(stderr, "ced eval: %s: PCL gives no response to rank by, so at the natural count (rows '(natural)')\n",
                 names.c_str());
  }
  return detectors;
}

eval_setting make_setting(const ced::point_cloud& p, const std::string& name, double resolution, double radius,
                          int min_neighbors, int threads, double nms_radius) {
  eval_setting s;
  s.resolution = resolution > 0 ? resolution : ced::estimate_resolution(p);
  if (!(s.resolution > 0)) throw ced::io::io_error(name + ": cannot estimate the resolution; give --resolution");
  s.params.radius = s.params.nms_radius = radius > 0 ? radius : 5 * s.resolution;
  if (nms_radius > 0) s.params.nms_radius = nms_radius;
  s.params.min_neighbors = static_cast<std::uint32_t>(std::max(0, min_neighbors));
  s.params.threads = static_cast<unsigned>(std::max(0, threads));
  return s;
}

detection run_detector(const eval_detector& d, const ced::point_cloud& cloud, const eval_setting& s,
                       std::size_t random_count, std::mt19937_64& rng) {
  const auto t0 = clock_type::now();
  detection out;
  switch (d.type) {
    case eval_detector::kind::random:
      out.keypoints = ced::eval::random_keypoints(cloud.size(), d.count ? d.count : random_count, rng);
      break;
    case eval_detector::kind::ced: {
      ced::detect_params params = s.params;
      params.refine = d.refine;
      params.keypoint_share = d.keypoint_share;
      params.max_keypoints = d.count;
      params.neighborhood = d.neighborhood;
      params.search = d.search;
      const auto r = ced::detect(cloud, params, d.modalities);
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
      p.threads = ced::resolve_threads(s.params.threads);
      p.max_keypoints = d.count;
      out.keypoints = ced::pcl_bridge::detect(cloud, *ced::pcl_bridge::parse_detector(d.text), p);
#endif
      break;
    }
  }
  out.ms = ms_since(t0);
  return out;
}

}  // namespace ced_cli
