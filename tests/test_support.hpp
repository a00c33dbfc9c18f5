// SPDX-License-Identifier: MIT
// Fixtures and an O(N²) brute-force oracle of the CED semantics, written
// independently of the library's fast paths.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "ced/cloud.hpp"

namespace ced_test {

/// A 1 cm grid of 21 x 21 points with NIR and red fields of type `type`
/// whose NDVI is 0.2 for x <= 0 (NIR 120, red 80) and 0.6 for x > 0 (NIR
/// 160, red 40); point (x, y) is index (y + 10) * 21 + x + 10.
inline ced::point_cloud ndvi_edge(ced::scalar_type type, const char* nir_name = "nir", const char* red_name = "red") {
  ced::point_cloud c;
  std::vector<double> nir, red;
  for (int y = -10; y <= 10; ++y)
    for (int x = -10; x <= 10; ++x) {
      c.push_back(x * 0.01f, y * 0.01f, 0.0f);
      nir.push_back(x <= 0 ? 120 : 160);
      red.push_back(x <= 0 ? 80 : 40);
    }
  c.add_field(nir_name, type, nir);
  c.add_field(red_name, type, red);
  return c;
}

/// The values of `c` as doubles, with value i replaced by `v` (for fields
/// whose type cannot hold v: rebuild them as float columns).
inline std::vector<double> with_value(const ced::column& c, std::size_t i, double v) {
  std::vector<double> out = c.to_doubles();
  out.at(i) = v;
  return out;
}

/// A noisy coloured "room corner": three planes plus a box, coloured patches,
/// extra channels `nir` (uint8) and `intensity` (uint16). Deterministic.
inline ced::point_cloud make_room(std::size_t n, std::uint32_t seed, float noise = 0.002f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, noise);
  ced::point_cloud c;
  std::vector<double> red, green, blue, nir, inten;
  const float side = std::sqrt(static_cast<float>(n) / 4.0f) * 0.01f;  // ~1 cm spacing
  for (std::size_t i = 0; i < n; ++i) {
    float x = u(rng) * side, y = u(rng) * side, z = u(rng) * side;
    switch (i % 4) {
      case 0:
        z = 0;
        break;  // floor
      case 1:
        x = 0;
        break;  // wall
      case 2:
        y = 0;
        break;    // wall
      default: {  // box on the floor
        const float b = side * 0.3f;
        x = side * 0.5f + u(rng) * b;
        y = side * 0.5f + u(rng) * b;
        z = u(rng) * b;
        const int face = static_cast<int>(u(rng) * 3);
        if (face == 0) z = b;
        if (face == 1) x = side * 0.5f;
        if (face == 2) y = side * 0.5f;
      }
    }
    c.push_back(x + g(rng), y + g(rng), z + g(rng));
    const bool patch = (static_cast<int>(x / (side / 4)) + static_cast<int>(y / (side / 4))) % 2 == 0;
    red.push_back(patch ? 200 : 40);
    green.push_back(patch ? 60 : 180);
    blue.push_back(std::floor(u(rng) * 40) + 20);
    nir.push_back(x > side * 0.6f ? 210 : 30);
    inten.push_back(std::floor(u(rng) * 65535));
  }
  c.add_field("red", ced::scalar_type::uint8, red);
  c.add_field("green", ced::scalar_type::uint8, green);
  c.add_field("blue", ced::scalar_type::uint8, blue);
  c.add_field("nir", ced::scalar_type::uint8, nir);
  c.add_field("intensity", ced::scalar_type::uint16, inten);
  return c;
}

/// Five points: the origin, one on each axis at 1, 2 and 3, and (4, 4, 4).
/// Two copies of a room, 4 m apart in x, positions on a 1/1024 m lattice:
/// every difference and sum of the detection is exact, so each point of one
/// copy has bitwise the saliencies of its twin in the other: exact ties.
inline ced::point_cloud twin_rooms(std::size_t n, std::uint32_t seed) {
  const ced::point_cloud base = make_room(n, seed);
  ced::point_cloud c = base;
  c.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < 3; ++a) {
      const float v = std::round(base.position(i)[a] * 1024.0f) / 1024.0f;
      c.positions()[3 * i + a] = v;
      c.positions()[3 * (n + i) + a] = v + (a == 0 ? 4.0f : 0.0f);
    }
  for (auto& f : c.fields()) {
    f.values.resize(2 * n);
    for (std::size_t i = 0; i < n; ++i) f.values.set(n + i, f.values[i]);
  }
  return c;
}

inline ced::point_cloud five_points() {
  ced::point_cloud c;
  c.push_back(0, 0, 0);
  c.push_back(1, 0, 0);
  c.push_back(0, 2, 0);
  c.push_back(0, 0, 3);
  c.push_back(4, 4, 4);
  return c;
}

/// A channel for the oracle: per-point values (D each) and per-dimension scale.
struct oracle_channel {
  std::vector<std::vector<double>> values;  // [i][d]
  std::vector<double> scale;
  int norm = 1;  // 1 = L1, 2 = L2
  double threshold = 0;
  bool per_radius = false;  // measured per unit of each point's own radius (xyz under knn/adaptive)
};

