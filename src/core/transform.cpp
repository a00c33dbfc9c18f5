// SPDX-License-Identifier: MIT
#include "ced/transform.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace ced::eval {

std::array<double, 3> rigid_transform::apply(const std::array<double, 3>& p) const noexcept {
  std::array<double, 3> out{};
  for (std::size_t r = 0; r < 3; ++r)
    out[r] = rotation[r][0] * p[0] + rotation[r][1] * p[1] + rotation[r][2] * p[2] + translation[r];
  return out;
}

rigid_transform compose(const rigid_transform& a, const rigid_transform& b) noexcept {
  rigid_transform out;
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 3; ++c)
      out.rotation[r][c] = a.rotation[r][0] * b.rotation[0][c] + a.rotation[r][1] * b.rotation[1][c] +
                           a.rotation[r][2] * b.rotation[2][c];
  out.translation = a.apply(b.translation);
  return out;
}

rigid_transform inverse(const rigid_transform& t) noexcept {
  rigid_transform out;
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 3; ++c) out.rotation[r][c] = t.rotation[c][r];
  for (std::size_t r = 0; r < 3; ++r)
    out.translation[r] = -(out.rotation[r][0] * t.translation[0] + out.rotation[r][1] * t.translation[1] +
                           out.rotation[r][2] * t.translation[2]);
  return out;
}

namespace {
rigid_transform shift(const std::array<double, 3>& v, double sign) noexcept {
  rigid_transform t;
  for (std::size_t k = 0; k < 3; ++k) t.translation[k] = sign * v[k];
  return t;
}
}  // namespace

rigid_transform to_local(const rigid_transform& absolute, const std::array<double, 3>& source_origin,
                         const std::array<double, 3>& target_origin) noexcept {
  // local_q = T(local_p + o_p) − o_q
  return compose(shift(target_origin, -1), compose(absolute, shift(source_origin, +1)));
}

rigid_transform to_absolute(const rigid_transform& local, const std::array<double, 3>& source_origin,
                            const std::array<double, 3>& target_origin) noexcept {
  return compose(shift(target_origin, +1), compose(local, shift(source_origin, -1)));
}

double rotation_error_deg(const rigid_transform& estimate, const rigid_transform& truth) noexcept {
  double trace = 0;  // trace(R_eᵀ R_t) = Σ R_e[r][c] R_t[r][c]
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 3; ++c) trace += estimate.rotation[r][c] * truth.rotation[r][c];
  const double cosine = std::clamp((trace - 1) / 2, -1.0, 1.0);
  return std::acos(cosine) * 180.0 / 3.14159265358979323846;
}

double translation_error(const rigid_transform& estimate, const rigid_transform& truth) noexcept {
  double d2 = 0;
  for (std::size_t k = 0; k < 3; ++k)
    d2 += (estimate.translation[k] - truth.translation[k]) * (estimate.translation[k] - truth.translation[k]);
  return std::sqrt(d2);
}

}  // namespace ced::eval
