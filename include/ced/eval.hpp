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

/// Repeatability between two different scans of a scene, counting only the
/// keypoints of P that lie in the overlap: a keypoint whose image under t is
/// not within epsilon of any point of Q cannot repeat.
struct overlap_repeatability {
  std::size_t source_keypoints = 0;   ///< |K_P|
  std::size_t target_keypoints = 0;   ///< |K_Q|
  std::size_t overlap_keypoints = 0;  ///< keypoints of P whose image is within epsilon (≤) of some point of Q
  std::size_t repeated = 0;           ///< of those, the ones with a keypoint of Q within epsilon
  /// repeated / overlap_keypoints (0 when no keypoint lies in the overlap).
  double relative() const noexcept { return overlap_keypoints ? double(repeated) / double(overlap_keypoints) : 0.0; }
};

/// A real pair: P, Q and the ground-truth map t from P's coordinates to Q's
/// (both clouds' local frames), with the match distance epsilon. Which points
/// of P lie in the overlap is found once; measures then take keypoints.
class real_pair {
 public:
  /// Keeps references to `p` and `q`: they must outlive the pair.
  real_pair(const point_cloud& p, const point_cloud& q, const rigid_transform& t, double epsilon);
  ~real_pair();
  real_pair(const real_pair&) = delete;
  real_pair& operator=(const real_pair&) = delete;

  /// Points of P in the overlap (image within epsilon of some point of Q).
  std::size_t overlap_points() const noexcept;
  bool in_overlap(std::uint32_t i) const { return m_in_overlap.at(i) != 0; }
  overlap_repeatability measure(const std::vector<std::uint32_t>& kp, const std::vector<std::uint32_t>& kq) const;
  /// The relative repeatability of `draws` random detectors with the same
  /// counts (`source_count` points of P, `target_count` of Q), pooled: all
  /// their repeated keypoints over all their keypoints in the overlap. The
  /// chance level against which a detector's lift is measured.
  double random_relative(std::size_t source_count, std::size_t target_count, std::size_t draws,
                         std::mt19937_64& rng) const;

 private:
  const point_cloud& m_p;
  const point_cloud& m_q;
  rigid_transform m_t;
  double m_epsilon;
  std::vector<std::uint8_t> m_in_overlap;
  std::size_t m_overlap = 0;
};

}  // namespace ced::eval
