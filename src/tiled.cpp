// SPDX-License-Identifier: MIT
// Tiled runs (ced/tiled.hpp): plan, tile cache, tiles, parts, merge.
#include "ced/tiled.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <queue>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "ced/detect.hpp"
#include "ced/io/output_file.hpp"
#include "ced/io/stream.hpp"
#include "ced/modality.hpp"
#include "ced/scaled.hpp"

namespace ced {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t chunk_points = std::size_t(1) << 20;
constexpr int plan_version = 1;
constexpr char part_magic[8] = {'C', 'E', 'D', 'P', 'A', 'R', 'T', '1'};

[[noreturn]] void fail(const std::string& what, const std::string& msg) { throw io::io_error(what + ": " + msg); }

std::uint64_t fnv1a(const char* p, std::size_t n, std::uint64_t h = 1469598103934665603ull) {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(p[i]);
    h *= 1099511628211ull;
  }
  return h;
}

/// A fast hash of decoded data, 8 bytes at a time (the content of a plan).
std::uint64_t hash_words(const unsigned char* p, std::size_t n, std::uint64_t h) {
  auto mix = [](std::uint64_t x, std::uint64_t w) {
    x = (x ^ w) * 0x9E3779B97F4A7C15ull;
    return x ^ (x >> 29);
  };
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = mix(h, w);
  }
  std::uint64_t tail = 0;
  if (i < n) std::memcpy(&tail, p + i, n - i);
  return mix(mix(h, tail), n);
}

/// A chunk's positions and every field's values, into the content hash.
std::uint64_t hash_chunk(const point_cloud& c, std::uint64_t h) {
  h = hash_words(reinterpret_cast<const unsigned char*>(c.positions().data()), 12 * c.size(), h);
  for (const field& f : c.fields()) h = hash_words(f.values.bytes(), size_of(f.type()) * c.size(), h);
  return h;
}

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

