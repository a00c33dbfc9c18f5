// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

namespace ced {

/// Fixed-radius neighbour search over a set of 3D points: a thin wrapper
/// around CGAL's `Kd_tree` (index keys, sliding-midpoint splitter). CGAL is
/// not included by this header.
///
/// Given a spatially coherent order, the index is a small forest: one tree
/// per run of at most 16,384 points of that order (past one tree, a multiple
/// of four runs of equal length), built in parallel, each small
/// enough to build in cache; queries visit the trees whose bounds they meet
/// and report their points tree after tree. The number of trees depends on
/// the number of points only, so results never depend on the thread count.
///
/// More than `bucket_size` points at one position (invalid LiDAR returns
/// stored at the origin) are one key of their tree, which stands for each of
/// them: the tree stays balanced and a search reports every one of them.
///
/// Semantics match the CED paper's implementation (FLANN): point j is a
/// neighbour of centre c when the squared distance, computed in float, is
/// strictly less than r² (float).
///
/// Threading: the tree is built in the constructor; all const member
/// functions may then be called concurrently from any number of threads.
class neighbor_index {
 public:
  /// Builds the index over `n` points given as N×3 row-major floats. The
  /// array must outlive the index. `bucket_size` is the kd-tree leaf size.
  /// `order`, when given, is a permutation of [0, n) listing the points in a
  /// spatially coherent order (e.g. a block_partition's): the trees are built
  /// over runs of it, several times faster on large clouds. Without it, one
  /// tree. Results are indices into `xyz` either way.
  neighbor_index(const float* xyz, std::size_t n, unsigned bucket_size = 32, unsigned threads = 1,
                 const std::uint32_t* order = nullptr);
  ~neighbor_index();
  neighbor_index(neighbor_index&&) noexcept;
  neighbor_index& operator=(neighbor_index&&) noexcept;
  neighbor_index(const neighbor_index&) = delete;
  neighbor_index& operator=(const neighbor_index&) = delete;

  std::size_t size() const noexcept { return m_n; }

  /// Replaces `out` with the indices j such that |p_j - c|² < r² (in the
  /// index's own order: deterministic, not sorted).
  void radius_search(const float c[3], double r, std::vector<std::uint32_t>& out) const;

  /// A point found with its squared distance (float, as squared_distance()).
  struct ranked_point {
    float d2;
    std::uint32_t index;
  };
  /// Replaces `out` with the k points nearest to c, nearest first: by
  /// squared distance in float, ties to the smaller index, with point `self`
  /// (an indexed point at c, or UINT32_MAX for none) always first. Exact
  /// whatever the forest's shape: CGAL's k-nearest search in one tree bounds
  /// the k-th distance, then a ball query over every tree settles the order.
  /// Fewer than k points when the index has fewer. `position`, when known,
  /// is self's position in the index's `order` (it picks the tree that
  /// holds self, the one that bounds best).
  void k_nearest(const float c[3], std::size_t k, std::uint32_t self, std::vector<ranked_point>& out,
                 std::size_t position = SIZE_MAX) const;

  /// An upper bound on the squared distance from c to its k-th nearest
  /// indexed point, cheaper than k_nearest(): the farthest of the k nearest
  /// within the tree that holds position `position` of the order (or, when
  /// that tree has fewer than k points or none is known, the exact k-th;
  /// +inf when the index has fewer than k points). `scratch` is work space.
  float k_distance_bound(const float c[3], std::size_t k, std::size_t position,
                         std::vector<ranked_point>& scratch) const;

  /// Distance from point i (an index of the indexed set) to its nearest
  /// other point (0 for a duplicate; +inf when it is alone).
  float nearest_other_distance(std::uint32_t i) const;
  /// When point i is one of more than a bucket's worth of coincident points
  /// (see above), and at least k of them: its k nearest into `out` (as
  /// k_nearest gives them: i, then the others by index, all at distance 0)
  /// and true. Else false, `out` unchanged. Cheap when the index has no
  /// such group.
  bool coincident_nearest(std::uint32_t i, std::size_t k, ranked_point* out) const {
    return !m_grouped.empty() && coincident_nearest_in_sets(i, k, out);
  }
  /// Distance from point i to the nearest point at another position (+inf
  /// when every point is at i's position).
  float nearest_distinct_distance(std::uint32_t i) const;

  /// Replaces `out` with the indices of all points inside the closed box
  /// [lo, hi] (deterministic order, not sorted).
  void box_search(const float lo[3], const float hi[3], std::vector<std::uint32_t>& out) const;
  /// A point found with its position, as the tree stores it.
  struct located_point {
    float xyz[3];
    std::uint32_t index;
  };
  /// The same points in the same order, each with its position (read from
  /// the tree itself, so the caller need not look them up).
  void box_search(const float lo[3], const float hi[3], std::vector<located_point>& out) const;

  struct impl;

 private:
  /// The tree that holds position `position` of the order, if it has at
  /// least k points (SIZE_MAX otherwise, or when position is unknown).
  std::size_t home_tree(std::size_t position, std::size_t k) const noexcept;
  /// Fills m_sets and m_grouped from the trees' groups.
  void index_groups();
  bool coincident_nearest_in_sets(std::uint32_t i, std::size_t k, ranked_point* out) const;
  std::unique_ptr<impl> m_impl;
  /// The points at each place that holds a coincident group (in any tree),
  /// ids ascending; and every such point with its set, by id.
  std::vector<std::vector<std::uint32_t>> m_sets;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> m_grouped;
  const float* m_xyz = nullptr;
  std::size_t m_n = 0;
};

/// The bits of a coordinate as a place: -0 as +0 (they are the same place),
/// so that positions compare as floats do (coincident points).
inline std::uint32_t place_bits(float v) noexcept {
  v += 0.0f;
  std::uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

/// Squared radius as the paper's code compares it: float(r*r).
inline float squared_radius(double r) noexcept { return static_cast<float>(r * r); }

/// Squared distance between two points of an N×3 float array, in float.
inline float squared_distance(const float* a, const float* b) noexcept {
  const float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

}  // namespace ced
