// SPDX-License-Identifier: MIT
// Tiled runs: the plan. Pass 1 over the input learns its counts, bounds and
// field ranges; the grid follows (its tile size asked, or sized for a memory
// limit: sizing.cpp); pass 2 counts the points of each tile.
#include "tiled/planning.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "ced/channels.hpp"
#include "ced/io/las.hpp"
#include "ced/scaled.hpp"
#include "core/text.hpp"
#include "tiled/chunks.hpp"
#include "tiled/fingerprint.hpp"
#include "tiled/modalities.hpp"
#include "tiled/records.hpp"
#include "tiled/sizing.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// Throws std::invalid_argument for a bad tile size, limit or modality.
void check_request(const tiled_request& request) {
  validate(request.params);
  if (request.reach_estimated && unbounded_reach(request.params.neighborhood))
    throw std::invalid_argument("tiled request: reach_estimated without a reach");
  if (request.memory_limit == 0 && (!(request.tile_size > 0) || !std::isfinite(request.tile_size)))
    throw std::invalid_argument("tile size must be a positive number of metres, got " +
                                detail::number_text(request.tile_size));
  if (request.memory_limit > 0 && request.tile_size > 0)
    throw std::invalid_argument("give a tile size or a memory limit, not both");
  modalities_of(request.modalities);  // bad specs fail before the file is read
}

/// A plan of `request` over the file `s` reads, before anything of its points:
/// the request (checked), the input's fingerprint and description.
tile_plan plan_head(const tiled_request& request, const io::point_stream& s) {
  check_request(request);
  tile_plan p;
  p.request = request;
  p.fingerprint = fingerprint_of(request.input, p.input_bytes);
  p.details = s.details();
  p.streamed = s.streaming();
  return p;
}

/// Throws io_error when the plan's input has no finite point or more than
/// 32-bit indices can count.
void check_point_count(const tile_plan& p) {
  if (p.finite_points == 0) throw io::io_error(p.request.input, "the cloud has no (finite) points");
  if (p.finite_points > std::numeric_limits<std::uint32_t>::max())
    throw io::io_error(p.request.input,
                       "more than 2^32-1 finite points: a tile plan indexes points with 32 bits in each tile, "
                       "but the whole file's indices must fit the outputs' too (split the file)");
}

/// The plan's modalities (a preset when none were asked: ced6d when `probe`,
/// a point of the file, has colour) find their fields: an error now, not in
/// every tile.
void bind_modalities(tile_plan& p, const point_cloud& probe) {
  if (p.request.modalities.empty()) p.request.modalities = preset_specs(probe.has_rgb() ? "ced6d" : "ced3d");
  const point_cloud one = probe_cloud(p);
  for (const auto& m : modalities_of(p.request.modalities)) m.bind(one, probe_params(p.request.params));
}

/// A neighbourhood that reaches as far as the data make it (knn:K, or
/// adaptive:K without max) asked without reach=: the plan takes one from
/// the box [lo, hi] of its finite points (tiled_request::reach_estimated).
void settle_reach(tile_plan& p, const double lo[3], const double hi[3]) {
  neighborhood_spec& n = p.request.params.neighborhood;
  if (!unbounded_reach(n)) return;
  if (p.finite_points < n.k)
    throw std::invalid_argument("neighbourhood " + to_string(n) + ": K is larger than the cloud (" +
                                std::to_string(p.finite_points) + " finite points)");
  n.reach = estimated_reach(p.request.params, lo, hi, p.finite_points);
  p.request.reach_estimated = true;
}

/// The absolute box [lo, hi] relative to the plan's origin, into [plo, phi].
void relative_box(const tile_plan& p, const double lo[3], const double hi[3], double plo[3], double phi[3]) noexcept {
  for (std::size_t k = 0; k < 3; ++k) {
    plo[k] = lo[k] - p.origin[k];
    phi[k] = hi[k] - p.origin[k];
  }
}