/// Refinement by its definition (ALGORITHM.md step 7) for the maximum `k`
/// whose NMS ball (ascending) is `ball`: the point of the ball nearest to its
/// centroid weighted by `score` (sums in double; the plain centroid when every
/// weight is 0), ties to the smaller index.
inline std::uint32_t refined_point(const ced::point_cloud& c, const std::vector<std::uint32_t>& ball,
                                   const std::vector<float>& score, std::uint32_t k) {
  double w = 0, m[3] = {0, 0, 0};
  for (std::uint32_t j : ball) {
    w += score[j];
    for (int a = 0; a < 3; ++a) m[a] += double(score[j]) * c.position(j)[a];
  }
  if (!(w > 0)) {
    w = double(ball.size());
    m[0] = m[1] = m[2] = 0;
    for (std::uint32_t j : ball)
      for (int a = 0; a < 3; ++a) m[a] += c.position(j)[a];
  }
  std::uint32_t best = k;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::uint32_t j : ball) {
    double d = 0;
    for (int a = 0; a < 3; ++a) d += (c.position(j)[a] - m[a] / w) * (c.position(j)[a] - m[a] / w);
    if (d < best_d) best_d = d, best = j;
  }
  return best;
}

inline std::vector<std::vector<std::uint32_t>> brute_neighbors(const ced::point_cloud& c, double r) {
  const float r2 = static_cast<float>(r * r);
  std::vector<std::vector<std::uint32_t>> nb(c.size());
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t j = 0; j < c.size(); ++j) {
      const float* a = c.position(i);
      const float* b = c.position(j);
      const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
      if (dx * dx + dy * dy + dz * dz < r2) nb[i].push_back(static_cast<std::uint32_t>(j));
    }
  return nb;
}

struct oracle_result {
  std::vector<std::vector<double>> saliency;  // [m][i]
  std::vector<std::uint8_t> candidate;
  std::vector<std::uint32_t> keypoints;
  std::vector<std::uint32_t> neighbor_count;
};

/// The CED definition, literally: centroid = sum/n, distance in the norm,
/// OR of thresholds, NMS on the product with ties kept.
/// The CED definition over given neighbour lists nb[i]: centroid = sum/n,
/// distance in the norm, OR of thresholds, NMS on the product with ties
/// kept. A channel with `per_unit[i]` given (knn/adaptive neighbourhoods)
/// has its saliency multiplied by per_unit[i] when `ch[m].per_radius`.
inline oracle_result oracle_of_lists(const ced::point_cloud& c, const std::vector<oracle_channel>& ch,
                                     const std::vector<std::vector<std::uint32_t>>& nb, double nms_radius,
                                     std::uint32_t min_neighbors, const std::vector<double>& per_unit = {},
                                     const std::vector<float>& point_nms = {}) {
  const std::size_t n = c.size();
  oracle_result r;
  for (const auto& v : nb) r.neighbor_count.push_back(static_cast<std::uint32_t>(v.size()));
  r.saliency.assign(ch.size(), std::vector<double>(n, 0.0));
  for (std::size_t m = 0; m < ch.size(); ++m)
    for (std::size_t i = 0; i < n; ++i) {
      if (nb[i].size() < min_neighbors) continue;
      const std::size_t dims = ch[m].scale.size();
      double acc = 0;
      for (std::size_t d = 0; d < dims; ++d) {
        double sum = 0;
        for (auto j : nb[i]) sum += ch[m].values[j][d];
        const double diff = (sum / double(nb[i].size()) - ch[m].values[i][d]) * ch[m].scale[d];
        acc += ch[m].norm == 1 ? std::abs(diff) : diff * diff;
      }
      r.saliency[m][i] = ch[m].norm == 1 ? acc : std::sqrt(acc);
      if (ch[m].per_radius && !per_unit.empty()) r.saliency[m][i] *= per_unit[i];
    }
  r.candidate.assign(n, 0);
  std::vector<double> product(n, 1.0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t m = 0; m < ch.size(); ++m) {
      if (r.saliency[m][i] >= ch[m].threshold) r.candidate[i] = 1;
      product[i] *= r.saliency[m][i];
    }
  const auto nms = point_nms.empty() ? brute_neighbors(c, nms_radius) : std::vector<std::vector<std::uint32_t>>{};
  for (std::size_t i = 0; i < n; ++i) {
    if (!r.candidate[i]) continue;
    bool maximum = true;
    if (point_nms.empty()) {
      for (auto j : nms[i])
        if (product[j] > product[i]) maximum = false;
    } else {  // point i's own NMS radius (nms=own)
      const float r2 = static_cast<float>(double(point_nms[i]) * double(point_nms[i]));
      for (std::size_t j = 0; j < n; ++j) {
        const float* a = c.position(i);
        const float* b = c.position(j);
        const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
        if (dx * dx + dy * dy + dz * dz < r2 && product[j] > product[i]) maximum = false;
      }
    }
    if (maximum) r.keypoints.push_back(static_cast<std::uint32_t>(i));
  }
  return r;
}

inline oracle_result oracle(const ced::point_cloud& c, const std::vector<oracle_channel>& ch, double radius,
                            double nms_radius, std::uint32_t min_neighbors) {
  return oracle_of_lists(c, ch, brute_neighbors(c, radius), nms_radius, min_neighbors);
}

inline oracle_channel xyz_channel(const ced::point_cloud& c, double ratio, double radius) {
  oracle_channel ch;
  for (std::size_t i = 0; i < c.size(); ++i)
    ch.values.push_back({c.position(i)[0], c.position(i)[1], c.position(i)[2]});
  ch.scale = {1, 1, 1};
  ch.norm = 2;
  ch.threshold = ratio * radius;
  ch.per_radius = true;
  return ch;
}

inline oracle_channel field_channel(const ced::point_cloud& c, const std::vector<std::string>& names, double range,
                                    double threshold, int norm = 1) {
  oracle_channel ch;
  for (std::size_t i = 0; i < c.size(); ++i) {
    std::vector<double> v;
    for (const auto& name : names) v.push_back(c.get_field(name).values[i]);
    ch.values.push_back(v);
  }
  ch.scale.assign(names.size(), 1.0 / range);
  ch.norm = norm;
  ch.threshold = threshold;
  return ch;
}

}  // namespace ced_test
