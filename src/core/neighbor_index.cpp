// SPDX-License-Identifier: MIT
// The only translation unit that includes CGAL's spatial search.
#include "core/neighbor_index.hpp"

#include <CGAL/Euclidean_distance.h>
#include <CGAL/Fuzzy_iso_box.h>
#include <CGAL/Fuzzy_sphere.h>
#include <CGAL/Kd_tree.h>
#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Search_traits_adapter.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <boost/iterator/counting_iterator.hpp>
#include <boost/iterator/function_output_iterator.hpp>
#include <boost/iterator/transform_iterator.hpp>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/parallel.hpp"

namespace ced {

namespace {
using kernel = CGAL::Simple_cartesian<float>;
using point_3 = kernel::Point_3;
/// A point of the tree: its coordinates and its index in the input. The tree
/// stores and partitions these directly and reads the coordinates from the
/// key itself (no indirection into another array), which keeps its build and
/// searches cache-friendly.
struct indexed_point {
  point_3 p;
  std::uint32_t id;
};
struct point_of {
  using key_type = indexed_point;
  using value_type = point_3;
  using reference = const point_3&;
  using category = boost::readable_property_map_tag;
  friend reference get(const point_of&, const indexed_point& k) { return k.p; }
};
using base_traits = CGAL::Search_traits_3<kernel>;
using traits = CGAL::Search_traits_adapter<indexed_point, point_of, base_traits>;
using splitter = CGAL::Sliding_midpoint<traits>;
using tree_type = CGAL::Kd_tree<traits, splitter, CGAL::Tag_true, CGAL::Tag_false>;
using sphere = CGAL::Fuzzy_sphere<traits>;
using iso_box = CGAL::Fuzzy_iso_box<traits>;
using distance = CGAL::Distance_adapter<indexed_point, point_of, CGAL::Euclidean_distance<base_traits>>;
using knn = CGAL::Orthogonal_k_neighbor_search<traits, distance, splitter, tree_type>;

point_3 at(const float c[3]) noexcept { return point_3(c[0], c[1], c[2]); }

/// Appends the ids of reported points to a vector (copy-assignable, as the
/// output iterator needs).
struct append_id {
  std::vector<std::uint32_t>* out;
  void operator()(const indexed_point& k) const { out->push_back(k.id); }
};
/// Appends reported points with their positions.
struct append_located {
  std::vector<neighbor_index::located_point>* out;
  void operator()(const indexed_point& k) const { out->push_back({{k.p.x(), k.p.y(), k.p.z()}, k.id}); }
};
}  // namespace

namespace {
/// The k-th point of the tree's input: point order[k] (or k) of the array.
struct point_at {
  const float* xyz;
  const std::uint32_t* order;
  indexed_point operator()(std::size_t k) const {
    const std::size_t i = order ? order[k] : k;
    return {point_3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]), static_cast<std::uint32_t>(i)};
  }
};

/// Points per tree of the forest (see the header). A tree of 16,384 keys
/// and their pointers (~400 kB) builds within a core's L2 cache; on the
/// 105k-point loft scan, 2^14 builds in 14 % fewer instructions than 2^16
/// and the two threads' builds slow each other down less.
constexpr std::size_t max_tree_points = std::size_t(1) << 14;

bool boxes_meet(const float alo[3], const float ahi[3], const float blo[3], const float bhi[3]) noexcept {
  for (int k = 0; k < 3; ++k)
    if (!(alo[k] <= bhi[k] && blo[k] <= ahi[k])) return false;
  return true;
}
}  // namespace

struct neighbor_index::impl {
  /// One tree over points order[begin..end), and their bounds.
  struct part {
    tree_type tree;
    float lo[3], hi[3];
    /// The tree copies its points straight from the array, in the given order.
    part(const float* xyz, const std::uint32_t* order, std::size_t begin, std::size_t end, unsigned bucket)
        : tree(boost::make_transform_iterator(boost::counting_iterator<std::size_t>(begin), point_at{xyz, order}),
               boost::make_transform_iterator(boost::counting_iterator<std::size_t>(end), point_at{xyz, order}),
               splitter(bucket), traits(point_of{})) {}
    /// Once built: the bounds of the tree's points, which CGAL computed.
    void take_bounds() {
      const auto& box = tree.bounding_box();
      for (int a = 0; a < 3; ++a) {
        lo[a] = box.min_coord(a);
        hi[a] = box.max_coord(a);
      }
    }
  };
  std::vector<std::unique_ptr<part>> parts;
};

