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
#include <cstring>
#include <limits>
#include <stdexcept>
#include <tuple>

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

/// Coincident points: more than a bucket's worth of points at one position
/// would make a degenerate tree (one point split off a level: a recursion
/// as deep as the points, and searches as slow as a list), so each such
/// group is one key of the tree, which stands for all of its points.
struct coincident_groups {
  /// Each group's point ids, ascending; group g is members[begin[g] .. begin[g + 1]).
  std::vector<std::uint32_t> members, begin{0};
  /// (a group's key id, which is its smallest member, group) by key id.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_key;

  bool empty() const noexcept { return by_key.empty(); }
  /// The group whose key is `id`, or UINT32_MAX.
  std::uint32_t group_of_key(std::uint32_t id) const noexcept {
    const auto it = std::lower_bound(by_key.begin(), by_key.end(), std::make_pair(id, std::uint32_t(0)));
    return it != by_key.end() && it->first == id ? it->second : UINT32_MAX;
  }
  const std::uint32_t* first(std::uint32_t g) const noexcept { return members.data() + begin[g]; }
  std::size_t size(std::uint32_t g) const noexcept { return begin[g + 1] - begin[g]; }
};

/// The groups of more than `bucket` coincident points among order[begin..end)
/// (or begin..end), found by counting hashed positions first, so that a
/// cloud without such groups costs one pass and a table of counts.
coincident_groups find_groups(const float* xyz, const std::uint32_t* order, std::size_t begin, std::size_t end,
                              unsigned bucket) {
  coincident_groups g;
  const std::size_t m = end - begin;
  if (m <= bucket) return g;
  std::size_t slots = 64;
  while (slots < 2 * m) slots *= 2;
  int shift = 64;
  for (std::size_t s = slots; s > 1; s /= 2) --shift;
  const auto hash = [&](std::uint32_t i) {
    const float* p = xyz + 3 * std::size_t(i);
    const std::uint64_t h = (place_bits(p[0]) * 0x9E3779B97F4A7C15ull) ^ (place_bits(p[1]) * 0xBF58476D1CE4E5B9ull) ^
                            (place_bits(p[2]) * 0x94D049BB133111EBull);
    return std::size_t(h >> shift);
  };
  const auto id = [&](std::size_t t) { return order ? order[t] : static_cast<std::uint32_t>(t); };
  // Counts that stop at 255 (a count of 255 is 255 or more).
  const unsigned crowd = std::min(bucket, 254u);
  std::vector<std::uint8_t> count(slots, 0);
  std::uint8_t most = 0;
  for (std::size_t t = begin; t < end; ++t) {
    std::uint8_t& c = count[hash(id(t))];
    c = static_cast<std::uint8_t>(c + (c != 255));
    most = std::max(most, c);
  }
  if (most <= crowd) return g;
  // The points of crowded slots, by position then id: runs of one position.
  struct placed {
    std::uint32_t x, y, z, id;
    bool operator<(const placed& o) const noexcept { return std::tie(x, y, z, id) < std::tie(o.x, o.y, o.z, o.id); }
  };
  std::vector<placed> crowded;
  for (std::size_t t = begin; t < end; ++t) {
    const std::uint32_t i = id(t);
    if (count[hash(i)] <= crowd) continue;
    const float* p = xyz + 3 * std::size_t(i);
    if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
    crowded.push_back({place_bits(p[0]), place_bits(p[1]), place_bits(p[2]), i});
  }
  std::sort(crowded.begin(), crowded.end());
  for (std::size_t a = 0, b; a < crowded.size(); a = b) {
    for (b = a + 1; b < crowded.size() && crowded[b].x == crowded[a].x && crowded[b].y == crowded[a].y &&
                    crowded[b].z == crowded[a].z;
         ++b) {
    }
    if (b - a <= bucket) continue;
    g.by_key.push_back({crowded[a].id, static_cast<std::uint32_t>(g.begin.size() - 1)});
    for (std::size_t q = a; q < b; ++q) g.members.push_back(crowded[q].id);
    g.begin.push_back(static_cast<std::uint32_t>(g.members.size()));
  }
  std::sort(g.by_key.begin(), g.by_key.end());
  return g;
}

/// The keys of a tree with groups: every point but the groups' other members.
std::vector<indexed_point> keys_of(const float* xyz, const std::uint32_t* order, std::size_t begin, std::size_t end,
                                   const coincident_groups& groups) {
  std::vector<std::uint32_t> others;
  for (std::uint32_t g = 0; g + 1 < groups.begin.size(); ++g)
    others.insert(others.end(), groups.first(g) + 1, groups.first(g) + groups.size(g));
  std::sort(others.begin(), others.end());
  std::vector<indexed_point> keys;
  keys.reserve(end - begin - others.size());
  const point_at at{xyz, order};
  for (std::size_t t = begin; t < end; ++t) {
    const indexed_point k = at(t);
    if (!std::binary_search(others.begin(), others.end(), k.id)) keys.push_back(k);
  }
  return keys;
}
}  // namespace