/// The file's size, and a hash of it: its size, its first and last 64 KiB and
/// 64 blocks of 4 KiB spread evenly (a different file, or one changed in
/// place, almost surely differs; reading it whole would cost a pass).
std::string fingerprint_of(const std::string& path, std::uint64_t& bytes) {
  std::error_code ec;
  bytes = fs::file_size(path, ec);
  if (ec) fail(path, "cannot read its size: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  std::uint64_t h = fnv1a(reinterpret_cast<const char*>(&bytes), sizeof bytes);
  std::string buf;
  auto block = [&](std::uint64_t at, std::uint64_t n) {
    n = std::min<std::uint64_t>(n, bytes - std::min(at, bytes));
    buf.resize(static_cast<std::size_t>(n));
    in.seekg(static_cast<std::streamoff>(at));
    in.read(buf.data(), static_cast<std::streamsize>(n));
    if (!in) fail(path, "cannot read it");
    h = fnv1a(buf.data(), buf.size(), h);
  };
  block(0, 65536);
  for (std::uint64_t k = 1; k <= 64; ++k) block(bytes / 65 * k, 4096);
  block(bytes > 65536 ? bytes - 65536 : 0, 65536);
  return hex(h);
}

bool finite3(const float* p) noexcept { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

/// True when p lies in tile t's core grown by the halo (the test of tiles_near()).
bool near_tile(const tile_grid& g, const std::array<std::uint32_t, 3>& c, const float* p) noexcept {
  std::int64_t own[3], c0[3], c1[3];
  g.locate(p, own, c0, c1);
  for (std::size_t k = 0; k < 3; ++k)
    if (c0[k] > std::int64_t(c[k]) || c1[k] < std::int64_t(c[k])) return false;
  return true;
}

std::vector<any_modality> modalities_of(const std::vector<std::string>& specs) {
  std::vector<any_modality> out;
  for (const auto& s : specs) out.push_back(make_modality(s));
  return out;
}

/// The parameters a tile's halo follows: the radius of the largest scale
/// among the modalities (scale=).
detect_params halo_params(const tiled_request& r) {
  return scaled_params(r.params, max_scale_factor(modalities_of(r.modalities)));
}

/// A part's modality names and absolute thresholds, from the plan's modalities.
void name_modalities(const tile_plan& plan, const std::vector<any_modality>& modalities, tile_part& part) {
  for (const auto& mod : modalities) {
    part.names.push_back(mod.name());
    part.thresholds.push_back(mod.threshold(plan.request.params));
  }
}

scalar_type type_named(const std::string& name, const std::string& where) {
  for (int t = 0; t <= int(scalar_type::float64); ++t)
    if (name_of(scalar_type(t)) == name) return scalar_type(t);
  fail(where, "unknown field type '" + name + "'");
}

nlohmann::json request_json(const tiled_request& r) {
  nlohmann::json j;
  j["input"] = r.input;
  j["format"] = io::format_name(r.read.format);
  j["csv_columns"] = r.read.csv.columns;
  j["fields"] = r.read.fields.all ? nlohmann::json("all") : nlohmann::json(r.read.fields.names);
  j["radius"] = r.params.radius;
  j["nms_radius"] = r.params.nms_radius;
  j["min_neighbors"] = r.params.min_neighbors;
  j["block_scale"] = r.params.block_scale;
  j["refine"] = r.params.refine;
  j["modalities"] = r.modalities;
  j["tile_size"] = r.tile_size;
  j["memory_limit"] = r.memory_limit;
  return j;
}

/// A whole number of a plan, within T's range (`what` names it): nlohmann's
/// get<> would wrap -1 to 2^32-1 and truncate 2.5.
template <class T>
T whole_number(const nlohmann::json& v, const std::string& what) {
  if (!v.is_number_unsigned() || v.get<std::uint64_t>() > std::numeric_limits<T>::max())
    throw std::invalid_argument(what + " must be a whole number from 0 to " +
                                std::to_string(std::numeric_limits<T>::max()) + ", got " + v.dump());
  return static_cast<T>(v.get<std::uint64_t>());
}
template <class T>
T count_of(const nlohmann::json& j, const char* key) {
  return whole_number<T>(j.at(key), std::string("'") + key + "'");
}
/// A finite number of a plan.
double number_of(const nlohmann::json& j, const char* key) {
  const nlohmann::json& v = j.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw std::invalid_argument(std::string("'") + key + "' must be a finite number, got " + v.dump());
  return v.get<double>();
}
std::array<double, 3> point_of(const nlohmann::json& j, const char* key) {
  const nlohmann::json& v = j.at(key);
  if (!v.is_array() || v.size() != 3) throw std::invalid_argument(std::string("'") + key + "' must be 3 numbers");
  std::array<double, 3> out{};
  for (std::size_t k = 0; k < 3; ++k) {
    if (!v[k].is_number() || !std::isfinite(v[k].get<double>()))
      throw std::invalid_argument(std::string("'") + key + "' must be 3 finite numbers, got " + v.dump());
    out[k] = v[k].get<double>();
  }
  return out;
}

tiled_request request_from_json(const nlohmann::json& j) {
  tiled_request r;
  r.input = j.at("input").get<std::string>();
  r.read.format = io::parse_format(j.at("format").get<std::string>());
  r.read.csv.columns = j.at("csv_columns").get<std::vector<std::string>>();
  if (j.at("fields").is_string()) {
    if (j.at("fields").get<std::string>() != "all") throw std::invalid_argument("'fields' must be \"all\" or a list");
    r.read.fields = {};
  } else {
    r.read.fields = field_selection::only(j.at("fields").get<std::vector<std::string>>());
  }
  r.params.radius = number_of(j, "radius");
  r.params.nms_radius = number_of(j, "nms_radius");
  r.params.min_neighbors = count_of<std::uint32_t>(j, "min_neighbors");
  r.params.block_scale = number_of(j, "block_scale");
  if (j.contains("refine") && !j.at("refine").is_boolean())
    throw std::invalid_argument("'refine' must be true or false");
  r.params.refine = j.value("refine", false);  // plans written before refinement existed
  r.modalities = j.at("modalities").get<std::vector<std::string>>();
  r.tile_size = number_of(j, "tile_size");
  r.memory_limit = count_of<std::uint64_t>(j, "memory_limit");
  validate(r.params);
  if (r.modalities.empty()) throw std::invalid_argument("'modalities' is empty");
  modalities_of(r.modalities);  // each spec parses
  if (r.tile_size < 0 || (r.tile_size == 0) == (r.memory_limit == 0))
    throw std::invalid_argument("a plan has a positive 'tile_size' or a 'memory_limit', one of them");
  return r;
}

/// Reads `s` chunk by chunk (positions relative to `origin`) and calls
/// f(chunk) for each, in order: a thread reads and decodes the next chunk
/// while f works on this one. An exception of either is rethrown here.
template <class F>
void for_each_chunk(io::point_stream& s, const std::array<double, 3>& origin, F&& f) {
  point_cloud chunks[2];
  std::size_t got[2] = {0, 0};
  got[0] = s.read(chunk_points, origin, chunks[0]);
  for (int k = 0; got[k] > 0; k ^= 1) {
    auto next = std::async(std::launch::async, [&, k] { got[k ^ 1] = s.read(chunk_points, origin, chunks[k ^ 1]); });
    try {
      f(static_cast<const point_cloud&>(chunks[k]));
    } catch (...) {
      next.wait();
      throw;
    }
    next.get();
  }
}

/// Bytes of one point in a tile cache or part: index, file index, position, fields.
std::size_t record_size(const tile_plan& p) {
  std::size_t s = 8 + 8 + 12;
  for (const auto& f : p.fields) s += size_of(f.type);
  return s;
}

/// An empty cloud with the plan's origin and fields (whole ranges set), room for n points.
point_cloud empty_cloud(const tile_plan& p, std::size_t n) {
  point_cloud c;
  c.set_origin(p.origin);
  c.resize(n);
  for (const auto& f : p.fields) c.add_field(f.name, column(f.type, n)).whole_range = f.range;
  return c;
}

/// Points [i, i + n) of `from` (positions and field bytes) into [j, j + n)
/// of `to`, a cloud with the same fields.
void copy_points(const point_cloud& from, std::size_t i, point_cloud& to, std::size_t j, std::size_t n = 1) {
  std::copy_n(from.position(i), 3 * n, to.positions().data() + 3 * j);
  for (std::size_t f = 0; f < from.fields().size(); ++f) {
    const std::size_t w = size_of(from.fields()[f].type());
    std::memcpy(to.fields()[f].values.bytes() + w * j, from.fields()[f].values.bytes() + w * i, w * n);
  }
}

/// The fields of a chunk as (bytes, width) pairs, for append_record().
using field_bytes = std::vector<std::pair<const unsigned char*, std::size_t>>;
field_bytes bytes_of(const point_cloud& c) {
  field_bytes out;
  for (const auto& f : c.fields()) out.push_back({f.values.bytes(), size_of(f.type())});
  return out;
}

/// Appends point i of a chunk (positions `xyz`, fields `fields`) as a record
/// of `size` bytes to `out`.
void append_record(std::string& out, std::size_t size, std::uint64_t index, std::uint64_t file_index, const float* xyz,
                   const field_bytes& fields, std::size_t i) {
  const std::size_t at = out.size();
  if (out.capacity() < at + size) out.reserve(std::max(2 * out.capacity(), at + size));
  out.resize(at + size);
  char* p = out.data() + at;
  std::memcpy(p, &index, 8);
  std::memcpy(p + 8, &file_index, 8);
  std::memcpy(p + 16, xyz + 3 * i, 12);
  p += 28;
  for (const auto& [bytes, w] : fields) {
    std::memcpy(p, bytes + w * i, w);
    p += w;
  }
}
void append_record(std::string& out, std::uint64_t index, std::uint64_t file_index, const point_cloud& c,
                   std::size_t i) {
  std::size_t size = 28;
  const field_bytes fields = bytes_of(c);
  for (const auto& f : fields) size += f.second;
  append_record(out, size, index, file_index, c.positions().data(), fields, i);
}

/// Decodes n records at `p` into points [at, at + n) of `c` and the index arrays.
void decode_records(const char* p, std::size_t n, point_cloud& c, std::size_t at, std::uint64_t* index,
                    std::uint64_t* file_index) {
  for (std::size_t i = 0; i < n; ++i) {
    std::memcpy(index + i, p, 8);
    std::memcpy(file_index + i, p + 8, 8);
    std::memcpy(c.positions().data() + 3 * (at + i), p + 16, 12);
    p += 28;
    for (auto& f : c.fields()) {
      const std::size_t w = size_of(f.type());
      std::memcpy(f.values.bytes() + w * (at + i), p, w);
      p += w;
    }
  }
}

/// Reads a whole file (a tile cache or a part).
std::string slurp(const std::string& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) fail(path, "cannot read its size: " + ec.message());
  std::string out(static_cast<std::size_t>(size), '\0');
  if (std::fread(out.data(), 1, out.size(), f.get()) != out.size()) fail(path, "cannot read it");
  return out;
}

/// What the first pass learns.
struct scan_result {
  std::uint64_t file_points = 0, finite_points = 0;
  std::map<std::string, std::pair<value_range, bool>> ranges;  // seen in every chunk?
  std::size_t chunks = 0;
};

void scan_chunk(const point_cloud& c, scan_result& s) {
  s.file_points += c.size();
  std::vector<std::uint8_t> fin(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    fin[i] = finite3(c.position(i));
    s.finite_points += fin[i];
  }
  std::map<std::string, bool> here;
  for (const field& f : c.fields()) {
    here[f.name] = true;
    value_range r{0, 0};
    bool any = false;
    f.values.visit([&](const auto* v, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i) {
        if (!fin[i]) continue;
        const double x = static_cast<double>(v[i]);
        r.lo = any ? std::min(r.lo, x) : x;
        r.hi = any ? std::max(r.hi, x) : x;
        any = true;
      }
    });
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

/// Estimated bytes a tile of n points takes while it is detected: its cache
/// records, its cloud, the detection (about 90 bytes a point for ced6d on
/// dense clouds: docs/BENCHMARKS.md), and its keypoints.
double tile_bytes_per_point(const tile_plan& p) {
  return 2.0 * double(record_size(p)) + 100.0 + 8.0 * double(p.fields.size());
}
constexpr double fixed_overhead = 200.0 * (1 << 20);  // chunks, cache buffers, the program

/// The largest tile size whose densest tile fits in `limit` bytes, from a
/// histogram of the points (one more pass).
double size_for_memory(io::point_stream& s, const tile_plan& p, const double lo[3], const double hi[3],
                       const tiled_progress& progress) {
  const double limit = double(p.request.memory_limit);
  const double per_point = tile_bytes_per_point(p);
  if (limit <= fixed_overhead + per_point * 1000)
    throw std::invalid_argument("--memory-limit " + std::to_string(p.request.memory_limit) +
                                " bytes is too small: a run needs about " +
                                std::to_string(std::uint64_t(fixed_overhead / (1 << 20))) + " MiB besides its tiles");
  // Larger tiles would fit but run slower: a whole 100 M-point run takes 1.4
  // M points a second, tiles of 8 M 1.6 M, tiles of 0.3 M 2.5 M (SCALE.md).
  const double max_fitting = (limit - fixed_overhead) / per_point;
  const double max_points = std::min(max_fitting, 2e6);
  const double halo = exact_halo(halo_params(p.request), 0);
  // Cells of the histogram: a quarter of the halo or more, at most 2^22.
  double cell = halo / 4;
  std::uint64_t dims[3];
  for (;;) {
    long double total = 1;
    for (int k = 0; k < 3; ++k) {
      dims[k] = std::uint64_t(std::floor((hi[k] - lo[k]) / cell)) + 1;
      total *= dims[k];
    }
    if (total <= (1 << 22)) break;
    cell *= 1.25;
  }
  std::vector<std::uint64_t> hist(dims[0] * dims[1] * dims[2], 0);
  s.rewind();
  std::uint64_t done = 0;
  for_each_chunk(s, p.origin, [&](const point_cloud& c) {
    for (std::size_t i = 0; i < c.size(); ++i) {
      const float* q = c.position(i);
      if (!finite3(q)) continue;
      std::uint64_t a[3];
      for (int k = 0; k < 3; ++k) {
        const double v = std::floor((double(q[k]) - lo[k]) / cell);
        a[k] = std::uint64_t(std::min(std::max(v, 0.0), double(dims[k] - 1)));
      }
      ++hist[(a[2] * dims[1] + a[1]) * dims[0] + a[0]];
    }
    done += c.size();
    if (progress)
      progress("counting points per area", double(done) / double(std::max<std::uint64_t>(1, p.file_points)));
  });
  // Summed-volume table for box counts.
  const std::uint64_t X = dims[0] + 1, Y = dims[1] + 1, Z = dims[2] + 1;
  std::vector<std::uint64_t> sum(X * Y * Z, 0);
  auto at = [&](std::uint64_t x, std::uint64_t y, std::uint64_t z) -> std::uint64_t& {
    return sum[(z * Y + y) * X + x];
  };
  for (std::uint64_t z = 1; z < Z; ++z)
    for (std::uint64_t y = 1; y < Y; ++y)
      for (std::uint64_t x = 1; x < X; ++x)
        at(x, y, z) = hist[((z - 1) * dims[1] + (y - 1)) * dims[0] + (x - 1)] + at(x - 1, y, z) + at(x, y - 1, z) +
                      at(x, y, z - 1) - at(x - 1, y - 1, z) - at(x - 1, y, z - 1) - at(x, y - 1, z - 1) +
                      at(x - 1, y - 1, z - 1);
  auto box = [&](const std::uint64_t a[3], const std::uint64_t b[3]) {  // cells [a, b)
    return at(b[0], b[1], b[2]) - at(a[0], b[1], b[2]) - at(b[0], a[1], b[2]) - at(b[0], b[1], a[2]) +
           at(a[0], a[1], b[2]) + at(a[0], b[1], a[2]) + at(b[0], a[1], a[2]) - at(a[0], a[1], a[2]);
  };
  // The most points a tile of size `size` reads (cells the box grown by the halo meets).
  auto densest = [&](double size) {
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
            a[k] = std::uint64_t(std::min(std::max(std::floor(x0 / cell), 0.0), double(dims[k])));
            b[k] = std::uint64_t(std::min(std::max(std::floor(x1 / cell) + 1, 0.0), double(dims[k])));
            if (t[k] + 1 == n[k]) b[k] = dims[k];
          }
          worst = std::max(worst, box(a, b));
        }
    return double(worst);
  };
  double extent = 0;
  for (int k = 0; k < 3; ++k) extent = std::max(extent, hi[k] - lo[k]);
  // The largest size whose densest tile reads at most `most` points, or 0.
  auto largest = [&](double most) {
    double size = std::max(extent, cell) * 1.0001;
    if (densest(size) <= most) return size;
    // Halve until it fits, then search between the last two sizes.
    double big = size;
    while (size > cell) {
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
  };
  // Tiles of at most 2 M points, which run fastest, unless that makes them
  // narrower than 8 halos (then each point is read too many times): then as
  // large as fits, up to 8 halos.
  double size = largest(max_points);
  if (size < 8 * halo) {
    const double fitting = largest(max_fitting);
    size = fitting == 0 ? 0 : std::min(fitting, std::max(size, 8 * halo));
  }
  if (size == 0)
    throw std::invalid_argument(
        "--memory-limit " + std::to_string(p.request.memory_limit) +
        " bytes is too small for this cloud: its densest area needs about " +
        std::to_string(std::uint64_t((densest(cell) * per_point + fixed_overhead) / (1 << 20))) +
        " MiB even with the smallest tiles");
  return size;
}

/// Plans without the tiles' counts (run_tiled counts them while it fills
/// its cache; plan_tiles in a pass of its own). Leaves `s` rewound.
tile_plan plan_grid(const tiled_request& request, io::point_stream& s, const tiled_progress& progress) {
  tile_plan p;
  p.request = request;
  validate(request.params);
  if (request.memory_limit == 0 && (!(request.tile_size > 0) || !std::isfinite(request.tile_size)))
    throw std::invalid_argument("tile size must be a positive number of metres, got " +
                                std::to_string(request.tile_size));
  if (request.memory_limit > 0 && request.tile_size > 0)
    throw std::invalid_argument("give a tile size or a memory limit, not both");
  modalities_of(request.modalities);  // bad specs fail before the file is read
  p.fingerprint = fingerprint_of(request.input, p.input_bytes);
  p.details = s.details();
  p.streamed = s.streaming();
  // Pass 1: counts, field ranges, the origin and bounds.
  scan_result scan;
  for_each_chunk(s, {0, 0, 0}, [&](const point_cloud& c) {
    scan_chunk(c, scan);
    if (progress)
      progress("reading (pass 1: bounds and ranges)",
               s.declared_points() ? double(scan.file_points) / double(s.declared_points()) : 0.0);
  });
  p.file_points = scan.file_points;
  p.finite_points = scan.finite_points;
  if (p.finite_points == 0) fail(request.input, "the cloud has no (finite) points");
  if (p.finite_points > std::numeric_limits<std::uint32_t>::max())
    fail(request.input,
         "more than 2^32-1 finite points: a tile plan indexes points with 32 bits in each tile, "
         "but the whole file's indices must fit the outputs' too (split the file)");
  p.origin = s.origin();
  double lo[3], hi[3];
  s.bounds(lo, hi);
  // The file's own fields, as every chunk has them from now on.
  s.rewind();
  point_cloud probe;
  s.read(1, p.origin, probe);
  s.rewind();
  for (const field& f : probe.fields()) {
    const auto it = scan.ranges.find(f.name);
    p.fields.push_back({f.name, f.type(), it != scan.ranges.end() ? it->second.first : value_range{0, 0}});
  }
  if (p.request.modalities.empty()) p.request.modalities = preset_specs(probe.has_rgb() ? "ced6d" : "ced3d");
  {  // the modalities find their fields (an error now, not in every tile)
    point_cloud one = empty_cloud(p, 1);
    for (const auto& m : modalities_of(p.request.modalities)) m.bind(one, p.request.params);
  }
  double plo[3], phi[3];
  for (int k = 0; k < 3; ++k) {
    plo[k] = lo[k] - p.origin[std::size_t(k)];
    phi[k] = hi[k] - p.origin[std::size_t(k)];
  }
  const double size = request.memory_limit > 0 ? size_for_memory(s, p, plo, phi, progress) : request.tile_size;
  s.rewind();
  p.grid = make_tile_grid(plo, phi, size, halo_params(request));
  return p;
}

/// Counts per tile, from the points of one chunk.
struct tile_counter {
  bool dense;
  std::vector<std::uint64_t> core_v, all_v;
  std::unordered_map<std::uint64_t, std::pair<std::uint64_t, std::uint64_t>> sparse;
  explicit tile_counter(std::uint64_t tiles) : dense(tiles <= (1u << 20)) {
    if (dense) {
      core_v.assign(tiles, 0);
      all_v.assign(tiles, 0);
    }
  }
  void core(std::uint64_t t) { dense ? ++core_v[t] : ++sparse[t].first; }
  void near(std::uint64_t t) { dense ? ++all_v[t] : ++sparse[t].second; }
  std::vector<tile_entry> entries() const {
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
};

/// Buffers of tile-cache records, written out to one file a tile when they
/// hold more than `budget` bytes.
class cache_writer {
 public:
  cache_writer(std::string dir, std::size_t budget) : m_dir(std::move(dir)), m_budget(budget) {}
  std::string& buffer(std::uint64_t t) { return m_buffers[t]; }
  void maybe_flush(std::size_t bytes_added) {
    m_held += bytes_added;
    if (m_held > m_budget) flush();
  }
  void flush() {
    for (auto& [t, b] : m_buffers) {
      if (b.empty()) continue;
      const std::string path = file(t);
      std::FILE* f = std::fopen(path.c_str(), "ab");
      if (!f) fail(path, std::string("cannot write the tile cache: ") + std::strerror(errno));
      const bool ok = std::fwrite(b.data(), 1, b.size(), f) == b.size();
      if (std::fclose(f) != 0 || !ok) fail(path, "cannot write the tile cache (disk full?)");
      // Released, so that the buffers of many tiles never hold more than the
      // budget between them (their memory is reused, not faulted in anew:
      // keep_freed_memory()).
      std::string().swap(b);
    }
    m_held = 0;
  }
  std::string file(std::uint64_t t) const { return m_dir + "/t" + std::to_string(t) + ".bin"; }

 private:
  std::string m_dir;
  std::size_t m_budget, m_held = 0;
  std::unordered_map<std::uint64_t, std::string> m_buffers;
};

/// Points per tile (a pass over `s`, which is left rewound), and the hash
/// of every decoded point into `content` when given.
std::vector<tile_entry> count_tiles(io::point_stream& s, const tile_plan& p, const tiled_progress& progress,
                                    std::uint64_t* content) {
  tile_counter counts(p.grid.count());
  std::vector<std::uint64_t> near;
  std::uint64_t done = 0;
  for_each_chunk(s, p.origin, [&](const point_cloud& c) {
    if (content) *content = hash_chunk(c, *content);
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (!finite3(c.position(i))) continue;
      counts.core(p.grid.tile_of(c.position(i)));
      p.grid.tiles_near(c.position(i), near);
      for (std::uint64_t t : near) counts.near(t);
    }
    done += c.size();
    if (progress) progress("reading (pass 2: points per tile)", double(done) / double(p.file_points));
  });
  s.rewind();
  return counts.entries();
}

/// About how many tiles read a point: the tile and its halo, per axis, at
/// most the grid's extent.
double tiles_per_point(const tile_grid& g) {
  double n = 1;
  for (std::size_t k = 0; k < 3; ++k) n *= std::min<double>(g.dims[k], (g.size + 2 * g.halo) / g.size);
  return n;
}

/// Which tiles own points (all of them until told).
class tile_owners {
 public:
  tile_owners() = default;
  explicit tile_owners(const tile_plan& p) : m_all(false) {
    for (const auto& t : p.tiles) m_ids.push_back(t.id);  // ascending
  }
  bool owns(std::uint64_t t) const { return m_all || std::binary_search(m_ids.begin(), m_ids.end(), t); }

 private:
  bool m_all = true;
  std::vector<std::uint64_t> m_ids;
};

tile_points points_from_records(const tile_plan& p, std::uint64_t id, const std::string& bytes,
                                const std::string& name) {
  const std::size_t rs = record_size(p);
  if (bytes.size() % rs != 0) fail(name, "truncated tile cache (" + std::to_string(bytes.size()) + " bytes)");
  const std::size_t n = bytes.size() / rs;
  tile_points t;
  t.tile = id;
  t.cloud = empty_cloud(p, n);
  t.index.resize(n);
  t.file_index.resize(n);
  decode_records(bytes.data(), n, t.cloud, 0, t.index.data(), t.file_index.data());
  return t;
}

}  // namespace