/// Pass 1: counts, field ranges, the origin (and the bounds, from `s`).
scan_result scan_input(tile_plan& p, io::point_stream& s, const tiled_progress& progress) {
  scan_result scan;
  for_each_chunk(s, {0, 0, 0}, [&](const point_cloud& c) {
    scan_chunk(c, scan);
    if (progress)
      progress("reading (pass 1: bounds and ranges)",
               s.declared_points() ? double(scan.file_points) / double(s.declared_points()) : 0.0);
  });
  p.file_points = scan.file_points;
  p.finite_points = scan.finite_points;
  check_point_count(p);
  p.origin = s.origin();
  return scan;
}

/// The file's own fields, as every chunk has them from now on, with their
/// ranges; the modalities (a preset when none were asked) find theirs.
/// Leaves `s` rewound.
void plan_fields(tile_plan& p, io::point_stream& s, const scan_result& scan) {
  s.rewind();
  point_cloud probe;
  s.read(1, p.origin, probe);
  s.rewind();
  for (const field& f : probe.fields()) p.fields.push_back({f.name, f.type(), value_range{0, 0}, nullptr});
  set_ranges(p.fields, scan);
  bind_modalities(p, probe);
}

using index_node = io::point_stream::index_node;

/// The most tiles a plan from a spatial index may have (it lists them all).
constexpr std::uint64_t k_max_indexed_tiles = std::uint64_t(1) << 20;
/// A catalogue's files without an index are planned from their headers only
/// when its tiles would decode at most this many points a point.
constexpr double k_most_decoded = 3;

/// The points that the tiles of a plan from `nodes` decode, per point, when
/// some are files without an index (index_node::whole_file: every tile whose
/// core and halo meet such a file decodes all of it); 0 when none is.
double decoded_per_point(const tile_plan& p, const std::vector<io::point_stream::index_node>& nodes) {
  const tile_grid& g = p.grid;
  double decoded = 0;
  bool any = false;
  for (const auto& n : nodes) {
    any = any || n.whole_file;
    double tiles = 1;
    for (std::size_t k = 0; k < 3; ++k) {
      const auto cell = [&](double x) { return std::clamp(std::floor((x - g.lo[k]) / g.size), 0.0, g.dims[k] - 1.0); };
      tiles *= cell(n.box[3 + k] - p.origin[k] + g.halo) - cell(n.box[k] - p.origin[k] - g.halo) + 1;
    }
    decoded += tiles * double(n.run.count);
  }
  return any ? decoded / double(std::max<std::uint64_t>(p.file_points, 1)) : 0;
}

/// The part of [a, b] (edge-extended: -inf/+inf at the grid's ends) that the
/// interval [lo, hi] covers, as a fraction of it.
double covered(double a, double b, double lo, double hi) noexcept {
  if (!(hi > lo)) return lo >= a && lo <= b ? 1.0 : 0.0;
  return std::max(0.0, std::min(b, hi) - std::max(a, lo)) / (hi - lo);
}

