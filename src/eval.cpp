// SPDX-License-Identifier: MIT
#include "ced/eval.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "ced/io/output_file.hpp"
#include "core/neighbor_index.hpp"

namespace ced::eval {

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

namespace {

/// Whether some point of `index` (over `xyz`) lies within epsilon (≤, in
/// double) of `m`. The index's test is strict and in float: it is queried a
/// little wider, and the decision made in double.
bool any_within(const neighbor_index& index, const float* xyz, const std::array<double, 3>& m, double epsilon,
                std::vector<std::uint32_t>& hits) {
  const float c[3] = {float(m[0]), float(m[1]), float(m[2])};
  index.radius_search(c, epsilon * 1.001 + 1e-9, hits);
  for (std::uint32_t h : hits) {
    double d2 = 0;
    for (std::size_t k = 0; k < 3; ++k) d2 += (double(xyz[3 * h + k]) - m[k]) * (double(xyz[3 * h + k]) - m[k]);
    if (d2 <= epsilon * epsilon) return true;
  }
  return false;
}

/// The positions of `q`'s keypoints `kq`, x y z after x y z.
std::vector<float> keypoint_positions(const point_cloud& q, const std::vector<std::uint32_t>& kq) {
  std::vector<float> xyz;
  xyz.reserve(3 * kq.size());
  for (std::uint32_t j : kq) {
    if (j >= q.size()) throw std::out_of_range("target keypoint index out of range");
    xyz.insert(xyz.end(), q.position(j), q.position(j) + 3);
  }
  return xyz;
}

std::array<double, 3> image(const point_cloud& p, std::uint32_t i, const rigid_transform& t) {
  const float* s = p.position(i);
  return t.apply({s[0], s[1], s[2]});
}

}  // namespace

repeatability measure(const point_cloud& p, const std::vector<std::uint32_t>& kp, const point_cloud& q,
                      const std::vector<std::uint32_t>& kq, const rigid_transform& t, double epsilon) {
  repeatability r;
  r.source_keypoints = kp.size();
  r.target_keypoints = kq.size();
  if (kp.empty() || kq.empty()) return r;
  const std::vector<float> xyz = keypoint_positions(q, kq);
  const neighbor_index index(xyz.data(), kq.size(), 8);
  std::vector<std::uint32_t> hits;
  for (std::uint32_t i : kp) {
    if (i >= p.size()) throw std::out_of_range("source keypoint index out of range");
    r.repeated += any_within(index, xyz.data(), image(p, i, t), epsilon, hits);
  }
  return r;
}

real_pair::real_pair(const point_cloud& p, const point_cloud& q, const rigid_transform& t, double epsilon)
    : m_p(p), m_q(q), m_t(t), m_epsilon(epsilon), m_in_overlap(p.size(), 0) {
  if (!(epsilon > 0) || !std::isfinite(epsilon)) throw std::invalid_argument("epsilon must be a positive number");
  if (q.empty()) return;
  const neighbor_index index(q.positions().data(), q.size(), 8);
  std::vector<std::uint32_t> hits;
  for (std::size_t i = 0; i < p.size(); ++i) {
    m_in_overlap[i] = any_within(index, q.positions().data(), image(p, std::uint32_t(i), t), epsilon, hits);
    m_overlap += m_in_overlap[i];
  }
}

real_pair::~real_pair() = default;

std::size_t real_pair::overlap_points() const noexcept { return m_overlap; }

overlap_repeatability real_pair::measure(const std::vector<std::uint32_t>& kp,
                                         const std::vector<std::uint32_t>& kq) const {
  overlap_repeatability r;
  r.source_keypoints = kp.size();
  r.target_keypoints = kq.size();
  const std::vector<float> xyz = keypoint_positions(m_q, kq);
  for (std::uint32_t i : kp)
    if (i >= m_p.size()) throw std::out_of_range("source keypoint index out of range");
  std::vector<std::uint32_t> hits;
  if (kq.empty()) {
    for (std::uint32_t i : kp) r.overlap_keypoints += m_in_overlap[i];
    return r;
  }
  const neighbor_index index(xyz.data(), kq.size(), 8);
  for (std::uint32_t i : kp) {
    if (!m_in_overlap[i]) continue;
    ++r.overlap_keypoints;
    r.repeated += any_within(index, xyz.data(), image(m_p, i, m_t), m_epsilon, hits);
  }
  return r;
}

double real_pair::random_relative(std::size_t source_count, std::size_t target_count, std::size_t draws,
                                  std::mt19937_64& rng) const {
  // Pooled over the draws (repeated / overlap keypoints, each summed), so
  // that draws with no keypoint in the overlap do not count as zeros.
  std::size_t repeated = 0, overlap = 0;
  for (std::size_t d = 0; d < draws; ++d) {
    const auto kp = random_keypoints(m_p.size(), source_count, rng);
    const auto kq = random_keypoints(m_q.size(), target_count, rng);
    const auto r = measure(kp, kq);
    repeated += r.repeated;
    overlap += r.overlap_keypoints;
  }
  return overlap ? double(repeated) / double(overlap) : 0.0;
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
