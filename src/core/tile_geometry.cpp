// SPDX-License-Identifier: MIT
// Exact tiles (see ced/tile_geometry.hpp for why they are exact).
#include "ced/tile_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "ced/channels.hpp"
#include "ced/scaled.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "core/ranking.hpp"
#include "core/text.hpp"

namespace ced {

namespace {
/// The cell of coordinate x on a grid axis (corner lo, cells of `size`, the
/// last at `last`) as a double: the floor of (x − lo) / size, 0 below (and
/// for NaN), the last cell above. Without a branch (the batch functions'
/// loops have none).
inline __attribute__((always_inline)) double cell_value(double x, double lo, double size, double last) noexcept {
  const double c = std::floor((x - lo) / size);
  return std::min(c > 0 ? c : 0.0, last);
}
std::int64_t cell_index(double x, double lo, double size, std::uint32_t dims) noexcept {
  return static_cast<std::int64_t>(cell_value(x, lo, size, double(dims - 1)));
}

/// How far beyond a core the points that its keypoints depend on through the
/// NMS can lie: the NMS radius (under nms=own, nms_radius × the largest own
/// radius `largest_own` / radius), twice with refinement. exact_halo() sizes
/// the halo with it and check_tile_reach() checks the points within it.
double nms_term(const detect_params& params, double largest_own) noexcept {
  const double nms =
      params.neighborhood.nms_own ? params.nms_radius * std::max(1.0, largest_own / params.radius) : params.nms_radius;
  return (params.refine ? 2 : 1) * nms;
}
}  // namespace

std::array<std::uint32_t, 3> tile_grid::coords(std::uint64_t t) const noexcept {
  return {static_cast<std::uint32_t>(t % dims[0]), static_cast<std::uint32_t>(t / dims[0] % dims[1]),
          static_cast<std::uint32_t>(t / dims[0] / dims[1])};
}

void tile_grid::locate(const float p[3], std::int64_t own[3], std::int64_t c0[3], std::int64_t c1[3]) const noexcept {
  for (std::size_t k = 0; k < 3; ++k) {
    own[k] = cell_index(double(p[k]), lo[k], size, dims[k]);
    c0[k] = cell_index(double(p[k]) - halo, lo[k], size, dims[k]);
    c1[k] = cell_index(double(p[k]) + halo, lo[k], size, dims[k]);
  }
}

namespace {
/// locate_many's body: cell_index's double operations, branch-free. (GCC
/// packs the stores into vectors; the divisions stay scalar.)
inline __attribute__((always_inline)) void locate_points(const tile_grid& g, const float* xyz, std::size_t n,
                                                         std::int32_t* cells) noexcept {
  const double s = g.size, h = g.halo;
  const double low[3] = {g.lo[0], g.lo[1], g.lo[2]};
  const double last[3] = {double(g.dims[0] - 1), double(g.dims[1] - 1), double(g.dims[2] - 1)};
  for (std::size_t i = 0; i < n; ++i) {
    bool finite = true;
    std::int32_t* out = cells + 9 * i;
    for (std::size_t k = 0; k < 3; ++k) {
      const float f = xyz[3 * i + k];
      finite = finite & (std::fabs(f) <= std::numeric_limits<float>::max());
      const double p = double(f);
      auto cell = [&](double x) { return static_cast<std::int32_t>(cell_value(x, low[k], s, last[k])); };
      out[k] = cell(p);
      out[3 + k] = cell(p - h);
      out[6 + k] = cell(p + h);
    }
    if (!finite) out[3] = -1;
  }
}
/// tile_of_many's body.
inline __attribute__((always_inline)) void tile_points(const tile_grid& g, const float* xyz, std::size_t n,
                                                       std::uint64_t* out) noexcept {
  const double s = g.size;
  const double low[3] = {g.lo[0], g.lo[1], g.lo[2]};
  const double last[3] = {double(g.dims[0] - 1), double(g.dims[1] - 1), double(g.dims[2] - 1)};
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t c[3];
    for (std::size_t k = 0; k < 3; ++k)  // (below 2^24: through int32)
      c[k] =
          static_cast<std::uint32_t>(static_cast<std::int32_t>(cell_value(double(xyz[3 * i + k]), low[k], s, last[k])));
    out[i] = g.tile_id(c[0], c[1], c[2]);
  }
}

// Each body built for AVX-512 and AVX2 too, and chosen at run time on each
// call (target_clones' ifunc resolvers would run before ThreadSanitizer is
// set up).
#if defined(__x86_64__) && defined(__GNUC__)
/// The batch functions' outputs for points i to i + w of a vector pass:
/// `cell` holds each one's nine (locate) or three (tile_of) cells, lane by
/// lane; bit j of `finite` says whether point i + j is finite.
template <class Out, std::size_t W>
inline __attribute__((always_inline)) void put_cells(const tile_grid& g, const std::int32_t (&cell)[9][W],
                                                     unsigned finite, std::size_t i, Out* out) noexcept {
  for (std::size_t j = 0; j < W; ++j) {
    if constexpr (std::is_same_v<Out, std::int32_t>) {
      std::int32_t* o = out + 9 * (i + j);
      for (std::size_t m = 0; m < 9; ++m) o[m] = cell[m][j];
      if (!((finite >> j) & 1)) o[3] = -1;
    } else {
      out[i + j] = g.tile_id(std::uint32_t(cell[0][j]), std::uint32_t(cell[1][j]), std::uint32_t(cell[2][j]));
    }
  }
}

// The bodies in vectors, eight points at a time on AVX-512, four on AVX2:
// cell_value's double operations (the same roundings: a division is exact
// in any width; VMAXPD gives its second operand, 0, for NaN and −0), the
// points left over by the body. GCC 12's AVX-512 intrinsics warn of their
// own undefined operand (GCC bug 105593), as in the kernel's AVX-512 build.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
__attribute__((target("avx512f,avx512vl"), always_inline)) inline __m256i cells_avx512(__m512d x, __m512d low,
                                                                                       __m512d size, __m512d last) {
  const __m512d c =
      _mm512_roundscale_pd(_mm512_div_pd(_mm512_sub_pd(x, low), size), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  return _mm512_cvttpd_epi32(_mm512_min_pd(_mm512_max_pd(c, _mm512_setzero_pd()), last));
}
template <auto Body, class Out>
__attribute__((target("avx512f,avx512vl"))) void on_avx512(const tile_grid& g, const float* xyz, std::size_t n,
                                                           Out* out) noexcept {
  constexpr bool locate = std::is_same_v<Out, std::int32_t>;
  const __m512d s = _mm512_set1_pd(g.size), h = _mm512_set1_pd(g.halo);
  // x, y and z of 8 points: every third of their 24 floats, from two loads.
  const __m512i every3[3] = {_mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 0, 0, 0, 0, 0, 0, 0, 0),
                             _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 0, 0, 0, 0, 0, 0, 0, 0),
                             _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 0, 0, 0, 0, 0, 0, 0, 0)};
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 largest = _mm256_set1_ps(std::numeric_limits<float>::max());
  alignas(32) std::int32_t cell[9][8];
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    unsigned finite = 0xff;
    const __m512 first = _mm512_loadu_ps(xyz + 3 * i), rest = _mm512_maskz_loadu_ps(0xff, xyz + 3 * i + 16);
    for (int k = 0; k < 3; ++k) {
      const __m256 f = _mm512_castps512_ps256(_mm512_permutex2var_ps(first, every3[k], rest));
      finite &= _mm256_cmp_ps_mask(_mm256_and_ps(f, abs_mask), largest, _CMP_LE_OQ);
      const __m512d p = _mm512_cvtps_pd(f), low = _mm512_set1_pd(g.lo[k]);
      const __m512d last = _mm512_set1_pd(double(g.dims[k] - 1));
      _mm256_store_si256(reinterpret_cast<__m256i*>(cell[k]), cells_avx512(p, low, s, last));
      if constexpr (locate) {
        _mm256_store_si256(reinterpret_cast<__m256i*>(cell[3 + k]), cells_avx512(_mm512_sub_pd(p, h), low, s, last));
        _mm256_store_si256(reinterpret_cast<__m256i*>(cell[6 + k]), cells_avx512(_mm512_add_pd(p, h), low, s, last));
      }
    }
    put_cells(g, cell, finite, i, out);
  }
  Body(g, xyz + 3 * i, n - i, out + (locate ? 9 : 1) * i);
}
#pragma GCC diagnostic pop
__attribute__((target("avx2"), always_inline)) inline __m128i cells_avx2(__m256d x, __m256d low, __m256d size,
                                                                         __m256d last) {
  const __m256d c =
      _mm256_round_pd(_mm256_div_pd(_mm256_sub_pd(x, low), size), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  return _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(c, _mm256_setzero_pd()), last));
}
template <auto Body, class Out>
__attribute__((target("avx2"))) void on_avx2(const tile_grid& g, const float* xyz, std::size_t n, Out* out) noexcept {
  constexpr bool locate = std::is_same_v<Out, std::int32_t>;
  const __m256d s = _mm256_set1_pd(g.size), h = _mm256_set1_pd(g.halo);
  // x, y and z of 4 points: every third of their 12 floats, 8 + 4 loaded.
  const __m256i from8[3] = {_mm256_setr_epi32(0, 3, 6, 0, 0, 0, 0, 0), _mm256_setr_epi32(1, 4, 7, 0, 0, 0, 0, 0),
                            _mm256_setr_epi32(2, 5, 0, 0, 0, 0, 0, 0)};
  const __m128i from4[3] = {_mm_setr_epi32(0, 0, 0, 1), _mm_setr_epi32(0, 0, 0, 2), _mm_setr_epi32(0, 0, 0, 3)};
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  const __m128 largest = _mm_set1_ps(std::numeric_limits<float>::max());
  alignas(16) std::int32_t cell[9][4];
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    unsigned finite = 0xf;
    const __m256 first = _mm256_loadu_ps(xyz + 3 * i);
    const __m128 rest = _mm_loadu_ps(xyz + 3 * i + 8);
    for (int k = 0; k < 3; ++k) {
      const __m128 a = _mm256_castps256_ps128(_mm256_permutevar8x32_ps(first, from8[k]));
      const __m128 b = _mm_permutevar_ps(rest, from4[k]);
      const __m128 f = k == 2 ? _mm_blend_ps(a, b, 0xc) : _mm_blend_ps(a, b, 0x8);
      finite &= unsigned(_mm_movemask_ps(_mm_cmp_ps(_mm_and_ps(f, abs_mask), largest, _CMP_LE_OQ)));
      const __m256d p = _mm256_cvtps_pd(f), low = _mm256_set1_pd(g.lo[k]);
      const __m256d last = _mm256_set1_pd(double(g.dims[k] - 1));
      _mm_store_si128(reinterpret_cast<__m128i*>(cell[k]), cells_avx2(p, low, s, last));
      if constexpr (locate) {
        _mm_store_si128(reinterpret_cast<__m128i*>(cell[3 + k]), cells_avx2(_mm256_sub_pd(p, h), low, s, last));
        _mm_store_si128(reinterpret_cast<__m128i*>(cell[6 + k]), cells_avx2(_mm256_add_pd(p, h), low, s, last));
      }
    }
    put_cells(g, cell, finite, i, out);
  }
  Body(g, xyz + 3 * i, n - i, out + (locate ? 9 : 1) * i);
}
#endif
/// The build of the neighbour pass's choice (detail::kernel_isa(), which
/// tests may force), at each call.
template <auto Body, class Out>
void on_best(const tile_grid& g, const float* xyz, std::size_t n, Out* out) noexcept {
#if defined(__x86_64__) && defined(__GNUC__)
  const std::string_view isa = detail::kernel_isa();
  if (isa == "avx512") return on_avx512<Body>(g, xyz, n, out);
  if (isa == "avx2") return on_avx2<Body>(g, xyz, n, out);
#endif
  Body(g, xyz, n, out);
}
}  // namespace

