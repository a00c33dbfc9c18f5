// SPDX-License-Identifier: MIT
#include "ced/preprocess.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/neighbor_index.hpp"
#include "core/parallel.hpp"

namespace ced {

std::vector<std::uint32_t> remove_nonfinite(point_cloud& cloud) {
  const auto& p = cloud.positions();
  std::vector<std::uint8_t> keep(cloud.size(), 1);
  std::vector<std::uint32_t> original;
  original.reserve(cloud.size());
  bool any = false;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (std::isfinite(p[3 * i]) && std::isfinite(p[3 * i + 1]) && std::isfinite(p[3 * i + 2])) {
      original.push_back(static_cast<std::uint32_t>(i));
    } else {
      keep[i] = 0;
      any = true;
    }
  }
  if (any) cloud.filter(keep);
  return original;
}

voxel_result voxel_downsample(const point_cloud& cloud, double size) {
  if (!(size > 0) || !std::isfinite(size))
    throw std::invalid_argument("voxel size must be a positive finite number, got " + std::to_string(size));
  voxel_result out;
  out.cloud.set_origin(cloud.origin());
  const std::size_t n = cloud.size();
  if (n == 0) {
    for (const auto& f : cloud.fields()) out.cloud.add_field(f.name, f.type(), {});
    return out;
  }
  const float inv = static_cast<float>(1.0 / size);
  std::vector<std::array<std::int64_t, 3>> cell(n);
  std::array<std::int64_t, 3> lo{}, hi{};
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = cloud.position(i);
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(p[k]))
        throw std::invalid_argument("voxel_downsample: point " + std::to_string(i) + " has a non-finite coordinate");
      const float v = std::floor(p[k] * inv);
      if (std::abs(v) > 4e15f) throw std::invalid_argument("voxel size too small for the cloud's extent");
      cell[i][std::size_t(k)] = static_cast<std::int64_t>(v);
    }
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = i == 0 ? cell[i][k] : std::min(lo[k], cell[i][k]);
      hi[k] = i == 0 ? cell[i][k] : std::max(hi[k], cell[i][k]);
    }
  }
  long double total = 1;
  for (std::size_t k = 0; k < 3; ++k) total *= static_cast<long double>(hi[k] - lo[k] + 1);
  if (total > 1.8e19L)
    throw std::invalid_argument("voxel size " + std::to_string(size) + " is too small for the cloud's extent");
  const std::uint64_t dx = std::uint64_t(hi[0] - lo[0] + 1), dy = std::uint64_t(hi[1] - lo[1] + 1);
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t key = std::uint64_t(cell[i][0] - lo[0]) + std::uint64_t(cell[i][1] - lo[1]) * dx +
                              std::uint64_t(cell[i][2] - lo[2]) * dx * dy;
    keyed[i] = {key, static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::vector<double>> fields(cloud.fields().size());
  for (std::size_t a = 0; a < n;) {
    std::size_t b = a;
    while (b < n && keyed[b].first == keyed[a].first) ++b;
    double s[3] = {0, 0, 0};
    for (std::size_t q = a; q < b; ++q)
      for (int k = 0; k < 3; ++k) s[k] += cloud.position(keyed[q].second)[k];
    const double m = double(b - a);
    const float c[3] = {float(s[0] / m), float(s[1] / m), float(s[2] / m)};
    out.cloud.push_back(c[0], c[1], c[2]);
    std::uint32_t best = keyed[a].second;
    float best_d = std::numeric_limits<float>::infinity();
    for (std::size_t q = a; q < b; ++q) {
      const float d = squared_distance(cloud.position(keyed[q].second), c);
      if (d < best_d) best_d = d, best = keyed[q].second;
    }
    out.representative.push_back(best);
    out.counts.push_back(static_cast<std::uint32_t>(b - a));
    for (std::size_t f = 0; f < fields.size(); ++f) {
      const auto& src = cloud.fields()[f];
      double sum = 0;
      for (std::size_t q = a; q < b; ++q) sum += src.values[keyed[q].second];
      const double mean = sum / m;
      fields[f].push_back(is_integer(src.type()) ? std::trunc(mean) : mean);
    }
    a = b;
  }
  for (std::size_t f = 0; f < fields.size(); ++f)
    out.cloud.add_field(cloud.fields()[f].name, cloud.fields()[f].type(), std::move(fields[f]));
  return out;
}

double estimate_resolution(const point_cloud& cloud, std::size_t max_samples) {
  const std::size_t n = cloud.size();
  if (n < 2) return 0.0;
  const neighbor_index index(cloud.positions().data(), n, 32);
  const std::size_t samples = std::max<std::size_t>(1, std::min(n, max_samples));
  std::vector<float> d;
  d.reserve(samples);
  for (std::size_t s = 0; s < samples; ++s) {
    const float v = index.nearest_other_distance(static_cast<std::uint32_t>(s * n / samples));
    if (v > 0 && std::isfinite(v)) d.push_back(v);
  }
  // Every sample has a twin (each point stored two times or more): the
  // spacing is that of the distinct positions.
  if (d.empty())
    for (std::size_t s = 0; s < samples; ++s) {
      const float v = index.nearest_distinct_distance(static_cast<std::uint32_t>(s * n / samples));
      if (v > 0 && std::isfinite(v)) d.push_back(v);
    }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() / 2), d.end());
  return d[d.size() / 2];
}

std::size_t coincident_points(const point_cloud& cloud) {
  const std::size_t n = cloud.size();
  std::vector<std::array<std::uint32_t, 3>> at(n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < 3; ++k) at[i][k] = place_bits(cloud.position(i)[k]);
  std::sort(at.begin(), at.end());
  std::size_t shared = 0;
  for (std::size_t a = 0, b; a < n; a = b) {
    for (b = a + 1; b < n && at[b] == at[a]; ++b) {
    }
    if (b - a > 1) shared += b - a;
  }
  return shared;
}