struct neighbor_index::impl {
  /// One tree over points order[begin..end), and their bounds.
  struct part {
    const float* points;  // the indexed array (a group's members are read from it)
    coincident_groups groups;
    tree_type tree;
    float lo[3], hi[3];
    /// The tree copies its points straight from the array, in the given
    /// order (a group of coincident points as one key).
    part(const float* xyz, const std::uint32_t* order, std::size_t begin, std::size_t end, unsigned bucket)
        : points(xyz),
          groups(find_groups(xyz, order, begin, end, bucket)),
          tree(boost::make_transform_iterator(boost::counting_iterator<std::size_t>(groups.empty() ? begin : end),
                                              point_at{xyz, order}),
               boost::make_transform_iterator(boost::counting_iterator<std::size_t>(end), point_at{xyz, order}),
               splitter(bucket), traits(point_of{})) {
      if (groups.empty()) return;
      const std::vector<indexed_point> keys = keys_of(xyz, order, begin, end, groups);
      tree.insert(keys.begin(), keys.end());
    }
    /// Appends key `k`'s point at `d2` to `out` and, when it stands for a
    /// group, its other members: at most `most` of them, the smallest ids,
    /// and `self` if it is one (the rest are never among the `most` nearest).
    void take(const indexed_point& k, float d2, std::size_t most, std::uint32_t self,
              std::vector<neighbor_index::ranked_point>& out) const {
      out.push_back({d2, k.id});
      if (!groups.empty()) take_group(k, d2, most, self, out);
    }
    [[gnu::noinline]] void take_group(const indexed_point& k, float d2, std::size_t most, std::uint32_t self,
                                      std::vector<neighbor_index::ranked_point>& out) const {
      const std::uint32_t g = groups.group_of_key(k.id);
      if (g == UINT32_MAX) return;
      const std::uint32_t* m = groups.first(g);
      const std::size_t n = groups.size(g), shown = std::min(n, most + 1);
      for (std::size_t q = 1; q < shown; ++q) out.push_back({d2, m[q]});
      if (self != UINT32_MAX && self != k.id && !std::binary_search(m, m + shown, self) &&
          std::binary_search(m, m + n, self))
        out.push_back({d2, self});
    }
    /// True when key `id` stands for a group (its other members too).
    bool stands_for_more(std::uint32_t id) const noexcept {
      return !groups.empty() && groups.group_of_key(id) != UINT32_MAX;
    }
    /// Calls out(id) for the point of key `k` and, when it stands for a
    /// group, for each of its other members.
    template <class Out>
    void expand(const indexed_point& k, Out&& out) const {
      out(k.id);
      if (groups.empty()) return;
      const std::uint32_t g = groups.group_of_key(k.id);
      if (g == UINT32_MAX) return;
      for (std::size_t q = 1; q < groups.size(g); ++q) out(groups.first(g)[q]);
    }
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

namespace {
/// Appends the ids of reported points (a group's every member) to a vector
/// (copy-assignable, as the output iterator needs).
struct append_id {
  std::vector<std::uint32_t>* out;
  const neighbor_index::impl::part* part;
  void operator()(const indexed_point& k) const {
    part->expand(k, [this](std::uint32_t id) { out->push_back(id); });
  }
};
/// Appends reported points with their positions.
struct append_located {
  std::vector<neighbor_index::located_point>* out;
  const neighbor_index::impl::part* part;
  void operator()(const indexed_point& k) const {
    part->expand(k, [&](std::uint32_t id) {
      // A group's other members at their own bits (-0 where the key has +0).
      const float* p = id == k.id ? nullptr : part->points + 3 * std::size_t(id);
      out->push_back(p ? neighbor_index::located_point{{p[0], p[1], p[2]}, id}
                       : neighbor_index::located_point{{k.p.x(), k.p.y(), k.p.z()}, id});
    });
  }
};
}  // namespace

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
    index_groups();
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
  index_groups();
}

void neighbor_index::index_groups() {
  // A group is the points of one tree at one place; the place may have
  // points in other trees too: the set is every point there, in any tree.
  std::vector<std::array<std::uint32_t, 3>> places;
  for (const auto& part : m_impl->parts)
    for (const auto& [key, g] : part->groups.by_key) {
      const float* p = m_xyz + 3 * std::size_t(key);
      places.push_back({place_bits(p[0]), place_bits(p[1]), place_bits(p[2])});
    }
  std::sort(places.begin(), places.end());
  places.erase(std::unique(places.begin(), places.end()), places.end());
  std::vector<std::uint32_t> ids;
  for (const auto& bits : places) {
    float p[3];
    for (int k = 0; k < 3; ++k) std::memcpy(&p[k], &bits[std::size_t(k)], sizeof p[k]);
    box_search(p, p, ids);
    std::sort(ids.begin(), ids.end());
    for (std::uint32_t id : ids) m_grouped.push_back({id, static_cast<std::uint32_t>(m_sets.size())});
    m_sets.push_back(ids);
  }
  std::sort(m_grouped.begin(), m_grouped.end());
}

bool neighbor_index::coincident_nearest_in_sets(std::uint32_t i, std::size_t k, ranked_point* out) const {
  if (k == 0) return false;
  const auto it = std::lower_bound(m_grouped.begin(), m_grouped.end(), std::make_pair(i, std::uint32_t(0)));
  if (it == m_grouped.end() || it->first != i) return false;
  const std::vector<std::uint32_t>& set = m_sets[it->second];
  if (set.size() < k) return false;
  out[0] = {0.0f, i};
  std::size_t n = 1;
  for (std::size_t m = 0; n < k; ++m)
    if (set[m] != i) out[n++] = {0.0f, set[m]};
  return true;
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
    const impl::part* part;
    void operator()(const indexed_point& k) const {
      const float q[3] = {k.p.x(), k.p.y(), k.p.z()};
      if (squared_distance(q, c) < r2) part->expand(k, [this](std::uint32_t id) { out->push_back(id); });
    }
  };
  const float qlo[3] = {c[0] - rq, c[1] - rq, c[2] - rq}, qhi[3] = {c[0] + rq, c[1] + rq, c[2] + rq};
  for (const auto& part : m_impl->parts) {
    if (!boxes_meet(qlo, qhi, part->lo, part->hi)) continue;
    auto sink = boost::make_function_output_iterator(strict_filter{c, r2, &out, part.get()});
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
  return parts[t]->tree.size() >= k ? t : SIZE_MAX;  // (k keys: at least k points)
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
      part->take(hit.first, squared_distance(q, c), ask, self, out);
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
    const impl::part* part;
    std::size_t k;
    std::uint32_t self;
    std::vector<ranked_point>* out;
    void operator()(const indexed_point& key) const {
      const float q[3] = {key.p.x(), key.p.y(), key.p.z()};
      const float d2 = squared_distance(q, c);
      if (d2 <= bound) part->take(key, d2, k, self, *out);
    }
  };
  for (const auto& part : m_impl->parts) {
    if (!boxes_meet(qlo, qhi, part->lo, part->hi)) continue;
    auto sink = boost::make_function_output_iterator(within_bound{c, bound, part.get(), k, self, &out});
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
      // (A group's key stands for two points or more: one of them is not i.)
      if (j != i || part->stands_for_more(j))
        best = std::min(best, std::sqrt(squared_distance(m_xyz + 3 * std::size_t(j), p)));
    }
  }
  return best;
}