void tile_grid::locate_many(const float* xyz, std::size_t n, std::int32_t* cells) const noexcept {
  on_best<locate_points>(*this, xyz, n, cells);
}

void tile_grid::tile_of_many(const float* xyz, std::size_t n, std::uint64_t* out) const noexcept {
  on_best<tile_points>(*this, xyz, n, out);
}

std::uint64_t tile_grid::tile_of(const float p[3]) const noexcept {
  std::uint64_t c[3];
  for (int k = 0; k < 3; ++k)
    c[k] = std::uint64_t(cell_index(double(p[k]), lo[std::size_t(k)], size, dims[std::size_t(k)]));
  return tile_id(c[0], c[1], c[2]);
}

void tile_grid::tiles_near(const float p[3], std::vector<std::uint64_t>& out) const {
  out.clear();
  std::int64_t own[3], c0[3], c1[3];
  locate(p, own, c0, c1);
  for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
    for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
      for (std::int64_t x = c0[0]; x <= c1[0]; ++x)
        out.push_back(tile_id(std::uint64_t(x), std::uint64_t(y), std::uint64_t(z)));
}

std::array<double, 6> tile_grid::core_box(std::uint64_t t) const noexcept {
  const auto c = coords(t);
  std::array<double, 6> b{};
  for (std::size_t k = 0; k < 3; ++k) {
    b[k] = lo[k] + double(c[k]) * size;
    b[k + 3] = lo[k] + double(c[k] + 1) * size;
  }
  return b;
}