// ------------------------------------------------------------------ plan

std::string tile_plan::to_json() const {
  nlohmann::json j;
  j["ced_tile_plan"] = plan_version;
  j["request"] = request_json(request);
  j["input"] = {{"details", details},    {"bytes", input_bytes},           {"fingerprint", fingerprint},
                {"points", file_points}, {"finite_points", finite_points}, {"streamed", streamed}};
  if (!content.empty()) j["input"]["content"] = content;
  j["origin"] = origin;
  j["grid"] = {{"lo", grid.lo}, {"size", grid.size}, {"dims", grid.dims}, {"halo", grid.halo}};
  auto& fl = j["fields"] = nlohmann::json::array();
  for (const auto& f : fields)
    fl.push_back({{"name", f.name}, {"type", std::string(name_of(f.type))}, {"lo", f.range.lo}, {"hi", f.range.hi}});
  auto& tl = j["tiles"] = nlohmann::json::array();
  for (const auto& t : tiles) tl.push_back({t.id, t.core_points, t.points});
  return j.dump(1) + "\n";
}

tile_plan tile_plan::from_json(const std::string& text, const std::string& name) {
  tile_plan p;
  try {
    const auto j = nlohmann::json::parse(text);
    if (!j.is_object() || !j.contains("ced_tile_plan")) fail(name, "not a ced tile plan (no 'ced_tile_plan' key)");
    if (j.at("ced_tile_plan").get<int>() != plan_version)
      fail(name, "tile plan version " + j.at("ced_tile_plan").dump() + ", this ced reads version " +
                     std::to_string(plan_version));
    p.request = request_from_json(j.at("request"));
    const auto& in = j.at("input");
    p.details = in.at("details").get<std::string>();
    p.input_bytes = count_of<std::uint64_t>(in, "bytes");
    p.fingerprint = in.at("fingerprint").get<std::string>();
    p.content = in.value("content", std::string());
    p.file_points = count_of<std::uint64_t>(in, "points");
    p.finite_points = count_of<std::uint64_t>(in, "finite_points");
    p.streamed = in.at("streamed").get<bool>();
    if (p.finite_points == 0 || p.finite_points > p.file_points ||
        p.finite_points > std::numeric_limits<std::uint32_t>::max())
      fail(name, "invalid tile plan: its point counts are inconsistent");
    p.origin = point_of(j, "origin");
    const auto& g = j.at("grid");
    p.grid.lo = point_of(g, "lo");
    p.grid.size = number_of(g, "size");
    const auto& dims = g.at("dims");
    if (!dims.is_array() || dims.size() != 3) fail(name, "invalid tile plan: the grid's 'dims' must be 3 counts");
    for (std::size_t k = 0; k < 3; ++k) p.grid.dims[k] = whole_number<std::uint32_t>(dims.at(k), "the grid's dims");
    p.grid.halo = number_of(g, "halo");
    if (!(p.grid.size > 0) || !(p.grid.halo >= 0) ||
        p.grid.dims[0] * std::uint64_t(p.grid.dims[1]) * p.grid.dims[2] == 0 ||
        p.grid.count() > (std::uint64_t(1) << 24))
      fail(name, "the tile grid is invalid");
    // The halo makes the tiles exact: at least the one the request needs.
    const double needed = exact_halo(halo_params(p.request), 0);
    if (p.grid.halo < needed)
      fail(name, "invalid tile plan: its halo " + std::to_string(p.grid.halo) + " is less than the " +
                     std::to_string(needed) + " its radii and modalities need (tiles would not be exact)");
    std::set<std::string> names;
    for (const auto& f : j.at("fields")) {
      const plan_field pf{f.at("name").get<std::string>(),
                          type_named(f.at("type").get<std::string>(), name),
                          {number_of(f, "lo"), number_of(f, "hi")}};
      if (pf.name.empty() || !names.insert(pf.name).second || !(pf.range.lo <= pf.range.hi))
        fail(name, "invalid tile plan: field '" + pf.name + "' is unnamed, repeated or has lo > hi");
      p.fields.push_back(pf);
    }
    std::uint64_t owned = 0;
    for (const auto& t : j.at("tiles")) {
      const tile_entry e{whole_number<std::uint64_t>(t.at(0), "a tile's id"),
                         whole_number<std::uint64_t>(t.at(1), "a tile's count"),
                         whole_number<std::uint64_t>(t.at(2), "a tile's count")};
      if (e.id >= p.grid.count() || (!p.tiles.empty() && e.id <= p.tiles.back().id))
        fail(name, "tile " + std::to_string(e.id) + " is out of the grid or out of order");
      if (e.core_points == 0 || e.core_points > e.points || e.points > p.finite_points)
        fail(name, "invalid tile plan: tile " + std::to_string(e.id) + "'s counts are inconsistent");
      owned += e.core_points;
      p.tiles.push_back(e);
    }
    if (owned != p.finite_points)
      fail(name, "invalid tile plan: its tiles own " + std::to_string(owned) + " points, its input has " +
                     std::to_string(p.finite_points) + " finite points");
  } catch (const nlohmann::json::exception& e) {
    fail(name, std::string("malformed tile plan: ") + e.what());
  } catch (const std::invalid_argument& e) {
    fail(name, std::string("invalid tile plan: ") + e.what());
  }
  return p;
}