neighbor_index::neighbor_index(const float* xyz, std::size_t n, unsigned bucket_size, unsigned threads,
                               const std::uint32_t* order)
    : m_impl(std::make_unique<impl>()), m_xyz(xyz), m_n(n) {
  if (n > std::size_t(UINT32_MAX) - 1) throw std::length_error("neighbor_index: too many points (max 2^32-2)");
  if (bucket_size == 0) throw std::invalid_argument("neighbor_index: bucket_size must be positive");
  if (order && std::any_of(order, order + n, [n](std::uint32_t i) { return i >= n; }))
    throw std::invalid_argument("neighbor_index: order is not a permutation");
  if (n == 0) return;
  // With a spatially coherent order, one tree per run of at most
  // max_tree_points of it. Past one tree, a multiple of four trees of equal
  // size, so that 2 or 4 threads build equal shares (7 trees on 2 threads
  // took as long as 8). The number depends on n only, never on the threads.
  std::size_t trees = order ? (n + max_tree_points - 1) / max_tree_points : 1;
  if (trees > 1) trees = (trees + 3) / 4 * 4;
  auto& parts = m_impl->parts;
  parts.resize(trees);
#if defined(CED_HAS_TBB) && defined(CGAL_LINKED_WITH_TBB)
  if (trees == 1 && threads != 1) {
    // The tree's shape does not depend on the thread count, so queries see
    // the same tree (and report neighbours in the same order) either way.
    parts[0] = std::make_unique<impl::part>(xyz, order, 0, n, bucket_size);
    detail::with_threads(threads, [&] { parts[0]->tree.build<CGAL::Parallel_tag>(); });
    parts[0]->take_bounds();
    return;
  }
#endif
  detail::parallel_for(trees, threads, 1, [&](std::size_t t0, std::size_t t1) {
    for (std::size_t t = t0; t < t1; ++t) {
      parts[t] = std::make_unique<impl::part>(xyz, order, n * t / trees, n * (t + 1) / trees, bucket_size);
      parts[t]->tree.build();
      parts[t]->take_bounds();
    }
  });
}

neighbor_index::~neighbor_index() = default;
neighbor_index::neighbor_index(neighbor_index&&) noexcept = default;
neighbor_index& neighbor_index::operator=(neighbor_index&&) noexcept = default;

void neighbor_index::radius_search(const float c[3], double r, std::vector<std::uint32_t>& out) const {
  out.clear();
  if (m_n == 0 || !(r > 0)) return;
  const float r2 = squared_radius(r);
  // Query a slightly larger sphere, then apply the exact float test.
  const float rq = static_cast<float>(r) * 1.0001f + 1e-30f;
  struct strict_filter {
    const float* c;
    float r2;
    std::vector<std::uint32_t>* out;
    void operator()(const indexed_point& k) const {
      const float q[3] = {k.p.x(), k.p.y(), k.p.z()};
      if (squared_distance(q, c) < r2) out->push_back(k.id);
    }
  };
  const float qlo[3] = {c[0] - rq, c[1] - rq, c[2] - rq}, qhi[3] = {c[0] + rq, c[1] + rq, c[2] + rq};
  for (const auto& part : m_impl->parts) {
    if (!boxes_meet(qlo, qhi, part->lo, part->hi)) continue;
    auto sink = boost::make_function_output_iterator(strict_filter{c, r2, &out});
    part->tree.search(sink, sphere(at(c), rq, 0.0f, part->tree.traits()));
  }
}

std::size_t neighbor_index::home_tree(std::size_t position, std::size_t k) const noexcept {
  const auto& parts = m_impl->parts;
  if (position >= m_n) return SIZE_MAX;
  // Tree t holds positions [n·t/trees, n·(t+1)/trees) of the order.
  std::size_t t = position * parts.size() / m_n;
  while (t + 1 < parts.size() && m_n * (t + 1) / parts.size() <= position) ++t;
  while (t > 0 && m_n * t / parts.size() > position) --t;
  return parts[t]->tree.size() >= k ? t : SIZE_MAX;
}

float neighbor_index::k_distance_bound(const float c[3], std::size_t k, std::size_t position,
                                       std::vector<ranked_point>& scratch) const {
  const std::size_t t = k > 0 ? home_tree(position, k) : SIZE_MAX;
  float bound = 0;
  if (t == SIZE_MAX) {  // no tree of k points known: the exact k nearest
    k_nearest(c, k, UINT32_MAX, scratch, position);
    for (const auto& p : scratch) bound = std::max(bound, p.d2);
    return scratch.size() < k ? HUGE_VALF : bound;
  }
  // Any k points bound the k-th distance by their farthest: take the home tree's k nearest.
  const knn search(m_impl->parts[t]->tree, at(c), static_cast<unsigned>(k), 0.0f, true, distance(point_of{}), false);
  for (const auto& hit : search) {
    const float q[3] = {hit.first.p.x(), hit.first.p.y(), hit.first.p.z()};
    bound = std::max(bound, squared_distance(q, c));
  }
  return bound;
}

