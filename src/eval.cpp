// SPDX-License-Identifier: MIT
#include "ced/eval.hpp"

#include <algorithm>
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
