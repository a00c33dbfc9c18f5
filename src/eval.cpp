// SPDX-License-Identifier: MIT
#include "ced/eval.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "ced/io/output_file.hpp"
#include "ced/neighbor_index.hpp"

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

namespace {

/// The numbers of a matrix file: '#' comments dropped, commas as blanks.
std::vector<double> read_numbers(std::istream& in, const std::string& name) {
  std::vector<double> values;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    line = line.substr(0, line.find('#'));
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream words(line);
    for (std::string word; words >> word;) {
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(word, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != word.size() || !std::isfinite(v))
        throw io::io_error(name + ": line " + std::to_string(line_no) + ": '" + word + "' is not a finite number");
      values.push_back(v);
    }
  }
  if (in.bad()) throw io::io_error(name + ": read error");
  return values;
}

void check_rigid(const rigid_transform& t, const std::array<double, 4>& last_row, const std::string& name,
                 double tolerance) {
  const std::array<double, 4> expected{0, 0, 0, 1};
  for (std::size_t c = 0; c < 4; ++c)
    if (std::abs(last_row[c] - expected[c]) > tolerance)
      throw io::io_error(name + ": the last row must be 0 0 0 1 (a rigid transform), got " +
                         std::to_string(last_row[0]) + " " + std::to_string(last_row[1]) + " " +
                         std::to_string(last_row[2]) + " " + std::to_string(last_row[3]));
  double worst = 0;  // max |RᵀR − I|
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t j = 0; j < 3; ++j) {
      double dot = 0;
      for (std::size_t k = 0; k < 3; ++k) dot += t.rotation[k][i] * t.rotation[k][j];
      worst = std::max(worst, std::abs(dot - (i == j ? 1.0 : 0.0)));
    }
  const auto& R = t.rotation;
  const double det = R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) -
                     R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0]) +
                     R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]);
  if (worst > tolerance || std::abs(det - 1) > tolerance)
    throw io::io_error(name +
                       ": the upper-left 3x3 block is not a rotation (max |R^T R - I| = " + std::to_string(worst) +
                       ", det = " + std::to_string(det) + "): only rigid transforms are supported");
}

}  // namespace

rigid_transform parse_transform(std::istream& in, const std::string& name, double tolerance) {
  const std::vector<double> v = read_numbers(in, name);
  if (v.size() != 16)
    throw io::io_error(name + ": expected a 4x4 matrix (16 numbers, row by row), found " + std::to_string(v.size()) +
                       " number(s)");
  rigid_transform t;
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 3; ++c) t.rotation[r][c] = v[4 * r + c];
    t.translation[r] = v[4 * r + 3];
  }
  check_rigid(t, {v[12], v[13], v[14], v[15]}, name, tolerance);
  return t;
}

rigid_transform read_transform(const std::string& path, double tolerance) {
  std::ifstream in(path);
  if (!in) throw io::io_error(path + ": cannot open the transform file");
  return parse_transform(in, path, tolerance);
}

rigid_transform random_transform(std::mt19937_64& rng, double max_translation) {
  // A uniform random unit quaternion (Shoemake), then its rotation matrix.
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double u1 = u(rng), u2 = u(rng), u3 = u(rng);
  const double pi = 3.14159265358979323846;
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const double w = a * std::sin(2 * pi * u2), x = a * std::cos(2 * pi * u2), y = b * std::sin(2 * pi * u3),
               z = b * std::cos(2 * pi * u3);
  rigid_transform t;
  t.rotation = {{{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                 {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                 {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}}};
  std::uniform_real_distribution<double> v(-max_translation, max_translation);
  for (auto& c : t.translation) c = v(rng);
  return t;
}

point_cloud transform(const point_cloud& cloud, const rigid_transform& t, double sigma, std::mt19937_64& rng) {
  if (!(sigma >= 0) || !std::isfinite(sigma)) throw std::invalid_argument("noise sigma must be a finite number >= 0");
  point_cloud out = cloud;
  std::normal_distribution<double> noise(0.0, sigma > 0 ? sigma : 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float* p = cloud.position(i);
    auto q = t.apply({p[0], p[1], p[2]});
    if (sigma > 0)
      for (auto& c : q) c += noise(rng);
    for (std::size_t k = 0; k < 3; ++k) out.positions()[3 * i + k] = static_cast<float>(q[k]);
  }
  return out;
}

repeatability measure(const point_cloud& p, const std::vector<std::uint32_t>& kp, const point_cloud& q,
                      const std::vector<std::uint32_t>& kq, const rigid_transform& t, double epsilon) {
  repeatability r;
  r.source_keypoints = kp.size();
  r.target_keypoints = kq.size();
  if (kp.empty() || kq.empty()) return r;
  std::vector<float> xyz;
  for (std::uint32_t j : kq) {
    if (j >= q.size()) throw std::out_of_range("target keypoint index out of range");
    xyz.insert(xyz.end(), q.position(j), q.position(j) + 3);
  }
  const neighbor_index index(xyz.data(), kq.size(), 8);
  std::vector<std::uint32_t> hits;
  for (std::uint32_t i : kp) {
    if (i >= p.size()) throw std::out_of_range("source keypoint index out of range");
    const float* s = p.position(i);
    const auto m = t.apply({s[0], s[1], s[2]});
    const float c[3] = {float(m[0]), float(m[1]), float(m[2])};
    // The index's test is strict and in float: query a little wider, then
    // decide "within epsilon" (inclusive) in double.
    index.radius_search(c, epsilon * 1.001 + 1e-9, hits);
    bool found = false;
    for (std::uint32_t h : hits) {
      double d2 = 0;
      for (std::size_t k = 0; k < 3; ++k) d2 += (double(xyz[3 * h + k]) - m[k]) * (double(xyz[3 * h + k]) - m[k]);
      found = found || d2 <= epsilon * epsilon;
    }
    r.repeated += found;
  }
  return r;
}

std::vector<std::uint32_t> random_keypoints(std::size_t n, std::size_t count, std::mt19937_64& rng) {
  count = std::min(count, n);
  std::vector<std::uint32_t> all(n);
  std::iota(all.begin(), all.end(), 0u);
  for (std::size_t i = 0; i < count; ++i) {  // partial Fisher-Yates
    std::uniform_int_distribution<std::size_t> pick(i, n - 1);
    std::swap(all[i], all[pick(rng)]);
  }
  all.resize(count);
  std::sort(all.begin(), all.end());
  return all;
}

}  // namespace ced::eval