/// The tiles whose core (grown by `margin`) meets a node with points, with
/// counts estimated from the nodes' (a node's points spread evenly over its box).
std::vector<tile_entry> tiles_of_nodes(const tile_plan& p, const std::vector<index_node>& nodes, double margin) {
  const tile_grid& g = p.grid;
  // Per tile: the estimated points of its core and of its core and halo, and
  // whether its core meets a node (the shallow nodes meet every tile).
  struct estimate {
    double core = 0, all = 0;
    bool listed = false;
  };
  std::vector<estimate> by_tile(g.count());
  constexpr double far = std::numeric_limits<double>::infinity();
  for (const index_node& n : nodes) {
    if (n.run.count == 0) continue;
    double lo[3], hi[3];
    std::int64_t c0[3], c1[3], h0[3], h1[3];
    const auto cell = [&](std::size_t k, double x) {
      const double c = std::floor((x - g.lo[k]) / g.size);
      return static_cast<std::int64_t>(std::clamp(c, 0.0, double(g.dims[k] - 1)));
    };
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = n.box[k] - p.origin[k];
      hi[k] = n.box[3 + k] - p.origin[k];
      c0[k] = cell(k, lo[k] - margin);
      c1[k] = cell(k, hi[k] + margin);
      h0[k] = cell(k, lo[k] - g.halo - margin);
      h1[k] = cell(k, hi[k] + g.halo + margin);
    }
    for (std::int64_t z = h0[2]; z <= h1[2]; ++z)
      for (std::int64_t y = h0[1]; y <= h1[1]; ++y)
        for (std::int64_t x = h0[0]; x <= h1[0]; ++x) {
          const std::int64_t c[3] = {x, y, z};
          double core = double(n.run.count), all = core;
          bool own = true;
          for (std::size_t k = 0; k < 3; ++k) {
            const double a = c[k] == 0 ? -far : g.lo[k] + double(c[k]) * g.size;
            const double b = c[k] + 1 == g.dims[k] ? far : g.lo[k] + double(c[k] + 1) * g.size;
            core *= covered(a, b, lo[k], hi[k]);
            all *= covered(a - g.halo, b + g.halo, lo[k], hi[k]);
            own = own && c[k] >= c0[k] && c[k] <= c1[k];
          }
          const std::uint64_t t = std::uint64_t(x) + g.dims[0] * (std::uint64_t(y) + g.dims[1] * std::uint64_t(z));
          estimate& e = by_tile[t];
          e.core += core;
          e.all += all;
          e.listed = e.listed || own;
        }
  }
  std::vector<tile_entry> out;
  const auto add = [&](std::uint64_t t, const estimate& e) {
    if (!e.listed) return;
    const auto core = std::max<std::uint64_t>(1, std::uint64_t(std::llround(e.core)));
    out.push_back({t, core, std::max(core, std::uint64_t(std::llround(e.all)))});
  };
  for (std::uint64_t t = 0; t < by_tile.size(); ++t) add(t, by_tile[t]);
  return out;
}

/// The ranges of the plan's tile fields (all its fields when it has none)
/// over every point, from a read of those fields alone (a layered LAZ
/// decodes only their layers).
void tile_field_ranges(tile_plan& p, const tiled_progress& progress) {
  io::read_options o = p.request.read;
  if (p.tile_fields) {
    if (p.tile_fields->empty()) return;
    o.fields = field_selection::only(*p.tile_fields);
  }
  const auto s = io::open_point_stream(p.request.input, o);
  scan_result scan;
  for_each_chunk(*s, p.origin, [&](const point_cloud& c) {
    scan_chunk(c, scan);
    if (progress) progress("reading the modalities' fields", double(scan.file_points) / double(p.file_points));
  });
  if (scan.file_points != p.file_points)
    throw io::io_error(p.request.input, std::to_string(scan.file_points) + " points read; its header says " +
                                            std::to_string(p.file_points));
  set_ranges(p.fields, scan);
}

/// A plan from the file's spatial index (COPC) and header, without a pass
/// over the points (tile_plan::indexed); none when the file has no index or
/// the request cannot be planned so.
std::optional<tile_plan> plan_from_index(const tiled_request& request, io::point_stream& s,
                                         const tiled_progress& progress) {
  if (request.scan || request.memory_limit > 0) return std::nullopt;
  const auto nodes = s.index_nodes();
  if (!nodes) return std::nullopt;
  std::optional<tile_plan> p = plan_from_header(request, s);
  if (!p) return std::nullopt;
  // The root's cube meets every tile, so such a plan lists every tile of the
  // grid: with more than 2^20, the passes, which list only those that own points.
  if (p->grid.count() > k_max_indexed_tiles) return std::nullopt;
  p->indexed = true;
  std::uint64_t total = 0;
  for (const index_node& n : *nodes) total += n.run.count;
  if (total != p->file_points)
    throw io::io_error(request.input, "its spatial index holds " + std::to_string(total) + " points; its header says " +
                                          std::to_string(p->file_points));
  // Twice the margin a tile read allows a point outside its node: listing errs on the safe side.
  p->tiles = tiles_of_nodes(*p, *nodes, 2 * io::point_stream::index_margin(*nodes));
  if (decoded_per_point(*p, *nodes) > k_most_decoded) return std::nullopt;
  tile_field_ranges(*p, progress);
  return p;
}

}  // namespace