tile_plan tile_plan::load(const std::string& path) { return from_json(slurp(path), path); }

std::string tile_plan::digest() const {
  const std::string j = to_json();
  return hex(fnv1a(j.data(), j.size()));
}

const tile_entry& tile_plan::tile(std::uint64_t id) const {
  const auto it =
      std::lower_bound(tiles.begin(), tiles.end(), id, [](const tile_entry& e, std::uint64_t v) { return e.id < v; });
  if (it == tiles.end() || it->id != id)
    throw std::invalid_argument("tile " + std::to_string(id) +
                                " owns no points in this plan (its tiles: " + std::to_string(tiles.size()) + ", ids " +
                                (tiles.empty()
                                     ? std::string("none")
                                     : std::to_string(tiles.front().id) + ".." + std::to_string(tiles.back().id)) +
                                ")");
  return *it;
}

tile_plan plan_tiles(const tiled_request& request, const tiled_progress& progress) {
  auto s = io::open_point_stream(request.input, request.read);
  tile_plan p = plan_grid(request, *s, progress);
  std::uint64_t content = 0;
  p.tiles = count_tiles(*s, p, progress, &content);  // pass 2
  p.content = hex(content);
  return p;
}

void check_plan_input(const tile_plan& plan) {
  std::uint64_t bytes = 0;
  const std::string fp = fingerprint_of(plan.request.input, bytes);
  if (bytes != plan.input_bytes || fp != plan.fingerprint)
    fail(plan.request.input, "this is not the file the plan was made for (" + std::to_string(bytes) + " bytes, " +
                                 "fingerprint " + fp + "; the plan says " + std::to_string(plan.input_bytes) +
                                 " bytes, fingerprint " + plan.fingerprint + "): make a new plan");
}

