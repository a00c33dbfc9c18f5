// SPDX-License-Identifier: MIT
// Keypoint repeatability (Tombari et al., IJCV 2013, as used by the CED paper).
#pragma once

#include <array>
#include <cstdint>
#include <istream>
#include <random>
#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/transform.hpp"
#include "ced/transform.hpp"

namespace ced::eval {

/// A rotation uniform over SO(3) and a translation uniform in
/// [-max_translation, max_translation]³, drawn from `rng` (deterministic for a seed).
rigid_transform random_transform(std::mt19937_64& rng, double max_translation);

/// T(cloud) with i.i.d. Gaussian noise of standard deviation `sigma` (metres)
/// added to every coordinate; fields are copied. Point i of the result is
/// the image of point i.
point_cloud transform(const point_cloud& cloud, const rigid_transform& t, double sigma, std::mt19937_64& rng);

struct repeatability {
  std::size_t source_keypoints = 0;  ///< |K_P|
  std::size_t target_keypoints = 0;  ///< |K_Q|
  std::size_t repeated = 0;          ///< keypoints of P whose image has a keypoint of Q within epsilon
  /// repeated / |K_P| (0 when P has no keypoints).
  double relative() const noexcept { return source_keypoints ? double(repeated) / double(source_keypoints) : 0.0; }
};

/// Counts the keypoints `kp` of `p` whose position mapped by `t` lies within
/// `epsilon` (Euclidean, ≤) of some keypoint `kq` of `q`.
repeatability measure(const point_cloud& p, const std::vector<std::uint32_t>& kp, const point_cloud& q,
                      const std::vector<std::uint32_t>& kq, const rigid_transform& t, double epsilon);

/// `count` distinct indices of [0, n), ascending, drawn from `rng`: the random baseline.
std::vector<std::uint32_t> random_keypoints(std::size_t n, std::size_t count, std::mt19937_64& rng);

}  // namespace ced::eval