namespace tiled_detail {

namespace {

/// The range of f's values over the finite points (`fin`); `any`: it has one.
value_range finite_range(const field& f, const std::vector<std::uint8_t>& fin, bool all_finite, bool& any) {
  value_range r{0, 0};
  any = false;
  f.values.visit([&](const auto* v, std::size_t n) {
    using T = std::remove_const_t<std::remove_pointer_t<decltype(v)>>;
    if constexpr (std::is_integral_v<T>) {
      if (all_finite && n > 0) {  // the same range, in a loop the compiler vectorizes
        T lo = v[0], hi = v[0];
        for (std::size_t i = 1; i < n; ++i) {
          lo = std::min(lo, v[i]);
          hi = std::max(hi, v[i]);
        }
        r = {static_cast<double>(lo), static_cast<double>(hi)};
        any = true;
        return;
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!fin[i]) continue;
      const double x = static_cast<double>(v[i]);
      r.lo = any ? std::min(r.lo, x) : x;
      r.hi = any ? std::max(r.hi, x) : x;
      any = true;
    }
  });
  return r;
}

}  // namespace

void scan_chunk(const point_cloud& c, scan_result& s) {
  s.file_points += c.size();
  std::vector<std::uint8_t> fin(c.size());
  std::size_t finite = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    fin[i] = finite3(c.position(i));
    finite += fin[i];
  }
  s.finite_points += finite;
  std::map<std::string, bool> here;
  for (const field& f : c.fields()) {
    here[f.name] = true;
    bool any = false;
    value_range r = finite_range(f, fin, finite == c.size(), any);
    auto it = s.ranges.find(f.name);
    if (it == s.ranges.end()) {
      // A field first seen after some chunks (a LAS flag): it was 0 there.
      if (s.chunks > 0) r = any ? value_range{std::min(r.lo, 0.0), std::max(r.hi, 0.0)} : value_range{0, 0};
      s.ranges[f.name] = {r, any || s.chunks > 0};
    } else if (any) {
      auto& [w, seen] = it->second;
      w = seen ? value_range{std::min(w.lo, r.lo), std::max(w.hi, r.hi)} : r;
      seen = true;
    }
  }
  for (auto& [name, v] : s.ranges)
    if (!here.count(name)) {  // absent from this chunk: 0 there
      v.first = v.second ? value_range{std::min(v.first.lo, 0.0), std::max(v.first.hi, 0.0)} : value_range{0, 0};
      v.second = true;
    }
  ++s.chunks;
}

void set_ranges(std::vector<plan_field>& fields, const scan_result& scan) {
  for (plan_field& f : fields) {
    const auto it = scan.ranges.find(f.name);
    if (it != scan.ranges.end()) f.range = it->second.first;
  }
}