double exact_halo(const detect_params& params, double max_abs_coordinate) {
  validate(params);
  // nms_radius: the competitors of a core point; block side: every point of
  // their blocks (the blocks fix the order of the sums); radius (with the
  // 1.001 pad of a block's box): what those blocks gather. 1% more, and some
  // float steps of the largest coordinate, for rounding.
  // With refinement a core keypoint may come from a maximum up to nms_radius
  // outside the core, whose own competitors lie nms_radius further.
  // Under adaptive:K,max=r1 a neighbourhood reaches r1, and the K nearest
  // that set a radius below r1 lie within r1 / scale (farther ones clamp it
  // to r1 whatever the tile holds). knn, and adaptive without max, reach as
  // far as the data make them: their reach= bounds it, and each tile checks
  // that bound (check_tile_reach).
  const neighborhood_spec& n = params.neighborhood;
  double reach = params.radius, largest_own = params.radius;  // how far neighbourhoods reach; the largest r_i
  if (n.kind == neighborhood_kind::adaptive && std::isfinite(n.max_radius)) {
    reach = std::max(n.max_radius, n.max_radius / n.scale);
    largest_own = n.max_radius;
  } else if (!n.fixed() && std::isfinite(n.reach)) {
    reach = largest_own = n.reach;
  } else if (!n.fixed()) {
    throw std::invalid_argument("tiles need a neighbourhood of bounded reach: " + to_string(n) +
                                " reaches as far as the data make it (give it reach=R, a bound that each tile "
                                "checks, or use adaptive:K with max=; ced info --knn prints the k-distances)");
  }
  const double h = nms_term(params, largest_own) + params.block_scale * params.radius + 1.001 * reach;
  return 1.01 * h + 16.0 * std::ldexp(std::fabs(max_abs_coordinate), -23);
}