std::vector<double> k_distance_quantiles(const point_cloud& cloud, std::size_t k, const std::vector<double>& q,
                                         std::size_t max_samples) {
  const std::size_t n = cloud.size();
  if (k < 1 || k > n)
    throw std::invalid_argument("k-distance: K must be from 1 to the number of points (" + std::to_string(n) +
                                "), got " + std::to_string(k));
  for (double v : q)
    if (!(v >= 0 && v <= 1)) throw std::invalid_argument("k-distance: a quantile must be in [0, 1]");
  const float* xyz = cloud.positions().data();
  const neighbor_index index(xyz, n, 32);
  const std::size_t samples = std::max<std::size_t>(1, std::min(n, max_samples));
  std::vector<double> d(samples);
  std::vector<neighbor_index::ranked_point> found;
  for (std::size_t s = 0; s < samples; ++s) {
    const auto i = static_cast<std::uint32_t>(s * n / samples);
    index.k_nearest(xyz + 3 * std::size_t(i), k, i, found);
    d[s] = std::sqrt(double(found.back().d2));
  }
  std::sort(d.begin(), d.end());
  std::vector<double> out;
  for (double v : q) out.push_back(d[static_cast<std::size_t>(std::lround(v * double(samples - 1)))]);
  return out;
}

}  // namespace ced

namespace ced {

point_cloud merge_channels(const point_cloud& reference, const std::vector<named_channel>& others,
                           const channel_merge_options& options, channel_merge_report* report) {
  if (!(options.radius > 0) || !std::isfinite(options.radius))
    throw std::invalid_argument("merge_channels: the radius must be a finite number > 0, got " +
                                std::to_string(options.radius));
  if (options.fields.empty()) throw std::invalid_argument("merge_channels: name at least one field to take");
  point_cloud out = reference;
  const std::size_t n = reference.size();
  const bool drop = options.when_missing == channel_merge_options::missing::drop;
  std::vector<std::uint8_t> complete(n, 1);
  channel_merge_report r;
  std::vector<std::string> names;
  for (const named_channel& ch : others) {
    if (!ch.cloud) throw std::invalid_argument("merge_channels: channel '" + ch.name + "' has no cloud");
    if (ch.name.empty()) throw std::invalid_argument("merge_channels: a channel needs a name");
    if (std::find(names.begin(), names.end(), ch.name) != names.end())
      throw std::invalid_argument("merge_channels: two channels are named '" + ch.name + "'");
    names.push_back(ch.name);
    const point_cloud& c = *ch.cloud;
    std::vector<const field*> take;
    for (const std::string& f : options.fields) {
      const field* found = c.find_field_icase(f);
      if (!found) throw std::invalid_argument("merge_channels: channel '" + ch.name + "' has no field '" + f + "'");
      const std::string merged = f + "_" + ch.name;
      if (out.find_field_icase(merged))
        throw std::invalid_argument("merge_channels: the reference already has a field '" + merged + "'");
      take.push_back(found);
    }
    // The channel's finite points in the reference's frame: origin + p, then
    // less the reference's origin, in double, rounded to float once.
    std::vector<float> xyz;
    std::vector<std::uint32_t> index_of;
    xyz.reserve(3 * c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      const float* p = c.position(i);
      float q[3];
      bool finite = true;
      for (int a = 0; a < 3; ++a) {
        q[a] = static_cast<float>((c.origin()[std::size_t(a)] - reference.origin()[std::size_t(a)]) + double(p[a]));
        finite = finite && std::isfinite(q[a]);
      }
      if (!finite) continue;
      xyz.insert(xyz.end(), q, q + 3);
      index_of.push_back(static_cast<std::uint32_t>(i));
    }
    std::vector<std::uint32_t> partner(n, UINT32_MAX);
    const float r2 = static_cast<float>(options.radius * options.radius);
    if (!index_of.empty()) {
      const neighbor_index index(xyz.data(), index_of.size(), 32);
      detail::parallel_for(n, detail::resolve_threads(options.threads), 4096, [&](std::size_t b, std::size_t e) {
        std::vector<neighbor_index::ranked_point> found;
        for (std::size_t i = b; i < e; ++i) {
          const float* p = reference.position(i);
          if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
          index.k_nearest(p, 1, UINT32_MAX, found);
          if (!found.empty() && found[0].d2 < r2) partner[i] = index_of[found[0].index];
        }
      });
    }
    std::size_t partnered = 0;
    for (std::size_t i = 0; i < n; ++i) {
      partnered += partner[i] != UINT32_MAX;
      if (partner[i] == UINT32_MAX) complete[i] = 0;
    }
    r.partnered.push_back(partnered);
    for (std::size_t k = 0; k < take.size(); ++k) {
      const field& src = *take[k];
      const scalar_type type = drop ? src.type() : scalar_type::float32;
      // (Points without a partner: NaN, or 0 where they are dropped below.)
      const double none = drop ? 0.0 : std::numeric_limits<double>::quiet_NaN();
      std::vector<double> v(n);
      for (std::size_t i = 0; i < n; ++i) v[i] = partner[i] != UINT32_MAX ? src.values[partner[i]] : none;
      out.add_field(options.fields[k] + "_" + ch.name, type, v);
    }
  }
  if (drop) {
    for (std::uint8_t k : complete) r.dropped += k == 0;
    if (r.dropped > 0) out.filter(complete);
  }
  if (report) *report = std::move(r);
  return out;
}

}  // namespace ced