tile_points read_tile(const tile_plan& plan, std::uint64_t id) {
  plan.tile(id);  // throws for a tile that owns no points
  check_plan_input(plan);
  auto s = io::open_point_stream(plan.request.input, plan.request.read);
  // A pass to learn the whole file's fields (LAS flags), then the tile's points.
  for_each_chunk(*s, {0, 0, 0}, [](const point_cloud&) {});
  s->rewind();
  const auto coords = plan.grid.coords(id);
  std::string records;
  std::uint64_t file_index = 0, index = 0, content = 0, core = 0;
  for_each_chunk(*s, plan.origin, [&](const point_cloud& c) {
    if (c.fields().size() != plan.fields.size())
      fail(plan.request.input, "its fields differ from the plan's: make a new plan");
    if (!plan.content.empty()) content = hash_chunk(c, content);
    for (std::size_t i = 0; i < c.size(); ++i, ++file_index) {
      if (!finite3(c.position(i))) continue;
      if (near_tile(plan.grid, coords, c.position(i))) {
        append_record(records, index, file_index, c, i);
        core += plan.grid.tile_of(c.position(i)) == id;
      }
      ++index;
    }
  });
  const tile_entry& e = plan.tile(id);
  auto changed = [&](const std::string& what) {
    fail(plan.request.input, "the file changed since the plan was made (" + what + "): make a new plan");
  };
  if (file_index != plan.file_points || index != plan.finite_points)
    changed(std::to_string(file_index) + " points, " + std::to_string(index) + " finite; the plan says " +
            std::to_string(plan.file_points) + ", " + std::to_string(plan.finite_points));
  if (!plan.content.empty() && hex(content) != plan.content)
    changed("its decoded points hash to " + hex(content) + ", the plan's to " + plan.content);
  tile_points pts = points_from_records(plan, id, records, plan.request.input);
  if (core != e.core_points || pts.cloud.size() != e.points)
    changed("tile " + std::to_string(id) + " reads " + std::to_string(pts.cloud.size()) + " points and owns " +
            std::to_string(core) + "; the plan says " + std::to_string(e.points) + " and " +
            std::to_string(e.core_points));
  return pts;
}

// ------------------------------------------------------------------ tiles

tile_part detect_tile(const tile_plan& plan, const tile_points& points, unsigned threads) {
  const auto t0 = std::chrono::steady_clock::now();
  tile_part part;
  part.tile = points.tile;
  part.plan = plan.digest();
  const auto modalities = modalities_of(plan.request.modalities);
  detect_params params = plan.request.params;
  params.threads = threads;
  const std::size_t m = modalities.size();
  name_modalities(plan, modalities, part);
  part.saliency.assign(m, {});
  part.candidates.assign(m, 0);
  part.keypoints = empty_cloud(plan, 0);
  if (points.cloud.empty()) return part;
  const detection_result r = detect(points.cloud, params, modalities);
  std::vector<std::uint32_t> kept;
  for (std::size_t i = 0; i < points.cloud.size(); ++i) {
    if (plan.grid.tile_of(points.cloud.position(i)) != points.tile) continue;
    for (std::size_t k = 0; k < m; ++k) part.candidates[k] += r.saliency[k][i] >= r.thresholds[k];
    part.any_candidates += r.candidate[i] != 0;
  }
  for (std::uint32_t k : core_keypoints(plan.grid, points.tile, points.cloud, r)) kept.push_back(k);
  part.keypoints = empty_cloud(plan, kept.size());
  for (std::size_t j = 0; j < kept.size(); ++j) {
    const std::uint32_t i = kept[j];
    part.index.push_back(points.index[i]);
    part.file_index.push_back(points.file_index[i]);
    copy_points(points.cloud, i, part.keypoints, j);
    for (std::size_t k = 0; k < m; ++k) part.saliency[k].push_back(r.saliency[k][i]);
  }
  part.detect_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return part;
}

namespace {
/// write_part() with the plan's digest already known (a digest formats the
/// whole plan: of thousands of tiles, a millisecond).
void write_part_as(const std::string& path, const tile_plan& plan, const std::string& digest, const tile_part& part) {
  std::string out(part_magic, 8);
  // A part of another plan would be stamped with this plan's digest.
  if (part.plan != digest)
    throw std::invalid_argument("the part of tile " + std::to_string(part.tile) +
                                " belongs to another plan (plan digest " +
                                (part.plan.empty() ? std::string("none") : part.plan) + ", `plan` has " + digest + ")");
  out += digest;
  auto put = [&](const auto& v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(part.tile);
  put(std::uint64_t(part.index.size()));
  put(std::uint32_t(part.saliency.size()));
  put(std::uint32_t(plan.fields.size()));
  for (std::uint64_t c : part.candidates) put(c);
  put(part.any_candidates);
  put(part.detect_ms);
  for (std::size_t j = 0; j < part.index.size(); ++j) {
    append_record(out, part.index[j], part.file_index[j], part.keypoints, j);
    for (const auto& s : part.saliency) put(s[j]);
  }
  io::atomic_output_file f(path);
  f.stream().write(out.data(), static_cast<std::streamsize>(out.size()));
  f.commit();
}
}  // namespace

void write_part(const std::string& path, const tile_plan& plan, const tile_part& part) {
  write_part_as(path, plan, plan.digest(), part);
}

namespace {

/// A part file read a piece at a time: its header at once, then its records
/// in order through a buffer of `buffer` bytes (the file is opened again for
/// each refill, so that thousands of parts need no open file each).
class part_reader {
 public:
  /// `digest`: plan.digest(), computed once by the caller for all its parts.
  part_reader(const std::string& path, const tile_plan& plan, const std::string& digest) : m_path(path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, std::string("cannot open: ") + std::strerror(errno));
    std::error_code ec;
    const std::uint64_t size = fs::file_size(path, ec);
    if (ec) fail(path, "cannot read its size: " + ec.message());
    const auto modalities = modalities_of(plan.request.modalities);
    const std::size_t m = modalities.size();
    // magic, digest, tile, keypoints, modalities, fields, candidates, any, ms
    const std::size_t head = 8 + digest.size() + 8 + 8 + 4 + 4 + 8 * m + 8 + 8;
    std::string b(std::min<std::uint64_t>(size, head), '\0');
    in.read(b.data(), static_cast<std::streamsize>(b.size()));
    if (!in) fail(path, "cannot read it");
    if (b.size() < 8 + digest.size()) fail(path, "truncated tile part (" + std::to_string(size) + " bytes)");
    if (std::memcmp(b.data(), part_magic, 8) != 0) fail(path, "not a ced tile part");
    if (b.compare(8, digest.size(), digest) != 0)
      fail(path, "this part belongs to another plan (plan digest " + b.substr(8, digest.size()) + ", expected " +
                     digest + ")");
    if (b.size() < head) fail(path, "truncated tile part (" + std::to_string(size) + " bytes)");
    std::size_t at = 8 + digest.size();
    auto get = [&](auto& v) {
      std::memcpy(&v, b.data() + at, sizeof v);
      at += sizeof v;
    };
    std::uint32_t nm = 0, nf = 0;
    totals.plan = digest;
    get(totals.tile);
    get(m_count);
    get(nm);
    get(nf);
    if (nm != m || nf != plan.fields.size()) fail(path, "its modalities or fields differ from the plan's");
    name_modalities(plan, modalities, totals);
    totals.candidates.resize(m);
    std::memcpy(totals.candidates.data(), b.data() + at, 8 * m);
    at += 8 * m;
    get(totals.any_candidates);
    get(totals.detect_ms);
    totals.keypoints = empty_cloud(plan, 0);
    totals.saliency.assign(m, {});
    m_record = record_size(plan) + 4 * m;
    m_offset = head;
    if (m_count > (size - head) / m_record || size - head != m_count * m_record)
      fail(path, "truncated or oversized tile part: " + std::to_string(m_count) + " keypoints declared");
    m_left = m_count;
  }