tile_grid make_tile_grid(const double lo[3], const double hi[3], double size, const detect_params& params) {
  if (!(size > 0) || !std::isfinite(size))
    throw std::invalid_argument("tile size must be a positive number, got " + detail::number_text(size));
  tile_grid g;
  g.size = size;
  double max_abs = 0;
  long double total = 1;
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(lo[k]) || !std::isfinite(hi[k]) || hi[k] < lo[k])
      throw std::invalid_argument("tile grid: the bounding box is not finite");
    g.lo[k] = lo[k];
    const double n = std::max(1.0, std::ceil((hi[k] - lo[k]) / size));
    total *= static_cast<long double>(n);
    if (total > static_cast<long double>(1u << 24))
      throw std::invalid_argument("tile size " + detail::number_text(size) +
                                  " is too small for the cloud: more than 2^24 tiles (16,777,216)");
    g.dims[k] = static_cast<std::uint32_t>(n);
    max_abs = std::max({max_abs, std::fabs(lo[k]), std::fabs(hi[k])});
  }
  g.halo = exact_halo(params, max_abs);
  return g;
}

std::vector<value_range> field_ranges(const point_cloud& cloud) {
  std::vector<value_range> out;
  for (const field& f : cloud.fields()) {
    value_range r{0.0, 0.0};
    if (!f.values.empty()) {
      r.lo = r.hi = f.values[0];
      f.values.visit([&](const auto* p, std::size_t n) {
        for (std::size_t i = 0; i < n; ++i) {
          const double v = static_cast<double>(p[i]);
          r.lo = std::min(r.lo, v);
          r.hi = std::max(r.hi, v);
        }
      });
    }
    out.push_back(r);
  }
  return out;
}