void sample_fields(tile_plan& p, const tiled_progress& progress) {
  std::vector<std::string> want;
  for (const auto& m : modalities_of(p.request.modalities))
    for (auto& name : m.whole_cloud_fields()) want.push_back(std::move(name));
  std::vector<plan_field*> fields;
  for (plan_field& f : p.fields)
    if (std::any_of(want.begin(), want.end(), [&](const std::string& w) { return field_name_matches(w, f.name); }))
      fields.push_back(&f);
  if (fields.empty()) return;  // none needed, or the modality will name the field it lacks
  std::vector<std::string> names;
  for (const plan_field* f : fields) names.push_back(f->name);
  io::read_options o = p.request.read;
  o.fields = field_selection::only(names);
  const auto s = io::open_point_stream(p.request.input, o);
  // The sample points are the finite points whose rank among them is
  // whole_sample_index(j, n): strictly ascending in j, as n ≥ m.
  const std::uint64_t n = p.finite_points;
  const std::size_t m = whole_sample_count(n);
  std::vector<std::vector<double>> values(fields.size());
  for (auto& v : values) v.reserve(m);
  std::uint64_t finite = 0, read = 0;
  std::size_t j = 0;
  std::vector<const field*> here(fields.size());
  for_each_chunk(*s, p.origin, [&](const point_cloud& c) {
    for (std::size_t k = 0; k < fields.size(); ++k) here[k] = c.find_field(fields[k]->name);
    for (std::size_t i = 0; i < c.size() && j < m; ++i) {
      if (!finite3(c.position(i))) continue;
      if (whole_sample_index(j, n) == finite) {
        // A field a chunk lacks (a LAS flag none of its points sets) is 0 there.
        for (std::size_t k = 0; k < fields.size(); ++k) values[k].push_back(here[k] ? here[k]->values[i] : 0.0);
        ++j;
      }
      ++finite;
    }
    read += c.size();
    if (progress) progress("reading (the sample of the whole-cloud statistics)", double(read) / double(p.file_points));
  });
  if (j != m)
    throw io::io_error(p.request.input, "its sample for range=zscore, percentiles or pca= read short (" +
                                            std::to_string(j) + " of " + std::to_string(m) +
                                            " points): the file changed since it was planned");
  for (std::size_t k = 0; k < fields.size(); ++k)
    fields[k]->sample = std::make_shared<const std::vector<double>>(std::move(values[k]));
}

bool is_las_flag(const std::string& name) {
  const auto& flags = io::las_flag_fields();
  return std::find(flags.begin(), flags.end(), name) != flags.end();
}

std::optional<tile_plan> plan_from_header(const tiled_request& request, io::point_stream& s) {
  double hlo[3], hhi[3], box[6];
  if (!s.header_bounds(hlo, hhi) || !s.header_box(0.01, box)) return std::nullopt;
  tile_plan p = plan_head(request, s);
  p.file_points = p.finite_points = s.declared_points();  // LAS positions are always finite
  check_point_count(p);
  p.origin = choose_origin(hlo, hhi);
  // The fields: every one the point format gives, each flag among them (a
  // stream of its own: a run read spends a stream's pass).
  point_cloud probe;
  io::open_point_stream(request.input, request.read)->read_run({0, 1}, io::las_flag_fields(), p.origin, probe);
  for (const field& f : probe.fields()) p.fields.push_back({f.name, f.type(), value_range{0, 0}, nullptr});
  bind_modalities(p, probe);
  p.tile_fields = detection_fields(p);
  // Without tile_fields every field goes through the cache (a modality that
  // does not say which it reads, or a read of only those): not the flags,
  // whose presence only a pass over the points decides.
  if (!p.tile_fields)
    for (const plan_field& f : p.fields)
      if (is_las_flag(f.name)) return std::nullopt;
  double plo[3], phi[3];
  relative_box(p, box, box + 3, plo, phi);
  settle_reach(p, plo, phi);
  p.grid = make_tile_grid(plo, phi, request.tile_size, halo_params(p.request));
  return p;
}

tile_plan plan_grid(const tiled_request& request, io::point_stream& s, const tiled_progress& progress) {
  tile_plan p = plan_head(request, s);
  const scan_result scan = scan_input(p, s, progress);
  double lo[3], hi[3];
  s.bounds(lo, hi);
  plan_fields(p, s, scan);
  double plo[3], phi[3];
  relative_box(p, lo, hi, plo, phi);
  settle_reach(p, plo, phi);
  const double size = request.memory_limit > 0 ? size_for_memory(s, p, plo, phi, progress) : request.tile_size;
  s.rewind();
  p.grid = make_tile_grid(plo, phi, size, halo_params(p.request));
  return p;
}