  /// The part without its keypoints: tile, names, thresholds, counts.
  tile_part totals;
  std::uint64_t count() const noexcept { return m_count; }
  std::size_t record_bytes() const noexcept { return m_record; }

  /// The next record (m_record bytes), nullptr after the last; `buffer`
  /// bytes are read at a time.
  const char* next(std::size_t buffer) {
    if (m_at == m_buf.size()) {
      if (m_left == 0) return nullptr;
      const std::uint64_t n = std::min<std::uint64_t>(m_left, std::max<std::size_t>(1, buffer / m_record));
      m_buf.resize(static_cast<std::size_t>(n * m_record));
      std::ifstream in(m_path, std::ios::binary);
      in.seekg(static_cast<std::streamoff>(m_offset));
      in.read(m_buf.data(), static_cast<std::streamsize>(m_buf.size()));
      if (!in) fail(m_path, "cannot read it (was it changed during the merge?)");
      m_offset += m_buf.size();
      m_left -= n;
      m_at = 0;
    }
    const char* r = m_buf.data() + m_at;
    m_at += m_record;
    return r;
  }
  /// Drops the buffer (after the last record).
  void release() { std::string().swap(m_buf), m_at = 0; }

 private:
  std::string m_path;
  std::uint64_t m_count = 0, m_left = 0, m_offset = 0;
  std::size_t m_record = 0;
  std::string m_buf;
  std::size_t m_at = 0;
};

/// Appends a record of a part (point, then one saliency a modality) to `p`'s point j.
void decode_part_record(const char* r, tile_part& p, std::size_t j) {
  decode_records(r, 1, p.keypoints, j, p.index.data() + j, p.file_index.data() + j);
  r += 28;
  for (const auto& f : p.keypoints.fields()) r += size_of(f.type());
  for (auto& s : p.saliency) {
    std::memcpy(s.data() + j, r, 4);
    r += 4;
  }
}

/// Sizes p's arrays for n keypoints.
void resize_part(tile_part& p, const tile_plan& plan, std::size_t n) {
  p.keypoints = empty_cloud(plan, n);
  p.index.resize(n);
  p.file_index.resize(n);
  for (auto& s : p.saliency) s.resize(n);
}

/// Checks one keypoint of tile `tile`'s part as a merge takes it: indices in
/// range and after the previous keypoint's (`last`, none yet: UINT64_MAX),
/// and the position in the tile's core. io_error naming `where` otherwise.
void check_keypoint(const tile_plan& plan, const std::string& where, std::uint64_t tile, std::uint64_t index,
                    std::uint64_t file_index, const float* xyz, std::uint64_t& last) {
  auto bad = [&](const std::string& what) {
    fail(where, "not a whole part of this plan: keypoint " + std::to_string(index) + " " + what);
  };
  if (index >= plan.finite_points || file_index >= plan.file_points)
    bad("is out of the input's range (" + std::to_string(plan.finite_points) + " finite points)");
  if (last != std::numeric_limits<std::uint64_t>::max() && index <= last)
    bad(index == last ? "is given twice" : "comes after keypoint " + std::to_string(last));
  if (file_index < index) bad("has a file index below its index");
  if (!finite3(xyz) || plan.grid.tile_of(xyz) != tile) bad("lies outside tile " + std::to_string(tile) + "'s core");
  last = index;
}

/// Throws io_error naming the tiles of the plan that own points and have
/// no part, and a tile given twice.
void check_complete(const tile_plan& plan, const std::vector<std::uint64_t>& tiles) {
  std::map<std::uint64_t, std::size_t> seen;
  for (std::uint64_t t : tiles) {
    plan.tile(t);  // a tile of the plan
    if (++seen[t] > 1) throw io::io_error("tile " + std::to_string(t) + " is given twice");
  }
  std::vector<std::uint64_t> missing;
  for (const auto& t : plan.tiles)
    if (!seen.count(t.id)) missing.push_back(t.id);
  if (!missing.empty()) {
    std::string list;
    for (std::size_t i = 0; i < missing.size() && i < 10; ++i) list += (i ? ", " : "") + std::to_string(missing[i]);
    if (missing.size() > 10) list += ", ...";
    throw io::io_error(std::to_string(missing.size()) + " of the plan's " + std::to_string(plan.tiles.size()) +
                       " tiles have no part: " + list);
  }
}

/// A merge's part before any part is added: the plan's modality names and
/// thresholds, no candidates, no keypoints.
tile_part empty_merge(const tile_plan& plan) {
  tile_part out;
  out.plan = plan.digest();
  const auto modalities = modalities_of(plan.request.modalities);
  name_modalities(plan, modalities, out);
  out.candidates.assign(modalities.size(), 0);
  out.saliency.assign(modalities.size(), {});
  out.keypoints = empty_cloud(plan, 0);
  return out;
}

}  // namespace

tile_part read_part(const std::string& path, const tile_plan& plan) {
  part_reader r(path, plan, plan.digest());
  tile_part p = std::move(r.totals);
  resize_part(p, plan, static_cast<std::size_t>(r.count()));
  const std::size_t buffer = std::size_t(8) << 20;
  for (std::size_t j = 0; j < p.index.size(); ++j) decode_part_record(r.next(buffer), p, j);
  return p;
}

void merge_part_files(const tile_plan& plan, const std::vector<std::string>& paths, const merge_sink& sink,
                      std::size_t memory) {
  const std::string digest = plan.digest();
  std::vector<part_reader> readers;
  readers.reserve(paths.size());
  std::vector<std::uint64_t> tiles;
  for (const auto& path : paths) {
    readers.emplace_back(path, plan, digest);
    tiles.push_back(readers.back().totals.tile);
  }
  check_complete(plan, tiles);
  tile_part totals = empty_merge(plan);
  const std::size_t m = totals.names.size();
  std::uint64_t count = 0;
  for (const auto& r : readers) {
    for (std::size_t k = 0; k < m; ++k) totals.candidates[k] += r.totals.candidates[k];
    totals.any_candidates += r.totals.any_candidates;
    totals.detect_ms += r.totals.detect_ms;
    count += r.count();
  }
  for (auto& f : totals.keypoints.fields()) f.whole_range.reset();
  if (sink.begin) sink.begin(totals, count);
  // A k-way merge by index (the parts' are ascending and disjoint): half the
  // memory for the parts' buffers, half for the chunk handed to the sink.
  const std::size_t record = record_size(plan) + 4 * m;
  const std::size_t buffer = std::max<std::size_t>(record, memory / 2 / std::max<std::size_t>(1, readers.size()));
  const std::size_t chunk_cap = std::max<std::size_t>(1, memory / 2 / record);
  using head = std::pair<std::uint64_t, std::pair<std::size_t, const char*>>;  // index, (part, record)
  std::priority_queue<head, std::vector<head>, std::greater<>> heap;
  auto push = [&](std::size_t i) {
    if (const char* r = readers[i].next(buffer)) {
      std::uint64_t index = 0;
      std::memcpy(&index, r, 8);
      heap.push({index, {i, r}});
    } else {
      readers[i].release();
    }
  };
  for (std::size_t i = 0; i < readers.size(); ++i) push(i);
  tile_part chunk = totals;
  std::uint64_t emitted = 0, last = std::numeric_limits<std::uint64_t>::max();
  while (emitted < count) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk_cap, count - emitted));
    resize_part(chunk, plan, n);
    for (auto& f : chunk.keypoints.fields()) f.whole_range.reset();
    for (std::size_t j = 0; j < n; ++j) {
      const auto [index, where] = heap.top();
      heap.pop();
      (void)index;
      decode_part_record(where.second, chunk, j);
      const std::size_t r = where.first;
      check_keypoint(plan, paths[r], readers[r].totals.tile, chunk.index[j], chunk.file_index[j],
                     chunk.keypoints.position(j), last);
      push(r);
    }
    emitted += n;
    if (sink.chunk) sink.chunk(chunk);
  }
}

