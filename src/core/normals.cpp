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

/// For each of L symmetric 3×3 matrices a[l] (row-major) marked in `todo`,
/// the unit eigenvector of its smallest eigenvalue, by cyclic Jacobi
/// rotations, to out[l] ((0, 0, 0) where none is found). A fixed sequence of
/// operations per matrix, the same whatever the other lanes hold: the same
/// input always gives the same bits, alone (L = 1) or in a batch. The lanes
/// are independent chains of divisions and roots, which the CPU overlaps.
template <int L>
void smallest_eigenvectors(double (&a)[L][3][3], const bool (&todo)[L], float (&out)[L][3]) noexcept {
  double v[L][3][3];
  bool active[L];
  for (int l = 0; l < L; ++l) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) v[l][i][j] = i == j ? 1.0 : 0.0;
    active[l] = todo[l];
    out[l][0] = out[l][1] = out[l][2] = 0;
  }
  for (int sweep = 0; sweep < 50; ++sweep) {
    bool any = false;
    for (int l = 0; l < L; ++l) {
      if (!active[l]) continue;
      const double off = std::abs(a[l][0][1]) + std::abs(a[l][0][2]) + std::abs(a[l][1][2]);
      const double diag = std::abs(a[l][0][0]) + std::abs(a[l][1][1]) + std::abs(a[l][2][2]);
      active[l] = !(off <= 1e-15 * diag || off == 0);
      any = any || active[l];
    }
    if (!any) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        double c[L], s[L];
        bool use[L];
        for (int l = 0; l < L; ++l) {
          use[l] = active[l] && a[l][p][q] != 0;
          const double apq = use[l] ? a[l][p][q] : 1.0;
          const double theta = (a[l][q][q] - a[l][p][p]) / (2 * apq);
          const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
          c[l] = 1 / std::sqrt(t * t + 1);
          s[l] = t * c[l];
        }
        for (int l = 0; l < L; ++l) {
          if (!use[l]) continue;
          double(&m)[3][3] = a[l];
          double(&w)[3][3] = v[l];
          for (int k = 0; k < 3; ++k) {  // a ← a·J
            const double akp = m[k][p], akq = m[k][q];
            m[k][p] = c[l] * akp - s[l] * akq;
            m[k][q] = s[l] * akp + c[l] * akq;
          }
          for (int k = 0; k < 3; ++k) {  // a ← Jᵀ·a
            const double apk = m[p][k], aqk = m[q][k];
            m[p][k] = c[l] * apk - s[l] * aqk;
            m[q][k] = s[l] * apk + c[l] * aqk;
          }
          for (int k = 0; k < 3; ++k) {  // v ← v·J
            const double vkp = w[k][p], vkq = w[k][q];
            w[k][p] = c[l] * vkp - s[l] * vkq;
            w[k][q] = s[l] * vkp + c[l] * vkq;
          }
        }
      }
  }
  for (int l = 0; l < L; ++l) {
    if (!todo[l]) continue;
    int m = 0;
    for (int k = 1; k < 3; ++k)
      if (a[l][k][k] < a[l][m][m]) m = k;
    const double len = std::sqrt(v[l][0][m] * v[l][0][m] + v[l][1][m] * v[l][1][m] + v[l][2][m] * v[l][2][m]);
    if (!(len > 0)) continue;
    // A sign fixed by the vector alone (its largest component positive), so
    // that the result does not depend on the rotation order's leftovers.
    int big = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(v[l][k][m]) > std::abs(v[l][big][m])) big = k;
    const double sign = v[l][big][m] < 0 ? -1.0 : 1.0;
    for (int k = 0; k < 3; ++k) out[l][k] = static_cast<float>(sign * v[l][k][m] / len);
  }
}

/// The covariance from a neighbourhood's n, Σ d and Σ d dᵀ (xx, xy, xz, yy,
/// yz, zz) of the offsets d from the point, to c; false below 3 neighbours
/// or when they are all at one place (no normal).
bool covariance_from_moments(std::uint32_t n, const double s[3], const double ss[6], double (&c)[3][3]) noexcept {
  if (n < 3) return false;
  const double inv = 1.0 / n;
  const double mx = s[0] * inv, my = s[1] * inv, mz = s[2] * inv;
  c[0][0] = ss[0] * inv - mx * mx;
  c[0][1] = c[1][0] = ss[1] * inv - mx * my;
  c[0][2] = c[2][0] = ss[2] * inv - mx * mz;
  c[1][1] = ss[3] * inv - my * my;
  c[1][2] = c[2][1] = ss[4] * inv - my * mz;
  c[2][2] = ss[5] * inv - mz * mz;
  return c[0][0] + c[1][1] + c[2][2] > 0;
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
  double c[1][3][3] = {};
  const bool todo[1] = {covariance_from_moments(n, s, ss, c[0])};
  float result[1][3];
  smallest_eigenvectors<1>(c, todo, result);
  std::copy_n(result[0], 3, out);
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
      // Four points at a time (independent lanes: each point's bits are
      // its own).
      constexpr int lanes = 4;
      for (std::size_t k0 = 0; k0 < block.size(); k0 += lanes) {
        const int used = static_cast<int>(std::min<std::size_t>(lanes, block.size() - k0));
        double c[lanes][3][3] = {};
        bool todo[lanes] = {};
        for (int l = 0; l < used; ++l) {
          const double* s = block.position_sums(k0 + std::size_t(l));
          const double* m = s + 3;  // xx, yy, zz, xy, xz, yz
          const double ss[6] = {m[0], m[3], m[4], m[1], m[5], m[2]};
          todo[l] = covariance_from_moments(block.count(k0 + std::size_t(l)), s, ss, c[l]);
        }
        float result[lanes][3];
        smallest_eigenvectors<lanes>(c, todo, result);
        for (int l = 0; l < used; ++l)
          std::copy_n(result[l], 3, normals.data() + 3 * std::size_t(block.point(k0 + std::size_t(l))));
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