std::vector<tile_entry> tile_counter::entries() const {
  std::vector<tile_entry> out;
  if (dense) {
    for (std::uint64_t t = 0; t < core_v.size(); ++t)
      if (core_v[t]) out.push_back({t, core_v[t], all_v[t]});
  } else {
    for (const auto& [t, v] : sparse)
      if (v.first) out.push_back({t, v.first, v.second});
    std::sort(out.begin(), out.end(), [](const tile_entry& a, const tile_entry& b) { return a.id < b.id; });
  }
  return out;
}

std::vector<tile_entry> count_tiles(io::point_stream& s, const tile_plan& p, const tiled_progress& progress,
                                    std::uint64_t* content) {
  tile_counter counts(p.grid.count());
  std::vector<std::uint64_t> near;
  std::uint64_t done = 0;
  for_each_chunk(s, p.origin, [&](const point_cloud& c) {
    if (content) *content = hash_chunk(c, *content);
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (!finite3(c.position(i))) continue;
      counts.point(p.grid, c.position(i), near);
    }
    done += c.size();
    if (progress) progress("reading (pass 2: points per tile)", double(done) / double(p.file_points));
  });
  s.rewind();
  return counts.entries();
}

}  // namespace tiled_detail

namespace {

/// Pass 2 over a file of runs (LAS, LAZ, binary PLY and PCD), run by run
/// (`runs`: its chunk_runs(), every point finite): points per tile, and each
/// run's box and hash (tile_plan::runs).
void count_tiles_by_runs(io::point_stream& s, tile_plan& p, const std::vector<io::point_stream::point_run>& runs,
                         const tiled_progress& progress) {
  tile_counter counts(p.grid.count());
  std::vector<std::uint64_t> near;
  const std::vector<std::string> names = field_names(p);
  std::uint64_t done = 0;
  p.runs.clear();
  for_each_run_group(s, runs, names, p.origin, [&](const point_cloud& c, std::size_t r0, std::size_t r1) {
    std::size_t at = 0;
    for (std::size_t r = r0; r < r1; ++r) {
      const auto n = static_cast<std::size_t>(runs[r].count);
      if (at + n > c.size()) throw io::io_error(p.request.input, "a run of its points reads short: make a new plan");
      plan_run& e = p.runs.emplace_back();
      e.first = runs[r].first;
      e.count = runs[r].count;
      e.hash = hash_points(c, at, n, 0);
      e.box = run_box(c, at, n);
      for (std::size_t i = at; i < at + n; ++i) counts.point(p.grid, c.position(i), near);
      at += n;
    }
    done += c.size();
    if (progress) progress("reading (pass 2: points per tile)", double(done) / double(p.file_points));
  });
  if (done != p.file_points)
    throw io::io_error(p.request.input, std::to_string(done) + " points read by runs; pass 1 read " +
                                            std::to_string(p.file_points) + ": make a new plan");
  p.tiles = counts.entries();
}

}  // namespace

tile_plan plan_tiles(const tiled_request& request, const tiled_progress& progress) {
  auto s = io::open_point_stream(request.input, request.read);
  if (auto p = plan_from_index(request, *s, progress)) {
    sample_fields(*p, progress);
    return std::move(*p);
  }
  tile_plan p = plan_grid(request, *s, progress);
  // LAS, LAZ, binary PLY and PCD (every point finite): a tile reads only the runs near it.
  const auto runs = s->chunk_runs();
  if (!runs.empty() && p.finite_points == p.file_points) {
    count_tiles_by_runs(*s, p, runs, progress);
  } else {
    std::uint64_t content = 0;
    p.tiles = count_tiles(*s, p, progress, &content);  // pass 2
    p.content = hex(content);
  }
  sample_fields(p, progress);
  return p;
}

}  // namespace ced