namespace {
using field_samples = std::vector<std::shared_ptr<const std::vector<double>>>;

/// Every field's sample (field_sample()), what a tile's fields carry as
/// whole_sample for range=zscore, percentiles and pca=.
field_samples samples_of(const point_cloud& cloud) {
  field_samples out;
  for (const field& f : cloud.fields()) out.push_back(std::make_shared<const std::vector<double>>(field_sample(f)));
  return out;
}

/// The tile of `cloud` made of the points `index` (ascending).
cloud_tile make_tile(const point_cloud& cloud, std::vector<std::uint32_t> index, const std::vector<value_range>& whole,
                     const field_samples& samples) {
  cloud_tile out;
  out.index = std::move(index);
  out.cloud.set_origin(cloud.origin());
  out.cloud.reserve(out.index.size());
  for (std::uint32_t i : out.index) {
    const float* p = cloud.position(i);
    out.cloud.push_back(p[0], p[1], p[2]);
  }
  for (std::size_t f = 0; f < cloud.fields().size(); ++f) {
    const field& src = cloud.fields()[f];
    const std::size_t w = size_of(src.type());
    column values(src.type(), out.index.size());
    for (std::size_t j = 0; j < out.index.size(); ++j)
      std::copy_n(src.values.bytes() + w * out.index[j], w, values.bytes() + w * j);
    field& added = out.cloud.add_field(src.name, std::move(values));
    added.whole_range = whole[f];
    added.whole_sample = samples[f];
  }
  return out;
}
}  // namespace

cloud_tile extract_tile(const point_cloud& cloud, const tile_grid& grid, std::uint64_t t,
                        const std::vector<value_range>& ranges) {
  if (t >= grid.count()) throw std::invalid_argument("tile " + std::to_string(t) + " is not in the grid");
  const std::vector<value_range> whole = ranges.empty() ? field_ranges(cloud) : ranges;
  if (whole.size() != cloud.fields().size()) throw std::invalid_argument("extract_tile: one range per field expected");
  std::vector<std::uint32_t> index;
  std::vector<std::uint64_t> near;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    grid.tiles_near(cloud.position(i), near);
    if (std::find(near.begin(), near.end(), t) != near.end()) index.push_back(static_cast<std::uint32_t>(i));
  }
  return make_tile(cloud, std::move(index), whole, samples_of(cloud));
}