void neighbor_index::k_nearest(const float c[3], std::size_t k, std::uint32_t self, std::vector<ranked_point>& out,
                               std::size_t position) const {
  out.clear();
  if (m_n == 0 || k == 0) return;
  auto before = [self](const ranked_point& a, const ranked_point& b) {
    const bool a_self = a.index == self, b_self = b.index == self;
    if (a_self != b_self) return a_self;
    return a.d2 < b.d2 || (a.d2 == b.d2 && a.index < b.index);
  };
  // 1. A bound on the k-th distance: k points of the tree that holds self,
  // or of every tree (when it is not known, or has fewer than k points).
  const auto& parts = m_impl->parts;
  const std::size_t t_home = home_tree(position, k);
  const impl::part* home = t_home == SIZE_MAX ? nullptr : parts[t_home].get();
  // One tree: its k + 1 nearest settle the answer unless the (k+1)-th is
  // as near as the k-th (a tie, or CGAL's rounding of the distance, which
  // may differ from ours by a few ulps): then the ball query below does.
  const bool one_tree = parts.size() == 1;
  const std::size_t ask = one_tree ? k + 1 : k;
  for (const auto& part : parts) {
    if (home && part.get() != home) continue;
    const knn search(part->tree, at(c), static_cast<unsigned>(ask), 0.0f, true, distance(point_of{}), false);
    for (const auto& hit : search) {
      const float q[3] = {hit.first.p.x(), hit.first.p.y(), hit.first.p.z()};
      out.push_back({squared_distance(q, c), hit.first.id});
    }
  }
  if (one_tree && out.size() <= k) {  // the whole index
    std::sort(out.begin(), out.end(), before);
    return;
  }
  if (one_tree) {
    std::sort(out.begin(), out.end(), before);
    float kth = 0;
    for (std::size_t q = 0; q < k; ++q) kth = std::max(kth, out[q].d2);
    if (out[k].d2 > kth * (1 + 1e-5f) && (self == UINT32_MAX || out[0].index == self)) {
      out.resize(k);
      return;
    }
  }
  if (out.size() > k) {
    std::nth_element(out.begin(), out.begin() + std::ptrdiff_t(k - 1), out.end(), before);
    out.resize(k);
  }
  float bound = 0;
  for (const auto& p : out) bound = std::max(bound, p.d2);
  // 2. Every point within that bound (the point itself is among them), in
  // exact order; the first k are the answer.
  out.clear();
  const float rq = std::sqrt(bound) * 1.0001f + 1e-30f;
  const float qlo[3] = {c[0] - rq, c[1] - rq, c[2] - rq}, qhi[3] = {c[0] + rq, c[1] + rq, c[2] + rq};
  struct within_bound {
    const float* c;
    float bound;
    std::vector<ranked_point>* out;
    void operator()(const indexed_point& key) const {
      const float q[3] = {key.p.x(), key.p.y(), key.p.z()};
      const float d2 = squared_distance(q, c);
      if (d2 <= bound) out->push_back({d2, key.id});
    }
  };
  for (const auto& part : m_impl->parts) {
    if (!boxes_meet(qlo, qhi, part->lo, part->hi)) continue;
    auto sink = boost::make_function_output_iterator(within_bound{c, bound, &out});
    part->tree.search(sink, sphere(at(c), rq, 0.0f, part->tree.traits()));
  }
  if (out.size() > k) {
    std::partial_sort(out.begin(), out.begin() + std::ptrdiff_t(k), out.end(), before);
    out.resize(k);
  } else {
    std::sort(out.begin(), out.end(), before);
  }
}

float neighbor_index::nearest_other_distance(std::uint32_t i) const {
  if (i >= m_n) throw std::out_of_range("neighbor_index::nearest_other_distance: index out of range");
  const float* p = m_xyz + 3 * std::size_t(i);
  float best = std::numeric_limits<float>::infinity();
  // The two nearest in each tree: the point itself (in its own tree) and
  // the nearest other one are among them.
  for (const auto& part : m_impl->parts) {
    const knn search(part->tree, at(p), 2, 0.0f, true, distance(point_of{}));
    for (const auto& hit : search) {
      const std::uint32_t j = hit.first.id;
      if (j != i) best = std::min(best, std::sqrt(squared_distance(m_xyz + 3 * std::size_t(j), p)));
    }
  }
  return best;
}

void neighbor_index::box_search(const float lo[3], const float hi[3], std::vector<std::uint32_t>& out) const {
  out.clear();
  for (const auto& part : m_impl->parts)
    if (boxes_meet(lo, hi, part->lo, part->hi))
      part->tree.search(boost::make_function_output_iterator(append_id{&out}),
                        iso_box(at(lo), at(hi), 0.0f, part->tree.traits()));
}

void neighbor_index::box_search(const float lo[3], const float hi[3], std::vector<located_point>& out) const {
  out.clear();
  for (const auto& part : m_impl->parts)
    if (boxes_meet(lo, hi, part->lo, part->hi))
      part->tree.search(boost::make_function_output_iterator(append_located{&out}),
                        iso_box(at(lo), at(hi), 0.0f, part->tree.traits()));
}

}  // namespace ced
