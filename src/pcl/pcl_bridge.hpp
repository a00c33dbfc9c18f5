// SPDX-License-Identifier: MIT
// ced's optional PCL component: PCL's keypoint detectors and the descriptor +
// RANSAC registration pipeline of the CED paper's evaluation, on
// ced::point_cloud. Private to the ced tools: no PCL header is included
// here, so callers need neither PCL's headers nor its flags. Two builds of
// it: the static library ced_pcl (tests, benchmarks) and, for the `ced`
// tool, the module libced_pcl.so that the tool loads on first use
// (pcl_module.hpp, pcl_loader.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/eval.hpp"

namespace ced::pcl_bridge {

enum class detector { iss3d, harris3d, harris6d, sift };

/// "iss3d", "harris3d", "harris6d" or "sift"; nullopt for any other name.
inline std::optional<detector> parse_detector(const std::string& name) {
  if (name == "iss3d") return detector::iss3d;
  if (name == "harris3d") return detector::harris3d;
  if (name == "harris6d") return detector::harris6d;
  if (name == "sift") return detector::sift;
  return std::nullopt;
}

/// Makes PCL's code available before a command starts its work. In the
/// `ced` tool this loads the PCL module, and throws std::runtime_error naming
/// the module when it is missing or broken; in ced_pcl it does nothing.
void require_pcl();

/// Parameters of PCL's detectors. Defaults: the CED paper's settings for a
/// 0.01 m resolution (its config.yaml), SIFT on RGB intensity scaled to it.
struct detector_params {
  double radius = 0.05;      ///< ISS salient radius; Harris radius and normal radius
  double nms_radius = 0.05;  ///< ISS non-maximum radius
  int min_neighbors = 5;     ///< ISS minimum neighbours
  double iss_gamma = 0.975;  ///< ISS thresholds gamma21 = gamma32
  float harris_threshold = 1e-6f;
  double sift_min_scale = 0.01;  ///< SIFT smallest scale (metres): the resolution
  int sift_octaves = 3;
  int sift_scales_per_octave = 2;
  float sift_min_contrast = 1.0f;  ///< on intensity 0.299 R + 0.587 G + 0.114 B in 0..255
  unsigned threads = 1;            ///< ISS / Harris worker threads
  /// At most this many keypoints, the strongest by the detector's response,
  /// for the detectors that have one (ranks_by_response); 0: no limit.
  std::size_t max_keypoints = 0;
};

/// Whether PCL gives the detector's response at each keypoint, by which
/// detector_params::max_keypoints ranks: Harris3D/6D do (their intensity);
/// ISS3D and SIFT do not, and keep their natural count.
inline bool ranks_by_response(detector d) { return d == detector::harris3d || d == detector::harris6d; }

/// Runs a PCL detector on `cloud` (positions relative to its origin) and
/// returns the keypoints as indices into `cloud`, ascending and distinct:
/// each output point of PCL (refined or a voxel centroid for Harris and SIFT)
/// is mapped to its nearest input point; non-finite outputs are dropped.
/// harris6d and sift need colour: std::invalid_argument without it.
std::vector<std::uint32_t> detect(const point_cloud& cloud, detector d, const detector_params& params);

enum class descriptor { fpfh, pfhrgb };

/// The registration pipeline's parameters (metres where lengths).
struct registration_params {
  descriptor feature = descriptor::fpfh;
  double normal_radius = 0.03;    ///< normals estimated over the full cloud
  double feature_radius = 0.05;   ///< descriptor support radius, over the full cloud
  double inlier_distance = 0.03;  ///< RANSAC: max distance of an inlier pair after the transform
  int max_iterations = 20000;
  double similarity = 0.9;       ///< RANSAC pre-rejection: edge-length similarity of a sample
  double inlier_fraction = 0.1;  ///< RANSAC: minimum inliers / matches to accept a hypothesis
  unsigned seed = 1;             ///< std::srand seed: PCL's RANSAC draws with std::rand
  unsigned threads = 1;          ///< normal estimation threads (results do not depend on it)
};

struct registration_result {
  eval::rigid_transform transform;  ///< estimated map from source to target positions (local frames)
  bool converged = false;           ///< RANSAC found a hypothesis with enough inliers
  std::size_t source_keypoints = 0, target_keypoints = 0;  ///< with a finite descriptor
  std::size_t matches = 0;                                 ///< mutual nearest neighbours in descriptor space
  std::size_t inliers = 0;                                 ///< matches consistent with the transform
  double features_ms = 0, ransac_ms = 0;
};

/// Registers `source` onto `target` from keypoints: normals over each full
/// cloud (oriented towards its `viewpoint`, in the cloud's local frame),
/// descriptors at the keypoints over the full cloud, mutual nearest-neighbour
/// matching in descriptor space, then pcl::SampleConsensusPrerejective on the
/// matches. Deterministic for a seed (single process-wide std::rand state:
/// not for concurrent calls). pfhrgb needs colour in both clouds.
registration_result register_keypoints(const point_cloud& source, const std::vector<std::uint32_t>& source_keypoints,
                                       const std::array<double, 3>& source_viewpoint, const point_cloud& target,
                                       const std::vector<std::uint32_t>& target_keypoints,
                                       const std::array<double, 3>& target_viewpoint,
                                       const registration_params& params);

}  // namespace ced::pcl_bridge