std::vector<std::uint32_t> core_keypoints(const tile_grid& grid, std::uint64_t t, const point_cloud& tile_cloud,
                                          const detection_result& result) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t k : result.keypoints)
    if (grid.tile_of(tile_cloud.position(k)) == t) out.push_back(k);
  return out;
}

bool unbounded_reach(const neighborhood_spec& n) noexcept {
  return !n.fixed() && !std::isfinite(n.reach) &&
         !(n.kind == neighborhood_kind::adaptive && std::isfinite(n.max_radius));
}

namespace {
/// x rounded up to two significant digits (x > 0, finite).
double round_up_2(double x) noexcept {
  const int e = static_cast<int>(std::floor(std::log10(x))) - 1;
  const double unit = std::pow(10.0, std::abs(e));
  auto at = [&](double m) { return e < 0 ? m / unit : m * unit; };
  double m = std::ceil(e < 0 ? x * unit : x / unit);
  while (at(m) < x) ++m;
  return at(m);
}
}  // namespace

double estimated_reach(const detect_params& params, const double lo[3], const double hi[3], std::uint64_t points) {
  const neighborhood_spec& n = params.neighborhood;
  double e[3];
  for (int k = 0; k < 3; ++k) e[k] = std::isfinite(hi[k] - lo[k]) ? std::max(hi[k] - lo[k], 0.0) : 0.0;
  std::sort(e, e + 3);
  const double k = std::max<double>(n.k, 1), count = std::max<double>(double(points), 1);
  double d = params.radius;  // one point, or all at one place
  if (e[1] > 0)
    d = std::sqrt(k * e[1] * e[2] / (3.141592653589793 * count));  // a surface the size of the largest face
  else if (e[2] > 0)
    d = k * e[2] / (2 * count);  // a line
  d *= 3;                        // density falls with range, and at an edge the K nearest fill half a disc
  if (n.kind == neighborhood_kind::adaptive) {
    const double r = std::max(n.scale * d, n.min_radius);
    d = std::max(r, r / n.scale);
  }
  return round_up_2(std::max(d, 1e-9));
}

double grown_reach(double tried, double needed, bool unmeasured) noexcept {
  const double measured = std::isfinite(needed) && needed > tried ? round_up_2(needed) : 0.0;
  return unmeasured || measured == 0.0 ? std::max(measured, 4 * tried) : measured;
}

bool tiles_check_reach(const detect_params& params) noexcept {
  const neighborhood_spec& n = params.neighborhood;
  return !n.fixed() && std::isfinite(n.reach) &&
         !(n.kind == neighborhood_kind::adaptive && std::isfinite(n.max_radius));
}

namespace {
/// How far a point of radius r (result::point_radius) reaches under `n`:
/// knn's r_i is its K-th distance; adaptive's r_i = max(α·d_K, r0) ≥ α·d_K.
double reach_of(double r, const neighborhood_spec& n) noexcept {
  return n.kind == neighborhood_kind::knn ? r : std::max(r, r / n.scale);
}

/// The farthest any point of tile t's core reaches among the tile's points
/// (tile_reach_error::needed); +infinity without a detection.
double core_needs(const tile_grid& grid, std::uint64_t t, const point_cloud& c, const detection_result* result,
                  const neighborhood_spec& n) {
  if (!result) return std::numeric_limits<double>::infinity();
  double far = 0;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (grid.tile_of(c.position(i)) == t) far = std::max(far, reach_of(result->point_radius[i], n));
  return far;
}

[[noreturn]] void reach_exceeded(const tile_grid& grid, std::uint64_t t, const float* p, const point_cloud& c,
                                 const detection_result* result, double needed, const neighborhood_spec& n) {
  char where[160];
  if (p)
    std::snprintf(where, sizeof where, "the point at (%.9g, %.9g, %.9g) reaches %.6g", c.origin()[0] + p[0],
                  c.origin()[1] + p[1], c.origin()[2] + p[2], needed);
  else
    std::snprintf(where, sizeof where, "it holds fewer than K = %u points", unsigned(n.k));
  const double core = core_needs(grid, t, c, result, n);
  char need[48] = "";
  if (std::isfinite(core))
    std::snprintf(need, sizeof need, "this tile's points need %.3g; ", grown_reach(0, std::max(core, needed)));
  throw tile_reach_error("tile " + std::to_string(t) + ": " + where + ", beyond the neighbourhood's reach (" +
                             to_string(n) + "): the tiles would not be exact. Give a larger reach= (" + need +
                             "ced info --knn prints the k-distances), or use adaptive:K with max= (without reach=, "
                             "ced detect --tile-size finds a reach itself)",
                         core);
}
}  // namespace

