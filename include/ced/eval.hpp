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

namespace ced::eval {

/// x ↦ R x + t, in the cloud's local frame (positions relative to its origin).
struct rigid_transform {
  std::array<std::array<double, 3>, 3> rotation{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  std::array<double, 3> translation{0, 0, 0};
  std::array<double, 3> apply(const std::array<double, 3>& p) const noexcept;
};

/// a ∘ b: x ↦ a(b(x)).
rigid_transform compose(const rigid_transform& a, const rigid_transform& b) noexcept;

/// The inverse transform: x ↦ Rᵀ(x − t).
rigid_transform inverse(const rigid_transform& t) noexcept;

/// `absolute` acts on absolute coordinates (a cloud's origin + its stored
/// positions). The same map between the clouds' local frames, i.e. from
/// positions stored relative to `source_origin` to positions relative to
/// `target_origin`: x ↦ R x + (R·source_origin + t − target_origin).
rigid_transform to_local(const rigid_transform& absolute, const std::array<double, 3>& source_origin,
                         const std::array<double, 3>& target_origin) noexcept;

/// The inverse of to_local: a local-frame map back to absolute coordinates.
rigid_transform to_absolute(const rigid_transform& local, const std::array<double, 3>& source_origin,
                            const std::array<double, 3>& target_origin) noexcept;

/// Angle, in degrees, of the rotation that takes `estimate`'s rotation to
/// `truth`'s: acos((trace(R_eᵀ R_t) − 1) / 2), in [0, 180].
double rotation_error_deg(const rigid_transform& estimate, const rigid_transform& truth) noexcept;

/// Euclidean distance between the two translations (same unit as the clouds).
double translation_error(const rigid_transform& estimate, const rigid_transform& truth) noexcept;

/// Reads a 4×4 row-major matrix of a rigid transform: 16 numbers separated by
/// white space or commas; '#' starts a comment. The last row must be 0 0 0 1
/// and the upper-left 3×3 block a rotation (orthonormal, determinant +1, to
/// within `tolerance`). Throws ced::io::io_error naming `name` and the
/// problem (wrong count, a bad number, not rigid) otherwise.
rigid_transform parse_transform(std::istream& in, const std::string& name, double tolerance = 1e-3);

/// parse_transform on the file `path` (io_error when it cannot be opened).
rigid_transform read_transform(const std::string& path, double tolerance = 1e-3);

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