tile_part merge_parts(const tile_plan& plan, std::vector<tile_part> parts) {
  std::vector<std::uint64_t> tiles;
  for (const auto& p : parts) tiles.push_back(p.tile);
  tile_part out = empty_merge(plan);
  const std::size_t m = out.names.size();
  for (const auto& p : parts) {
    const std::string where = "the part of tile " + std::to_string(p.tile);
    if (p.plan != out.plan)
      fail(where, "it belongs to another plan (plan digest " + (p.plan.empty() ? std::string("none") : p.plan) +
                      ", expected " + out.plan + ")");
    const std::size_t n = p.index.size();
    bool whole = p.names == out.names && p.saliency.size() == m && p.candidates.size() == m &&
                 p.file_index.size() == n && p.keypoints.size() == n &&
                 p.keypoints.fields().size() == plan.fields.size();
    for (std::size_t k = 0; whole && k < m; ++k) whole = p.saliency[k].size() == n;
    for (std::size_t f = 0; whole && f < plan.fields.size(); ++f)
      whole =
          p.keypoints.fields()[f].name == plan.fields[f].name && p.keypoints.fields()[f].type() == plan.fields[f].type;
    if (!whole) fail(where, "its modalities, fields or array sizes differ from the plan's");
    std::uint64_t last = std::numeric_limits<std::uint64_t>::max();
    for (std::size_t j = 0; j < n; ++j)
      check_keypoint(plan, where, p.tile, p.index[j], p.file_index[j], p.keypoints.position(j), last);
  }
  check_complete(plan, tiles);
  // Keypoints of all parts, by index (the parts' are disjoint).
  std::vector<std::pair<std::uint64_t, std::pair<std::size_t, std::size_t>>> order;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    for (std::size_t k = 0; k < m; ++k) out.candidates[k] += parts[i].candidates[k];
    out.any_candidates += parts[i].any_candidates;
    out.detect_ms += parts[i].detect_ms;
    for (std::size_t j = 0; j < parts[i].index.size(); ++j) order.push_back({parts[i].index[j], {i, j}});
  }
  std::sort(order.begin(), order.end());
  for (std::size_t q = 1; q < order.size(); ++q)
    if (order[q].first == order[q - 1].first)
      fail("the parts of tiles " + std::to_string(parts[order[q - 1].second.first].tile) + " and " +
               std::to_string(parts[order[q].second.first].tile),
           "both have keypoint " + std::to_string(order[q].first) + ": not parts of one plan's run");
  out.keypoints = empty_cloud(plan, order.size());
  out.saliency.assign(m, std::vector<float>(order.size()));
  for (std::size_t q = 0; q < order.size(); ++q) {
    const auto [i, j] = order[q].second;
    const tile_part& p = parts[i];
    out.index.push_back(p.index[j]);
    out.file_index.push_back(p.file_index[j]);
    copy_points(p.keypoints, j, out.keypoints, q);
    for (std::size_t k = 0; k < m; ++k) out.saliency[k][q] = p.saliency[k][j];
  }
  for (auto& f : out.keypoints.fields()) f.whole_range.reset();
  return out;
}

// ------------------------------------------------------------------ work directory

namespace {

/// The marker's text; "created" says whether ced made the directory (then
/// it removes the directory too, once empty).
std::string marker_text(bool created) {
  return std::string("ced tiled-run work directory: ced removes its own files here when the run succeeds\n") +
         "created " + (created ? "yes" : "no") + "\n";
}

bool has_marker(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(fs::symlink_status(dir / work_dir_marker, ec));
}

/// A name ced gives a file of its work directory: `base` (plan.json) or
/// t<digits><suffix> when `base` is empty, or the temporary of such a name
/// (io::detail::temporary_name()).
bool ced_file_name(std::string name, const std::string& base, const std::string& suffix) {
  std::string of;
  long pid = 0;
  if (io::detail::parse_temporary_name(name, of, pid)) name = of;
  if (!base.empty()) return name == base;
  if (name.size() < 1 + suffix.size() + 1 || name[0] != 't' ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  const std::string id = name.substr(1, name.size() - 1 - suffix.size());
  return id.find_first_not_of("0123456789") == std::string::npos;
}

/// Removes ced's files (names ced_file_name() accepts) from `dir`, and
/// `dir` itself when it is then empty. Other files stay.
void remove_ced_files(const fs::path& dir, const std::string& base, const std::string& suffix) {
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(dir, ec))) return;
  std::vector<fs::path> ours;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code e2;
    if (fs::is_regular_file(it->symlink_status(e2)) && ced_file_name(it->path().filename().string(), base, suffix))
      ours.push_back(it->path());
  }
  for (const auto& p : ours) fs::remove(p, ec);
  fs::remove(dir, ec);  // only when empty
}

/// Empties ced's cache and parts of a work directory (a run stopped before
/// its plan was written: its cache is incomplete).
void clear_tiles(const fs::path& dir) {
  remove_ced_files(dir / "cache", "", ".bin");
  remove_ced_files(dir / "parts", "", ".part");
}

/// Makes `dir` ced's: creates it (marker "created yes"), or marks an empty
/// directory (marker "created no"), or accepts one that has ced's marker.
/// Anything else is refused, with or without `resume`.
void claim_work_dir(const std::string& work_dir) {
  const fs::path dir(work_dir);
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  bool created = false;
  if (!fs::exists(st)) {
    // Only the last component is created: a mistyped parent is an error.
    if (dir.has_parent_path() && !fs::is_directory(dir.parent_path(), ec))
      throw work_dir_error("work directory '" + work_dir + "': its parent directory does not exist");
    if (!fs::create_directory(dir, ec) || ec)
      fail(work_dir, "cannot create the work directory: " + (ec ? ec.message() : std::string("it appeared meanwhile")));
    created = true;
  } else if (!fs::is_directory(st)) {
    throw work_dir_error("work directory '" + work_dir + "' exists and is not a directory");
  } else if (has_marker(dir)) {
    return;
  } else if (!fs::is_empty(dir, ec) || ec) {
    std::string first;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end && first.empty(); it.increment(ec))
      first = it->path().filename().string();
    throw work_dir_error("work directory '" + work_dir + "' holds files ced did not make (" +
                         (first.empty() ? std::string("it cannot be listed") : "'" + first + "'") +
                         "): ced works only in a new or empty directory, and never deletes what it did not "
                         "create; choose another --work-dir");
  }
  io::write_text_file_atomic((dir / work_dir_marker).string(), marker_text(created));
}

}  // namespace

void remove_work_dir(const std::string& work_dir) noexcept {
  try {
    const fs::path dir(work_dir);
    if (work_dir.empty() || !has_marker(dir)) return;
    std::error_code ec;
    std::string marker;
    try {
      marker = slurp((dir / work_dir_marker).string());
    } catch (const std::exception&) {
    }
    const bool created = marker.find("\ncreated yes\n") != std::string::npos;
    clear_tiles(dir);
    remove_ced_files(dir, "plan.json", "");
    fs::remove(dir / work_dir_marker, ec);
    if (created) fs::remove(dir, ec);  // only when empty: a file someone put there keeps it
  } catch (...) {
  }
}

// ------------------------------------------------------------------ one process

