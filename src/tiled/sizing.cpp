// SPDX-License-Identifier: MIT
// Tiled runs: the tile size for a memory limit. A pass over the input counts
// the points of small cells (a histogram, summed so that any box of cells
// counts at once); a search then finds the largest tiles whose densest one,
// halo included, fits the limit.
#include "tiled/sizing.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "tiled/chunks.hpp"
#include "tiled/modalities.hpp"
#include "tiled/records.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// Estimated bytes a tile of n points takes while it is detected: its cache
/// records, its cloud, the detection (about 100 bytes a point for ced6d on
/// dense clouds, with the block partition's sorted positions: docs/RESULTS.md#memory),
/// and its keypoints.
double tile_bytes_per_point(const tile_plan& p) {
  return 2.0 * double(record_size(p)) + 112.0 + 8.0 * double(p.fields.size());
}
constexpr double fixed_overhead = 200.0 * (1 << 20);  // chunks, cache buffers, the program

/// Points per cell of a grid over the bounds [lo, hi], summed: the points of
/// any box of cells at once.
class point_histogram {
 public:
  /// Cells of `cell` or more (at most 2^22 of them), no points yet.
  point_histogram(double cell, const double lo[3], const double hi[3]) : m_cell(cell), m_lo(lo) {
    for (;;) {
      long double total = 1;
      for (int k = 0; k < 3; ++k) {
        m_dims[k] = std::uint64_t(std::floor((hi[k] - lo[k]) / m_cell)) + 1;
        total *= m_dims[k];
      }
      if (total <= (1 << 22)) break;
      m_cell *= 1.25;
    }
  }

  /// The histogram step: counts the finite points of `s` (a pass), then sums them.
  void count(io::point_stream& s, const tile_plan& p, const tiled_progress& progress) {
    std::vector<std::uint64_t> hist(m_dims[0] * m_dims[1] * m_dims[2], 0);
    s.rewind();
    std::uint64_t done = 0;
    for_each_chunk(s, p.origin, [&](const point_cloud& c) {
      for (std::size_t i = 0; i < c.size(); ++i) {
        const float* q = c.position(i);
        if (!finite3(q)) continue;
        std::uint64_t a[3];
        for (int k = 0; k < 3; ++k) {
          const double v = std::floor((double(q[k]) - m_lo[k]) / m_cell);
          a[k] = std::uint64_t(std::min(std::max(v, 0.0), double(m_dims[k] - 1)));
        }
        ++hist[(a[2] * m_dims[1] + a[1]) * m_dims[0] + a[0]];
      }
      done += c.size();
      if (progress)
        progress("counting points per area", double(done) / double(std::max<std::uint64_t>(1, p.file_points)));
    });
    sum(hist);
  }

  double cell() const noexcept { return m_cell; }
  std::uint64_t dims(int k) const noexcept { return m_dims[k]; }

  /// The points of cells [a, b).
  std::uint64_t box(const std::uint64_t a[3], const std::uint64_t b[3]) const {
    return at(b[0], b[1], b[2]) - at(a[0], b[1], b[2]) - at(b[0], a[1], b[2]) - at(b[0], b[1], a[2]) +
           at(a[0], a[1], b[2]) + at(a[0], b[1], a[2]) + at(b[0], a[1], a[2]) - at(a[0], a[1], a[2]);
  }

 private:
  /// The summed-volume table of `hist`.
  void sum(const std::vector<std::uint64_t>& hist) {
    const std::uint64_t X = m_dims[0] + 1, Y = m_dims[1] + 1, Z = m_dims[2] + 1;
    m_sum.assign(X * Y * Z, 0);
    for (std::uint64_t z = 1; z < Z; ++z)
      for (std::uint64_t y = 1; y < Y; ++y)
        for (std::uint64_t x = 1; x < X; ++x)
          at(x, y, z) = hist[((z - 1) * m_dims[1] + (y - 1)) * m_dims[0] + (x - 1)] + at(x - 1, y, z) +
                        at(x, y - 1, z) + at(x, y, z - 1) - at(x - 1, y - 1, z) - at(x - 1, y, z - 1) -
                        at(x, y - 1, z - 1) + at(x - 1, y - 1, z - 1);
  }
  std::uint64_t& at(std::uint64_t x, std::uint64_t y, std::uint64_t z) {
    return m_sum[(z * (m_dims[1] + 1) + y) * (m_dims[0] + 1) + x];
  }
  std::uint64_t at(std::uint64_t x, std::uint64_t y, std::uint64_t z) const {
    return m_sum[(z * (m_dims[1] + 1) + y) * (m_dims[0] + 1) + x];
  }

