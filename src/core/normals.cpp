// SPDX-License-Identifier: MIT
// Normals by local PCA, and their orientation tensors (the normals modality).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/channels.hpp"
#include "ced/detect.hpp"
#include "ced/scaled.hpp"
#include "core/detection.hpp"

namespace ced {

namespace {

/// The unit eigenvector of the smallest eigenvalue of the symmetric 3×3
/// matrix a (row-major), by cyclic Jacobi rotations: a fixed sequence of
/// operations, so the same input always gives the same bits.
bool smallest_eigenvector(double a[3][3], float out[3]) noexcept {
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = std::abs(a[0][1]) + std::abs(a[0][2]) + std::abs(a[1][2]);
    const double diag = std::abs(a[0][0]) + std::abs(a[1][1]) + std::abs(a[2][2]);
    if (off <= 1e-15 * diag || off == 0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 3; ++k) {  // a ← a·J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // a ← Jᵀ·a
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // v ← v·J
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  int m = 0;
  for (int k = 1; k < 3; ++k)
    if (a[k][k] < a[m][m]) m = k;
  const double len = std::sqrt(v[0][m] * v[0][m] + v[1][m] * v[1][m] + v[2][m] * v[2][m]);
  if (!(len > 0)) return false;
  // A sign fixed by the vector alone (its largest component positive), so
  // that the result does not depend on the rotation order's leftovers.
  int big = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(v[k][m]) > std::abs(v[big][m])) big = k;
  const double sign = v[big][m] < 0 ? -1.0 : 1.0;
  for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(sign * v[k][m] / len);
  return true;
}

}  // namespace

namespace {
/// The normal from a neighbourhood's n, Σ d and Σ d dᵀ (xx, xy, xz, yy, yz,
/// zz) of the offsets d from the point: (0, 0, 0) below 3 neighbours or
/// when they are all at one place.
void normal_from_moments(std::uint32_t n, const double s[3], const double ss[6], float out[3]) noexcept {
  out[0] = out[1] = out[2] = 0;
  if (n < 3) return;
  const double inv = 1.0 / n;
  const double mx = s[0] * inv, my = s[1] * inv, mz = s[2] * inv;
  double c[3][3];
  c[0][0] = ss[0] * inv - mx * mx;
  c[0][1] = c[1][0] = ss[1] * inv - mx * my;
  c[0][2] = c[2][0] = ss[2] * inv - mx * mz;
  c[1][1] = ss[3] * inv - my * my;
  c[1][2] = c[2][1] = ss[4] * inv - my * mz;
  c[2][2] = ss[5] * inv - mz * mz;
  if (!(c[0][0] + c[1][1] + c[2][2] > 0)) return;  // all at one place
  smallest_eigenvector(c, out);
}
}  // namespace

void normal_from_neighbors(const float* xyz, std::uint32_t point, const std::uint32_t* neighbors, std::uint32_t n,
                           float out[3]) noexcept {
  // Moments of the offsets from the point, in double: stable far from the
  // origin.
  const double px = xyz[3 * std::size_t(point)], py = xyz[3 * std::size_t(point) + 1],
               pz = xyz[3 * std::size_t(point) + 2];
  double s[3] = {0, 0, 0}, ss[6] = {0, 0, 0, 0, 0, 0};
  for (std::uint32_t k = 0; k < n; ++k) {
    const float* q = xyz + 3 * std::size_t(neighbors[k]);
    const double dx = q[0] - px, dy = q[1] - py, dz = q[2] - pz;
    s[0] += dx, s[1] += dy, s[2] += dz;
    ss[0] += dx * dx, ss[1] += dx * dy, ss[2] += dx * dz;
    ss[3] += dy * dy, ss[4] += dy * dz, ss[5] += dz * dz;
  }
  normal_from_moments(n, s, ss, out);
}

std::vector<float> estimate_normals(const point_cloud& cloud, double radius, unsigned threads) {
  if (!(radius > 0) || !std::isfinite(radius))
    throw std::invalid_argument("estimate_normals: the radius must be a finite number > 0, got " +
                                std::to_string(radius));
  detect_params p;
  p.radius = p.nms_radius = radius;
  p.threads = threads;
  return estimate_normals(cloud, p);
}

std::vector<float> estimate_normals(const point_cloud& cloud, const detect_params& params, double factor) {
  if (!(factor > 0 && factor <= 1))
    throw std::invalid_argument("estimate_normals: the factor must be in (0, 1], got " + std::to_string(factor));
  // knn:K itself at factor 1; otherwise factor × each point's radius.
  detect_params p = factor == 1 ? params : scaled_params(params, factor);
  p.min_neighbors = 1;
  p.max_keypoints = 0;
  p.keypoint_share = 0;
  p.refine = false;
  p.progress = nullptr;  // a stage of the caller's detection, not one of its own
  std::vector<float> normals(3 * cloud.size(), 0.0f);
  if (cloud.empty()) return normals;
  detail::detection_context ctx(cloud, p, {"normals"}, {std::numeric_limits<double>::max()});
  const float* xyz = cloud.positions().data();
  if (p.neighborhood.fixed() && p.search == search_kind::grid) {
    // The grid's pass sums d and d dᵀ in its vector lanes, in an order fixed
    // by the sub-cells (so the same in any tile), with no neighbour lists.
    ctx.without_neighbor_lists();
    ctx.with_position_moments();
    ctx.compute_saliency({channel_source{}}, [&](const block_view& block, float* const*) {
      for (std::size_t k = 0; k < block.size(); ++k) {
        const double* s = block.position_sums(k);
        const double* m = s + 3;  // xx, yy, zz, xy, xz, yz
        const double ss[6] = {m[0], m[3], m[4], m[1], m[5], m[2]};
        normal_from_moments(block.count(k), s, ss, normals.data() + 3 * std::size_t(block.point(k)));
      }
    });
    return normals;
  }
  ctx.compute_saliency({channel_source{}}, [&](const block_view& block, float* const*) {
    std::vector<std::uint32_t> sorted;
    for (std::size_t k = 0; k < block.size(); ++k) {
      const neighborhood nb = block[k];
      // By index: the sums then depend only on the set of neighbours, not on
      // how the cloud was split into blocks or tiles.
      sorted.assign(nb.begin(), nb.end());
      std::sort(sorted.begin(), sorted.end());
      normal_from_neighbors(xyz, nb.point, sorted.data(), nb.size, normals.data() + 3 * std::size_t(nb.point));
    }
  });
  return normals;
}

std::vector<float> normal_tensors(const std::vector<float>& normals) {
  if (normals.size() % 3 != 0) throw std::invalid_argument("normal_tensors: not N×3 values");
  const std::size_t n = normals.size() / 3;
  std::vector<float> t(6 * n);
  for (std::size_t i = 0; i < n; ++i) {
    double x = normals[3 * i], y = normals[3 * i + 1], z = normals[3 * i + 2];
    const double len = std::sqrt(x * x + y * y + z * z);
    if (!std::isfinite(len)) throw std::invalid_argument("normal of point " + std::to_string(i) + " is not finite");
    if (len > 0) x /= len, y /= len, z /= len;  // a zero normal stays zero
    float* o = t.data() + 6 * i;
    o[0] = static_cast<float>(x * x), o[1] = static_cast<float>(y * y), o[2] = static_cast<float>(z * z);
    o[3] = static_cast<float>(x * y), o[4] = static_cast<float>(x * z), o[5] = static_cast<float>(y * z);
  }
  return t;
}

}  // namespace ced