void check_tile_reach(const tile_grid& grid, std::uint64_t t, const point_cloud& tile_cloud,
                      const detection_result* result, const detect_params& params, double extra) {
  if (!tiles_check_reach(params)) return;
  const neighborhood_spec& n = params.neighborhood;
  if (!result) {
    if (tile_cloud.size() < n.k) reach_exceeded(grid, t, nullptr, tile_cloud, nullptr, 0, n);
    return;
  }
  // The points the core depends on: within the NMS term of exact_halo().
  const double inner = nms_term(params, n.reach) + extra;
  const auto box = grid.core_box(t);
  for (std::size_t i = 0; i < tile_cloud.size(); ++i) {
    const float* p = tile_cloud.position(i);
    double gap2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double e = std::max({box[a] - p[a], 0.0, p[a] - box[a + 3]});
      gap2 += e * e;
    }
    if (gap2 > inner * inner * 1.0001) continue;
    const double needed = reach_of(result->point_radius[i], n);
    if (needed > n.reach) reach_exceeded(grid, t, p, tile_cloud, result, needed, n);
  }
}

namespace {
/// Keypoints of tiles: every keypoint of their cores (ascending within a tile).
struct tiled_keypoints {
  std::vector<std::uint32_t> index;  ///< into the whole cloud
  std::vector<float> rank;           ///< detection_result::rank_score
  std::uint64_t candidates = 0;      ///< candidate points of the cores
};
/// The keypoints of the tiles that passed an earlier try (an exact tile's
/// are the same under any longer reach), by tile, and that try's grid.
struct passed_tiles {
  std::optional<tile_grid> grid;
  std::map<std::uint64_t, tiled_keypoints> keypoints;
};

/// A tile's keypoints in its core, with their ranks and the core's candidates.
tiled_keypoints core_of(const tile_grid& grid, std::uint64_t t, const cloud_tile& tile, const detection_result& r) {
  tiled_keypoints kept;
  for (std::size_t i = 0; i < tile.cloud.size(); ++i)
    kept.candidates += r.candidate[i] != 0 && grid.tile_of(tile.cloud.position(i)) == t;
  const std::vector<std::uint32_t> core = core_keypoints(grid, t, tile.cloud, r);
  for (std::uint32_t k : core) kept.index.push_back(tile.index[k]);
  kept.rank = detail::ranks_of(r.keypoints, r.rank_score, core);
  return kept;
}

/// detect_tiled() at one reach. With `grow` (the reach is ced's own), a tile
/// that finds it too short does not stop the others: `shortfall` gathers how
/// far every such tile's core reaches, and there is no result; `passed`
/// keeps the keypoints of the tiles that passed, for the next try.
std::optional<tiled_keypoints> tiles_at(const point_cloud& cloud, const detect_params& params,
                                        const std::vector<any_modality>& modalities, double tile_size,
                                        const double lo[3], const double hi[3], bool grow, reach_shortfall& shortfall,
                                        passed_tiles& passed) {
  // A modality at a larger scale (scale=) reads farther: the halo grows with it.
  const tile_grid grid = make_tile_grid(lo, hi, tile_size, tile_halo_params(params, modalities));
  if (!passed.grid || !passed.grid->same_cores(grid)) passed.keypoints.clear();
  passed.grid = grid;
  const double check_extra = tile_check_extra(params, modalities);
  const std::vector<value_range> ranges = field_ranges(cloud);
  const field_samples samples = samples_of(cloud);
  // Each tile's points, and which tiles own a point: only those are detected.
  std::vector<std::vector<std::uint32_t>> members(grid.count());
  std::vector<std::uint8_t> owns(grid.count(), 0);
  std::vector<std::uint64_t> near;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    owns[grid.tile_of(cloud.position(i))] = 1;
    grid.tiles_near(cloud.position(i), near);
    for (std::uint64_t t : near) members[t].push_back(static_cast<std::uint32_t>(i));
  }
  // Every keypoint of each core: the limits apply to all tiles' at the end.
  detect_params per_tile = params;
  per_tile.max_keypoints = 0;
  per_tile.keypoint_share = 0;
  tiled_keypoints out;  // in tile order; strongest() sorts
  for (std::uint64_t t = 0; t < grid.count(); ++t) {
    if (!owns[t]) continue;
    auto done = passed.keypoints.find(t);
    if (done == passed.keypoints.end()) {
      const cloud_tile tile = make_tile(cloud, std::move(members[t]), ranges, samples);
      try {
        check_tile_reach(grid, t, tile.cloud, nullptr, per_tile);
        const detection_result r = detect(tile.cloud, per_tile, modalities);
        check_tile_reach(grid, t, tile.cloud, &r, per_tile, check_extra);
        done = passed.keypoints.emplace(t, core_of(grid, t, tile, r)).first;
      } catch (const tile_reach_error& e) {
        if (!grow) throw;
        shortfall.add(e);
        continue;
      }
    }
    const tiled_keypoints& kept = done->second;
    out.index.insert(out.index.end(), kept.index.begin(), kept.index.end());
    out.rank.insert(out.rank.end(), kept.rank.begin(), kept.rank.end());
    out.candidates += kept.candidates;
  }
  if (shortfall.any) return std::nullopt;
  return out;
}
}  // namespace