  double m_cell;
  const double* m_lo;
  std::uint64_t m_dims[3];
  std::vector<std::uint64_t> m_sum;
};

/// The search step: tile sizes against the histogram.
struct tile_size_search {
  const point_histogram& hist;
  const double* lo;
  const double* hi;
  double halo;

  /// The most points a tile of size `size` reads (cells the box grown by the halo meets).
  double densest(double size) const {
    const double cell = hist.cell();
    std::uint64_t n[3];
    for (int k = 0; k < 3; ++k) n[k] = std::uint64_t(std::max(1.0, std::ceil((hi[k] - lo[k]) / size)));
    std::uint64_t worst = 0;
    for (std::uint64_t tz = 0; tz < n[2]; ++tz)
      for (std::uint64_t ty = 0; ty < n[1]; ++ty)
        for (std::uint64_t tx = 0; tx < n[0]; ++tx) {
          const std::uint64_t t[3] = {tx, ty, tz};
          std::uint64_t a[3], b[3];
          for (int k = 0; k < 3; ++k) {
            const double x0 = double(t[k]) * size - halo, x1 = double(t[k] + 1) * size + halo;
            const double dims = double(hist.dims(k));
            a[k] = std::uint64_t(std::min(std::max(std::floor(x0 / cell), 0.0), dims));
            b[k] = std::uint64_t(std::min(std::max(std::floor(x1 / cell) + 1, 0.0), dims));
            if (t[k] + 1 == n[k]) b[k] = hist.dims(k);
          }
          worst = std::max(worst, hist.box(a, b));
        }
    return double(worst);
  }

  /// The largest size whose densest tile reads at most `most` points, or 0.
  double largest(double most) const {
    double extent = 0;
    for (int k = 0; k < 3; ++k) extent = std::max(extent, hi[k] - lo[k]);
    double size = std::max(extent, hist.cell()) * 1.0001;
    if (densest(size) <= most) return size;
    // Halve until it fits, then search between the last two sizes.
    double big = size;
    while (size > hist.cell()) {
      size /= 2;
      if (densest(size) <= most) break;
      big = size;
    }
    if (densest(size) > most) return 0.0;
    for (int i = 0; i < 12; ++i) {
      const double mid = 0.5 * (size + big);
      if (densest(mid) <= most)
        size = mid;
      else
        big = mid;
    }
    return size;
  }
};

}  // namespace

double tiled_detail::size_for_memory(io::point_stream& s, const tile_plan& p, const double lo[3], const double hi[3],
                                     const tiled_progress& progress) {
  const double limit = double(p.request.memory_limit);
  const double per_point = tile_bytes_per_point(p);
  if (limit <= fixed_overhead + per_point * 1000)
    throw std::invalid_argument("--memory-limit " + std::to_string(p.request.memory_limit) +
                                " bytes is too small: a run needs about " +
                                std::to_string(std::uint64_t(fixed_overhead / (1 << 20))) + " MiB besides its tiles");
  // Larger tiles would fit but run slower: a whole 100 M-point run takes 1.4
  // M points a second, tiles of 8 M 1.6 M, tiles of 0.3 M 2.5 M (docs/journal/scale.md).
  const double max_fitting = (limit - fixed_overhead) / per_point;
  const double max_points = std::min(max_fitting, 2e6);
  const double halo = exact_halo(halo_params(p.request), 0);
  // Cells of the histogram: a quarter of the halo or more, at most 2^22.
  point_histogram hist(halo / 4, lo, hi);
  hist.count(s, p, progress);
  const tile_size_search search{hist, lo, hi, halo};
  // Tiles of at most 2 M points, which run fastest, unless that makes them
  // narrower than 8 halos (then each point is read too many times): then as
  // large as fits, up to 8 halos.
  double size = search.largest(max_points);
  if (size < 8 * halo) {
    const double fitting = search.largest(max_fitting);
    size = fitting == 0 ? 0 : std::min(fitting, std::max(size, 8 * halo));
  }
  if (size == 0)
    throw std::invalid_argument(
        "--memory-limit " + std::to_string(p.request.memory_limit) +
        " bytes is too small for this cloud: its densest area needs about " +
        std::to_string(std::uint64_t((search.densest(hist.cell()) * per_point + fixed_overhead) / (1 << 20))) +
        " MiB even with the smallest tiles");
  return size;
}

}  // namespace ced