namespace {

/// Passes 1 and 2 of a run without a plan yet: the plan and the tile cache
/// in `dir`, then plan.json. `announced`: the plan was reported already.
tile_plan build_cache(const tiled_request& request, const tiled_run_options& o, const fs::path& dir, bool& announced) {
  const fs::path plan_path = dir / "plan.json", cache = dir / "cache";
  std::error_code ec;
  tile_plan plan;
  fs::create_directories(cache, ec);
  if (ec) fail(cache.string(), "cannot create the tile cache directory: " + ec.message());
  auto s = io::open_point_stream(request.input, request.read);
  plan = plan_grid(request, *s, o.progress);
  // Small tiles under a large halo: a point lands in many tiles, most of
  // which may own none (the air above the ground). Then the tiles are
  // counted first (one more pass), the plan is reported before anything
  // is written, and only tiles that own points are cached.
  tile_owners owners;
  if (tiles_per_point(plan.grid) > 2) {
    plan.tiles = count_tiles(*s, plan, o.progress, nullptr);
    owners = tile_owners(plan);
    if (o.planned) o.planned(plan);
    announced = true;
  }
  // Pass 2: every point into the cache file of each tile that reads it.
  tile_counter counts(plan.grid.count());
  cache_writer writer(cache.string(), std::size_t(64) << 20);
  std::uint64_t file_index = 0, index = 0;
  for_each_chunk(*s, plan.origin, [&](const point_cloud& c) {
    const std::size_t rs = record_size(plan);
    const field_bytes fields = bytes_of(c);
    const tile_grid& g = plan.grid;
    for (std::size_t i = 0; i < c.size(); ++i, ++file_index) {
      const float* q = c.position(i);
      if (!finite3(q)) continue;
      std::int64_t own[3], c0[3], c1[3];
      g.locate(q, own, c0, c1);
      counts.core((std::uint64_t(own[2]) * g.dims[1] + std::uint64_t(own[1])) * g.dims[0] + std::uint64_t(own[0]));
      std::size_t added = 0;
      for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
        for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
          for (std::int64_t x = c0[0]; x <= c1[0]; ++x) {
            const std::uint64_t t = (std::uint64_t(z) * g.dims[1] + std::uint64_t(y)) * g.dims[0] + std::uint64_t(x);
            counts.near(t);
            if (!owners.owns(t)) continue;
            append_record(writer.buffer(t), rs, index, file_index, c.positions().data(), fields, i);
            added += rs;
          }
      writer.maybe_flush(added);  // a point at a time: the buffers never hold much more than their budget
      ++index;
    }
    if (o.progress) o.progress("reading (pass 2: tile cache)", double(file_index) / double(plan.file_points));
  });
  writer.flush();
  plan.tiles = counts.entries();
  io::write_text_file_atomic(plan_path.string(), plan.to_json());
  return plan;
}

}  // namespace

tile_plan prepare_tiled(const tiled_request& request, const tiled_run_options& o) {
  if (o.work_dir.empty()) throw std::invalid_argument("tiled run: no work directory");
  const fs::path dir(o.work_dir), plan_path = dir / "plan.json", parts = dir / "parts";
  std::error_code ec;
  tile_plan plan;
  bool announced = false;
  claim_work_dir(o.work_dir);
  if (fs::exists(plan_path, ec)) {
    if (!o.resume)
      fail(o.work_dir, "holds the tiles of an unfinished run: pass --resume to finish it, or remove the directory");
    plan = tile_plan::from_json(slurp(plan_path.string()), plan_path.string());
    tiled_request asked = request;
    if (asked.modalities.empty()) asked.modalities = plan.request.modalities;
    if (request_json(asked) != request_json(plan.request))
      fail(o.work_dir, "holds the tiles of another run (" + request_json(plan.request).dump() +
                           "): remove it or choose another work directory");
    check_plan_input(plan);
  } else {
    clear_tiles(dir);  // a run stopped before its plan was written: its cache is incomplete
    try {
      plan = build_cache(request, o, dir, announced);
    } catch (...) {
      // Nothing to resume without a plan (a rerun redoes the cache): ced's
      // files go, and the directory when ced made it.
      remove_work_dir(o.work_dir);
      throw;
    }
  }
  fs::create_directories(parts, ec);
  if (ec) fail(parts.string(), "cannot create the parts directory: " + ec.message());
  if (o.planned && !announced) o.planned(plan);
  return plan;
}

namespace {
std::string part_file(const std::string& work_dir, std::uint64_t id) {
  return (fs::path(work_dir) / "parts" / ("t" + std::to_string(id) + ".part")).string();
}
std::string cache_file(const std::string& work_dir, std::uint64_t id) {
  return (fs::path(work_dir) / "cache" / ("t" + std::to_string(id) + ".bin")).string();
}
/// Tile id's points from the cache.
tile_points load_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id) {
  const std::string file = cache_file(work_dir, id);
  tile_points pts = points_from_records(plan, id, slurp(file), file);
  if (pts.cloud.size() != plan.tile(id).points) fail(file, "the tile cache does not hold the tile's points");
  return pts;
}
/// Detects a cached tile and keeps its part (the cache file goes).
tile_part detect_and_keep(const tile_plan& plan, const std::string& work_dir, const tile_points& pts,
                          unsigned threads) {
  tile_part part = detect_tile(plan, pts, threads);
  write_part_as(part_file(work_dir, pts.tile), plan, part.plan, part);  // detect_tile's digest
  std::error_code ec;
  fs::remove(cache_file(work_dir, pts.tile), ec);
  // The resume tests' hook: die like a killed process after so many tiles.
  static std::atomic<long> detected{0};
  if (const char* kill_after = std::getenv("CED_TEST_KILL_AFTER_TILES"))
    if (++detected >= std::atol(kill_after)) std::raise(SIGKILL);
  return part;
}
}  // namespace

tile_part detect_cached_tile(const tile_plan& plan, const std::string& work_dir, std::uint64_t id, unsigned threads,
                             bool* was_done) {
  plan.tile(id);
  std::error_code ec;
  const bool done = fs::exists(part_file(work_dir, id), ec);
  if (was_done) *was_done = done;
  if (done) return read_part(part_file(work_dir, id), plan);
  return detect_and_keep(plan, work_dir, load_cached(plan, work_dir, id), threads);
}

namespace {
/// The parts of the plan's tiles in the work directory, merged into `sink`,
/// or into one tile_part that is returned.
tile_part merge_work_dir(const tile_plan& plan, const std::string& work_dir, const merge_sink* sink) {
  std::vector<std::string> paths;
  std::error_code ec;
  for (const auto& t : plan.tiles)
    if (fs::exists(part_file(work_dir, t.id), ec)) paths.push_back(part_file(work_dir, t.id));
  tile_part out;
  merge_sink collect;
  collect.begin = [&](const tile_part& totals, std::uint64_t n) {
    out = totals;
    if (!sink) resize_part(out, plan, static_cast<std::size_t>(n));
    if (sink && sink->begin) sink->begin(totals, n);
  };
  std::size_t at = 0;
  collect.chunk = [&](const tile_part& c) {
    if (sink) {
      if (sink->chunk) sink->chunk(c);
      return;
    }
    const std::size_t n = c.index.size();
    std::copy_n(c.index.begin(), n, out.index.begin() + at);
    std::copy_n(c.file_index.begin(), n, out.file_index.begin() + at);
    copy_points(c.keypoints, 0, out.keypoints, at, n);
    for (std::size_t k = 0; k < c.saliency.size(); ++k)
      std::copy_n(c.saliency[k].begin(), n, out.saliency[k].begin() + at);
    at += n;
  };
  merge_part_files(plan, paths, collect);
  for (auto& f : out.keypoints.fields()) f.whole_range.reset();
  return out;
}
}  // namespace

tile_part finish_tiled(const tile_plan& plan, const std::string& work_dir, const merge_sink* sink, bool keep_work_dir) {
  tile_part merged = merge_work_dir(plan, work_dir, sink);
  if (!keep_work_dir) remove_work_dir(work_dir);
  return merged;
}

tile_part run_tiled(const tiled_request& request, const tiled_run_options& o, tile_plan* plan_out) {
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  const auto t_plan = clock::now();
  const tile_plan plan = prepare_tiled(request, o);
  if (plan_out) *plan_out = plan;
  // The tiles one after the other, threads within each; the next tile's
  // cache is read while this one is detected.
  const auto t0 = std::chrono::steady_clock::now();
  std::error_code ec;
  auto needs_work = [&](std::size_t k) { return !fs::exists(part_file(o.work_dir, plan.tiles[k].id), ec); };
  auto load = [&](std::size_t k) {
    return std::async(std::launch::async, [&, k] { return load_cached(plan, o.work_dir, plan.tiles[k].id); });
  };
  std::future<tile_points> next;
  for (std::size_t k = 0; k < plan.tiles.size(); ++k) {
    if (needs_work(k)) {
      const tile_points pts = next.valid() ? next.get() : load(k).get();
      std::size_t after = k + 1;
      while (after < plan.tiles.size() && !needs_work(after)) ++after;
      if (after < plan.tiles.size()) next = load(after);
      detect_and_keep(plan, o.work_dir, pts, o.threads);
    }
    if (o.tile_done)
      o.tile_done(k + 1, plan.tiles.size(),
                  std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  const auto t_merge = std::chrono::steady_clock::now();
  tile_part merged = merge_work_dir(plan, o.work_dir, o.sink);
  if (!o.keep_work_dir) remove_work_dir(o.work_dir);
  if (o.times) *o.times = {ms(t_plan, t0), ms(t0, t_merge), ms(t_merge, clock::now())};
  return merged;
}

}  // namespace ced
