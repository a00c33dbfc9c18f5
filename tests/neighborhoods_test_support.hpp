// SPDX-License-Identifier: MIT
// Helpers of the tests split from test_neighborhoods.cpp.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "core/neighbor_index.hpp"
#include "test_support.hpp"
#include "tiled_support.hpp"

namespace neighborhoods_test {

using lists = std::vector<std::vector<std::uint32_t>>;

/// A room scanned from one corner: floor, two walls and a box, each point
/// kept with a probability that falls with the square of its range, so the
/// spacing grows from about 5 mm near the sensor to several cm far away.
/// Coloured patches; a few exact duplicates (ties at distance 0).
inline ced::point_cloud scanned_room(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ced::point_cloud c;
  std::vector<double> red, green, blue;
  while (c.size() < n) {
    float p[3] = {u(rng) * 2.0f, u(rng) * 2.0f, u(rng) * 2.0f};
    const int surface = int(u(rng) * 4);
    if (surface == 0) p[2] = 0;
    if (surface == 1) p[0] = 0;
    if (surface == 2) p[1] = 0;
    if (surface == 3) {  // a box face at z = 0.3 over [0.8, 1.2]²
      p[0] = 0.8f + 0.4f * u(rng), p[1] = 0.8f + 0.4f * u(rng), p[2] = 0.3f;
    }
    const float range2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    if (u(rng) > std::min(1.0f, 0.15f / range2)) continue;
    const bool patch = p[0] > 0.5f && p[0] < 1.0f && p[1] < 0.6f;
    const int copies = c.size() % 97 == 0 ? 2 : 1;
    for (int k = 0; k < copies && c.size() < n; ++k) {
      c.push_back(p[0], p[1], p[2]);
      red.push_back(patch ? 200 : 60);
      green.push_back(patch ? 40 : 60 + (surface * 30));
      blue.push_back(50);
    }
  }
  c.add_field("red", ced::scalar_type::uint8, red);
  c.add_field("green", ced::scalar_type::uint8, green);
  c.add_field("blue", ced::scalar_type::uint8, blue);
  return c;
}

inline float d2(const ced::point_cloud& c, std::size_t i, std::size_t j) {
  const float* a = c.position(i);
  const float* b = c.position(j);
  const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
  return dx * dx + dy * dy + dz * dz;
}

/// Every point's k nearest (itself first, then by squared distance in
/// float, ties to the smaller index), by sorting all points.
inline lists brute_knn(const ced::point_cloud& c, std::size_t k) {
  lists out(c.size());
  std::vector<std::uint32_t> all(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (std::size_t j = 0; j < c.size(); ++j) all[j] = std::uint32_t(j);
    std::sort(all.begin(), all.end(), [&](std::uint32_t a, std::uint32_t b) {
      if ((a == i) != (b == i)) return a == i;
      const float da = d2(c, i, a), db = d2(c, i, b);
      return da < db || (da == db && a < b);
    });
    out[i].assign(all.begin(), all.begin() + std::ptrdiff_t(k));
  }
  return out;
}

/// The neighbourhoods the spec defines, and each point's own radius.
inline lists brute_neighborhoods(const ced::point_cloud& c, const ced::neighborhood_spec& n,
                                 std::vector<double>& radius) {
  const lists knn = brute_knn(c, n.k);
  lists out(c.size());
  radius.assign(c.size(), 0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double dk = std::sqrt(double(d2(c, i, knn[i].back())));
    if (n.kind == ced::neighborhood_kind::knn) {
      out[i] = knn[i];
      std::sort(out[i].begin(), out[i].end());
      radius[i] = dk;
      continue;
    }
    radius[i] = std::min(std::max(n.scale * dk, n.min_radius), n.max_radius);
    const float r2 = static_cast<float>(radius[i] * radius[i]);
    for (std::size_t j = 0; j < c.size(); ++j)
      if (d2(c, i, j) < r2 || j == i) out[i].push_back(std::uint32_t(j));
  }
  return out;
}

/// A list-reading modality that checks every list it is given against the
/// expected one (ascending indices) and counts the mismatches.
struct list_check {
  const lists* expected;
  std::atomic<int>* wrong;
  std::string name() const { return "list_check"; }
  double threshold(const ced::detect_params&) const { return 1e30; }
  struct evaluator {
    const lists* expected;
    std::atomic<int>* wrong;
    float operator()(const ced::neighborhood& nb) const {
      const auto& e = (*expected)[nb.point];
      if (!std::equal(nb.begin(), nb.end(), e.begin(), e.end())) ++*wrong;
      return 0.0f;
    }
  };
  evaluator bind(const ced::point_cloud&, const ced::detect_params&) const { return {expected, wrong}; }
};

/// Each point's own NMS radius under nms=own, as the detector rounds it.
inline std::vector<float> own_nms(const ced::detection_result& r, const ced::detect_params& p) {
  std::vector<float> out;
  for (float ri : r.point_radius) out.push_back(static_cast<float>(p.nms_radius / p.radius * double(ri)));
  return out;
}

inline std::vector<ced::neighborhood_spec> kinds() {
  std::vector<ced::neighborhood_spec> out;
  for (const char* text :
       {"knn:1", "knn:12", "knn:30", "adaptive:12", "adaptive:8,scale=0.7", "adaptive:10,scale=1.6",
        "adaptive:12,min=0.06", "adaptive:16,scale=2,max=0.05", "knn:16,nms=own", "adaptive:12,scale=1.5,nms=own"})
    out.push_back(ced::parse_neighborhood(text));
  return out;
}

}  // namespace neighborhoods_test
