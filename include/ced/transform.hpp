// SPDX-License-Identifier: MIT
// Rigid transforms of clouds (ground truth of evaluations, camera poses).
#pragma once

#include <array>

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

}  // namespace ced::eval