std::vector<std::uint32_t> detect_tiled(const point_cloud& cloud, const detect_params& params,
                                        const std::vector<any_modality>& modalities, double tile_size,
                                        double* reach_used) {
  validate(params);
  if (cloud.empty()) throw std::invalid_argument("detect_tiled: the cloud is empty");
  double lo[3], hi[3];
  for (std::size_t k = 0; k < 3; ++k) lo[k] = hi[k] = cloud.position(0)[k];
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(cloud.position(i)[k]));
      hi[k] = std::max(hi[k], double(cloud.position(i)[k]));
    }
  detect_params p = params;
  const bool grow = unbounded_reach(p.neighborhood);
  if (grow) {
    if (cloud.size() < p.neighborhood.k)
      throw std::invalid_argument("neighbourhood " + to_string(p.neighborhood) + ": K is larger than the cloud (" +
                                  std::to_string(cloud.size()) + " points)");
    p.neighborhood.reach = estimated_reach(p, lo, hi, cloud.size());
  }
  // Each try that finds the reach short measures how far the tiles' points
  // reach (at least how far they do in the whole cloud): the next passes,
  // and detects only the tiles that did not.
  // Only a tile of fewer than K points measures nothing; its reach grows
  // fourfold, until the halo holds the whole cloud.
  passed_tiles passed;
  for (;;) {
    reach_shortfall shortfall;
    if (auto out = tiles_at(cloud, p, modalities, tile_size, lo, hi, grow, shortfall, passed)) {
      if (reach_used) *reach_used = p.neighborhood.reach;
      // max_keypoints, keypoint_share: the strongest of all tiles' (the share of all cores' candidates);
      // ascending by index, as strongest() returns them.
      return strongest(out->index, out->rank, keypoint_limit(params, out->candidates));
    }
    p.neighborhood.reach = grown_reach(p.neighborhood.reach, shortfall.needed, shortfall.unmeasured);
  }
}

}  // namespace ced