float neighbor_index::nearest_distinct_distance(std::uint32_t i) const {
  if (i >= m_n) throw std::out_of_range("neighbor_index::nearest_distinct_distance: index out of range");
  const float* p = m_xyz + 3 * std::size_t(i);
  float best = std::numeric_limits<float>::infinity();
  // Keys at p's position: light duplicates (at most a bucket of them) and
  // one key a group, so a few doublings of k reach past them.
  for (const auto& part : m_impl->parts) {
    const std::size_t keys = part->tree.size();
    for (std::size_t k = 2;; k *= 2) {
      const knn search(part->tree, at(p), static_cast<unsigned>(std::min(k, keys)), 0.0f, true, distance(point_of{}));
      bool found = false;
      for (const auto& hit : search) {
        const float d2 = squared_distance(m_xyz + 3 * std::size_t(hit.first.id), p);
        if (d2 > 0) best = std::min(best, std::sqrt(d2)), found = true;
      }
      if (found || k >= keys) break;
    }
  }
  return best;
}

void neighbor_index::box_search(const float lo[3], const float hi[3], std::vector<std::uint32_t>& out) const {
  out.clear();
  for (const auto& part : m_impl->parts)
    if (boxes_meet(lo, hi, part->lo, part->hi))
      part->tree.search(boost::make_function_output_iterator(append_id{&out, part.get()}),
                        iso_box(at(lo), at(hi), 0.0f, part->tree.traits()));
}

void neighbor_index::box_search(const float lo[3], const float hi[3], std::vector<located_point>& out) const {
  out.clear();
  for (const auto& part : m_impl->parts)
    if (boxes_meet(lo, hi, part->lo, part->hi))
      part->tree.search(boost::make_function_output_iterator(append_located{&out, part.get()}),
                        iso_box(at(lo), at(hi), 0.0f, part->tree.traits()));
}

}  // namespace ced
