// SPDX-License-Identifier: MIT
// The detectors that `ced eval repeatability` and `ced eval registration`
// compare: their names and sweeps (-d, --detector), their shared settings,
// and one run of one of them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "ced/ced.hpp"

namespace ced_cli {

// PCL's detectors, available when ced is built with its PCL component.
extern const std::vector<std::string> pcl_detector_names;
extern const char* const no_pcl_message;

/// A detector of the evaluation: "random", a preset, one of PCL's, or
/// modality specs joined by commas ("xyz:0.2,bands(nir):0.1,range=0..255"),
/// among which the word "refine" asks for keypoint refinement and "share:Q"
/// for a keypoint share (detect_params::keypoint_share).
struct eval_detector {
  enum class kind { ced, random, pcl };
  std::string name;  ///< as shown: the text given, "@N" added by at_counts()
  std::string text;  ///< the text given (-d)
  kind type = kind::ced;
  std::vector<ced::any_modality> modalities;
  bool refine = false;        ///< a robust preset, or "refine" among the specs
  double keypoint_share = 0;  ///< the robust presets', or "share:Q" among the specs
  /// At most this many keypoints, the strongest (--counts); 0: the detector's
  /// natural count. Random picks exactly this many.
  std::size_t count = 0;
  /// ced's detectors: the neighbourhood (--neighborhood, or "DETECTOR|SPEC")
  /// and how it is searched (--search).
  ced::neighborhood_spec neighborhood;
  ced::search_kind search = ced::search_kind::grid;
};

/// One detector; "DETECTOR|SPEC" gives a ced detector its own neighbourhood
/// (ced::parse_neighborhood), overriding `neighborhood`.
/// std::invalid_argument naming the problem.
eval_detector parse_detector(const std::string& text, const ced::neighborhood_spec& neighborhood = {},
                             ced::search_kind search = ced::search_kind::grid);
/// A sweep: every setting of `text`'s brace lists, in order (the last list
/// varies fastest): "xyz:{0.1,0.2},rgb:{0.1,0.5}" gives xyz:0.1,rgb:0.1,
/// xyz:0.1,rgb:0.5, xyz:0.2,rgb:0.1, xyz:0.2,rgb:0.5. Text without braces is
/// itself. std::invalid_argument for unbalanced or nested braces and empty
/// values.
std::vector<std::string> expand_sweep(const std::string& text);
/// Every detector of every sweep; `neighborhood` and `search` (the texts of
/// --neighborhood and --search) apply to ced's detectors. usage_error.
std::vector<eval_detector> parse_detectors(const std::vector<std::string>& names,
                                           const std::string& neighborhood = "radius",
                                           const std::string& search = "grid");

/// --counts: comma-separated keypoint counts, each 1..10^9 (usage_error otherwise).
std::vector<std::size_t> parse_counts(const std::string& text);
/// Every detector at every count, named "NAME@N"; a detector that cannot rank
/// its keypoints (PCL's ISS3D and SIFT: no response) once, at its natural
/// count, named "NAME (natural)", and its name is added to `natural`.
std::vector<eval_detector> at_counts(const std::vector<eval_detector>& detectors,
                                     const std::vector<std::size_t>& counts, std::vector<std::string>& natural);
/// --counts of an eval command: `detectors` as they are when `counts` is
/// empty, else at_counts() of them; unless `quiet`, says on stderr which
/// detectors stay at their natural count.
std::vector<eval_detector> detectors_at_counts(std::vector<eval_detector> detectors, const std::string& counts,
                                               bool quiet);

/// What the evaluated detectors share: the detector parameters and the resolution.
struct eval_setting {
  ced::detect_params params;
  double resolution = 0;
};

eval_setting make_setting(const ced::point_cloud& p, const std::string& name, double resolution, double radius,
                          int min_neighbors, int threads, double nms_radius = 0);

struct detection {
  std::vector<std::uint32_t> keypoints;
  double ms = 0;
};

/// Runs `d` on `cloud`. "random" picks `random_count` points.
detection run_detector(const eval_detector& d, const ced::point_cloud& cloud, const eval_setting& s,
                       std::size_t random_count, std::mt19937_64& rng);

}  // namespace ced_cli
