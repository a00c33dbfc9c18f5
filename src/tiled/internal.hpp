// SPDX-License-Identifier: MIT
// Private: what the stages of a tiled run (src/tiled/*.cpp) share, in the
// order of the data path: chunks of the input, the plan and its sizing, the
// point records of the tile cache and the parts, the tiles, the merge, the
// work directory. Not installed.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ced/io/error.hpp"
#include "ced/io/stream.hpp"
#include "ced/modality.hpp"
#include "ced/tiled.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::tiled_detail {

namespace fs = std::filesystem;

// ------------------------------------------------------------------ chunks (planning, detect_tile, tile_cache)

constexpr std::size_t chunk_points = std::size_t(1) << 20;

inline bool finite3(const float* p) noexcept {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
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

/// Reads the runs `runs` of `s` (ascending and apart), those next to each
/// other joined into one read of up to chunk_points points (at least one
/// run), with the fields `fields` names (as point_stream::read_run()), and
/// calls f(cloud, r0, r1) for each read: `cloud` holds runs [r0, r1) back to
/// back. A thread reads the next while f works on this one.
template <class F>
void for_each_run_group(io::point_stream& s, const std::vector<io::point_stream::point_run>& runs,
                        const std::vector<std::string>& fields, const std::array<double, 3>& origin, F&& f) {
  const auto group_end = [&](std::size_t r0) {
    std::size_t r1 = r0 + 1;
    std::uint64_t n = runs[r0].count;
    while (r1 < runs.size() && runs[r1].first == runs[r1 - 1].first + runs[r1 - 1].count &&
           n + runs[r1].count <= chunk_points)
      n += runs[r1++].count;
    return r1;
  };
  const auto read = [&](std::size_t r0, std::size_t r1, point_cloud& out) {
    const std::uint64_t end = runs[r1 - 1].first + runs[r1 - 1].count;
    s.read_run({runs[r0].first, end - runs[r0].first}, fields, origin, out);
  };
  if (runs.empty()) return;
  point_cloud clouds[2];
  std::size_t r0 = 0, r1 = group_end(0);
  read(r0, r1, clouds[0]);
  for (int k = 0;; k ^= 1) {
    const std::size_t n0 = r1, n1 = n0 < runs.size() ? group_end(n0) : n0;
    std::future<void> next;
    if (n0 < runs.size()) next = std::async(std::launch::async, [&, k, n0, n1] { read(n0, n1, clouds[k ^ 1]); });
    try {
      f(static_cast<const point_cloud&>(clouds[k]), r0, r1);
    } catch (...) {
      if (next.valid()) next.wait();
      throw;
    }
    if (!next.valid()) return;
    next.get();
    r0 = n0;
    r1 = n1;
  }
}

// ------------------------------------------------------------------ modalities (planning.cpp)

std::vector<any_modality> modalities_of(const std::vector<std::string>& specs);
/// The parameters a tile's halo follows: the radius of the largest scale
/// among the modalities (scale=).
detect_params halo_params(const tiled_request& r);
/// `params` for binding modalities to a one-point probe cloud (which only
/// checks their fields): the fixed radius, since K nearest need K points.
inline detect_params probe_params(detect_params params) {
  params.neighborhood = neighborhood_spec{};
  return params;
}
/// A part's modality names and absolute thresholds, from the plan's modalities.
void name_modalities(const tile_plan& plan, const std::vector<any_modality>& modalities, tile_part& part);

// ------------------------------------------------------------------ plan file (plan_file.cpp)

std::string hex(std::uint64_t v);
/// A chunk's positions and every field's values, into the content hash.
std::uint64_t hash_chunk(const point_cloud& c, std::uint64_t h);
/// hash_chunk() of the points [first, first + n) of `c`, as of a cloud of
/// those alone (a run of tile_plan::runs).
std::uint64_t hash_points(const point_cloud& c, std::size_t first, std::size_t n, std::uint64_t h);
/// The box of the points [first, first + n) of `c` (n > 0): a run's
/// plan_run::box, which a tile that reads the run checks.
std::array<float, 6> run_box(const point_cloud& c, std::size_t first, std::size_t n);
/// The file's size (into `bytes`), and a hash of it (check_plan_input()).
std::string fingerprint_of(const std::string& path, std::uint64_t& bytes);
/// The request as a plan writes it (and as a resumed run compares it).
nlohmann::json request_json(const tiled_request& r);

// ------------------------------------------------------------------ planning (planning.cpp, sizing.cpp)

/// What a pass over the points learns: counts, and each field's range over
/// the finite points (and whether every chunk had it).
struct scan_result {
  std::uint64_t file_points = 0, finite_points = 0;
  std::map<std::string, std::pair<value_range, bool>> ranges;
  std::size_t chunks = 0;
};
/// Adds chunk `c` to `s`.
void scan_chunk(const point_cloud& c, scan_result& s);
/// Each of `fields` that `scan` saw gets the range it saw.
void set_ranges(std::vector<plan_field>& fields, const scan_result& scan);
/// True for the names of LAS's one-bit flag fields (io::las_flag_fields()).
bool is_las_flag(const std::string& name);

/// The plan a LAS or LAZ file's header gives, without a pass over the
/// points: origin and grid from the header's bounds (grown by 1 %), every
/// field of the point format (each flag among them), the modalities'
/// tile_fields; no ranges, no tiles, and counts as the header declares.
/// None when the header's bounds are not finite and ordered (or not LAS),
/// or every field would go through the cache (no tile_fields) and one of
/// them is a flag, whose presence only a pass decides. What the file's
/// points make of it (the origin a whole read takes, the flags set) is for
/// the caller to check after a pass (build_cache).
std::optional<tile_plan> plan_from_header(const tiled_request& request, io::point_stream& s);

/// Plans without the tiles' counts (run_tiled counts them while it fills
/// its cache; plan_tiles in a pass of its own). Leaves `s` rewound.
tile_plan plan_grid(const tiled_request& request, io::point_stream& s, const tiled_progress& progress);

/// The largest tile size whose densest tile fits in the request's memory
/// limit, from a histogram of the points (one more pass over `s`). `lo`,
/// `hi`: the bounds relative to the plan's origin.
double size_for_memory(io::point_stream& s, const tile_plan& p, const double lo[3], const double hi[3],
                       const tiled_progress& progress);

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
  /// Point q (finite) of grid g: its own tile, and every tile it is near
  /// (`near_tiles`: scratch).
  void point(const tile_grid& g, const float* q, std::vector<std::uint64_t>& near_tiles) {
    core(g.tile_of(q));
    g.tiles_near(q, near_tiles);
    for (std::uint64_t t : near_tiles) near(t);
  }
  std::vector<tile_entry> entries() const;
};

/// Points per tile (a pass over `s`, which is left rewound), and the hash
/// of every decoded point into `content` when given.
std::vector<tile_entry> count_tiles(io::point_stream& s, const tile_plan& p, const tiled_progress& progress,
                                    std::uint64_t* content);

// ------------------------------------------------------------------ point records (records.cpp)
//
// The tile cache and the parts hold points as records, little-endian
// whatever the host, after a header (magic, format version). The layout:
// records.cpp (records, headers, the cache) and part_file.cpp (a part).

/// The format of the tile cache and part files; a reader refuses any other.
/// 1: parts began "CEDPART1", host byte order; caches had no header.
/// 2: cache records of fixed size (u64 index, u64 file index, f32 x y z, every field).
/// 3: cache records delta-coded (cache_coder), with only the tile fields;
///    parts with only the tile fields.
/// 4: part records end with the keypoint's rank (detection_result::rank_score).
constexpr std::uint32_t tiled_file_version = 4;

/// What a header names: a tile cache or a part.
struct tiled_file_kind {
  const char* magic;   ///< 7 characters, then '\0' ends the 8-byte magic
  const char* what;    ///< "tile cache", "tile part"
  const char* redo;    ///< what to do with a file of another version
  bool v1_headerless;  ///< its files of format version 1 had no header (caches)
};
extern const tiled_file_kind cache_kind, part_kind;
constexpr std::size_t tiled_header_bytes = 8 + 4;

/// The header of a file of `kind` (tiled_header_bytes).
std::string tiled_header(const tiled_file_kind& kind);
/// Checks the first `n` bytes at `p` of `path` (`size` bytes in all) for
/// the header of `kind` and this format version; io_error naming the file
/// (and both versions) otherwise.
void check_tiled_header(const char* p, std::size_t n, std::uint64_t size, const tiled_file_kind& kind,
                        const std::string& path);

/// A value of w bytes (1, 2, 4 or 8) from `from` to `to`, turned from host
/// to little-endian byte order or back (the same swap).
inline void copy_le(char* to, const char* from, std::size_t w) noexcept {
  if (!io::detail::host_little_endian()) {
    std::reverse_copy(from, from + w, to);
    return;
  }
  switch (w) {  // copies of a constant size, not calls to memcpy: records hold a few small values
    case 1:
      *to = *from;
      break;
    case 2:
      std::memcpy(to, from, 2);
      break;
    case 4:
      std::memcpy(to, from, 4);
      break;
    case 8:
      std::memcpy(to, from, 8);
      break;
    default:
      std::memcpy(to, from, w);
  }
}
template <class T>
void append_le(std::string& out, T v) {
  char b[sizeof(T)];
  io::detail::store_le(reinterpret_cast<unsigned char*>(b), v);
  out.append(b, sizeof b);
}
template <class T>
T load_le(const char* p) noexcept {
  return io::detail::load_le<T>(reinterpret_cast<const unsigned char*>(p));
}

/// The fields the tile cache and the parts carry (tile_plan::tile_fields).
std::vector<plan_field> tile_fields_of(const tile_plan& p);

/// The names of the plan's fields (every field of the input), in order: what
/// a stream reads them by (point_stream::read_run(), take_fields()).
std::vector<std::string> field_names(const tile_plan& p);

/// Bytes of one record of a part of the plan (its tile fields).
std::size_t record_size(const tile_plan& p);

/// The fields of a chunk as (bytes, width) pairs, for append_record().
using field_bytes = std::vector<std::pair<const unsigned char*, std::size_t>>;
field_bytes bytes_of(const point_cloud& c);

/// Appends point i of a chunk (positions `xyz`, fields `fields`) as a record
/// of `size` bytes to `out`. (Inline: the tile cache calls it for every
/// point and tile.)
inline void append_record(std::string& out, std::size_t size, std::uint64_t index, std::uint64_t file_index,
                          const float* xyz, const field_bytes& fields, std::size_t i) {
  const std::size_t at = out.size();
  if (out.capacity() < at + size) out.reserve(std::max(2 * out.capacity(), at + size));
  out.resize(at + size);
  auto* p = reinterpret_cast<unsigned char*>(out.data() + at);
  io::detail::store_le(p, index);
  io::detail::store_le(p + 8, file_index);
  for (std::size_t k = 0; k < 3; ++k) io::detail::store_le(p + 16 + 4 * k, xyz[3 * i + k]);
  char* q = reinterpret_cast<char*>(p + 28);
  for (const auto& [bytes, w] : fields) {
    copy_le(q, reinterpret_cast<const char*>(bytes + w * i), w);
    q += w;
  }
}
void append_record(std::string& out, std::uint64_t index, std::uint64_t file_index, const point_cloud& c,
                   std::size_t i);

/// The fields `want` of a chunk, as (bytes, width) pairs of their types:
/// the chunk's own bytes when its field has that name and type, else
/// converted into `keep` (a stream's chunks before its first complete pass
/// may lack a LAS flag, 0 there, or hold a CSV column as float64).
field_bytes conform_fields(const point_cloud& c, const std::vector<plan_field>& want, std::vector<column>& keep);

/// The tile cache's records (format version 3), each coded against the one
/// before it in its tile's file, in the input's order:
///   varint  (index - next index) * 2 + g, where next index is the previous
///           record's index + 1 (0 for the first), g = 1 when the count of
///           non-finite points before it grew
///   varint  by how much it grew (only when g = 1)
///   3 varints  x, y, z: the zigzag of the difference of the float's bits,
///           as an integer ordered like the floats, from the previous record's
///   the tile fields, each a value of its type, little-endian
/// So positions are the exact floats, and a point costs about 13 bytes with
/// 16-bit RGB (the figures in docs/RESULTS.md#scale).
struct cache_coder {
  std::uint64_t next_index = 0, gap = 0;
  std::int64_t at[3] = {0, 0, 0};

  static std::int64_t ordered(float f) noexcept {
    std::uint32_t b;
    std::memcpy(&b, &f, 4);
    return (b & 0x80000000u) ? -std::int64_t(b & 0x7fffffffu) - 1 : std::int64_t(b);
  }
  static float from_ordered(std::int64_t k) noexcept {
    const std::uint32_t b = k >= 0 ? std::uint32_t(k) : (0x80000000u | std::uint32_t(-(k + 1)));
    float f;
    std::memcpy(&f, &b, 4);
    return f;
  }
  static char* put(char* p, std::uint64_t v) noexcept {
    if (v < 0x80) {  // most deltas: one or two bytes
      *p = char(v);
      return p + 1;
    }
    if (v < 0x4000) {
      p[0] = char((v & 0x7f) | 0x80);
      p[1] = char(v >> 7);
      return p + 2;
    }
    for (; v >= 0x80; v >>= 7) *p++ = char((v & 0x7f) | 0x80);
    *p++ = char(v);
    return p;
  }
  /// The most bytes write() takes for a record with fields of
  /// `field_width` bytes in all.
  static constexpr std::size_t max_record_bytes(std::size_t field_width) noexcept { return 5 * 10 + field_width; }
  /// Writes point i (positions `xyz`, fields `fields`) with its indices at
  /// p, which has room for max_record_bytes() of the fields' width; returns
  /// the record's end.
  char* write(char* p, std::uint64_t index, std::uint64_t file_index, const float* xyz, const field_bytes& fields,
              std::size_t i) noexcept {
    const std::uint64_t g = file_index - index;
    p = put(p, ((index - next_index) << 1) | (g != gap ? 1 : 0));
    if (g != gap) p = put(p, g - gap);
    next_index = index + 1;
    gap = g;
    for (std::size_t k = 0; k < 3; ++k) {
      const std::int64_t o = ordered(xyz[3 * i + k]), d = o - at[k];
      at[k] = o;
      p = put(p, (std::uint64_t(d) << 1) ^ std::uint64_t(d >> 63));
    }
    for (const auto& [bytes, w] : fields) {
      copy_le(p, reinterpret_cast<const char*>(bytes + w * i), w);
      p += w;
    }
    return p;
  }
};

/// Tile id's points from its cache records (`bytes` from `offset` on, `n`
/// records); io_error naming `name` when they are not n whole records.
tile_points points_from_cache(const tile_plan& p, std::uint64_t id, std::size_t n, const std::string& bytes,
                              std::size_t offset, const std::string& name);

/// Decodes n records at `p` into points [at, at + n) of `c` and the index
/// arrays; returns the end of the records.
const char* decode_records(const char* p, std::size_t n, point_cloud& c, std::size_t at, std::uint64_t* index,
                           std::uint64_t* file_index);

/// An empty cloud with the plan's origin and tile fields (whole ranges set), room for n points.
point_cloud empty_cloud(const tile_plan& p, std::size_t n);
/// The same with every field of the plan: the input's records.
point_cloud record_cloud(const tile_plan& p, std::size_t n);
/// The same with no field: positions only.
point_cloud position_cloud(const tile_plan& p, std::size_t n);

/// Points [i, i + n) of `from` (positions and field bytes) into [j, j + n)
/// of `to`, a cloud with the same fields.
void copy_points(const point_cloud& from, std::size_t i, point_cloud& to, std::size_t j, std::size_t n = 1);

/// Tile id's points from its records (`bytes` from `offset` on); io_error
/// naming `name` when they are not whole records.
tile_points points_from_records(const tile_plan& p, std::uint64_t id, const std::string& bytes, std::size_t offset,
                                const std::string& name);

// ------------------------------------------------------------------ fetching records (fetch.cpp)

/// The tile fields of a plan whose modalities read fewer fields than it
/// has (what build_cache() sets as tile_plan::tile_fields); nullopt when
/// they read them all, or a modality does not say which it reads.
std::optional<std::vector<std::string>> detection_fields(const tile_plan& p);

/// The last pass of a run whose parts carry only the tile fields: the
/// keypoints' whole records, read from the input in one sequential pass (a
/// merge join: the keypoints come in ascending file index), or, when every
/// point is finite and the stream can (LAS, LAZ, binary PCD, PLY of fixed
/// records), only their records, or the LAZ chunks that hold them
/// (point_stream::read_points). Every keypoint's index and position must be
/// the input's, and the input's counts the plan's: else io_error, the input
/// changed since the plan.
class record_fetcher {
 public:
  /// With `fields` false, the keypoints' positions only (still checked).
  record_fetcher(const tile_plan& plan, bool fields);
  ~record_fetcher();
  record_fetcher(const record_fetcher&) = delete;
  record_fetcher& operator=(const record_fetcher&) = delete;
  /// `c` with every field of the input (or none); c's keypoints follow the previous call's.
  void fetch(tile_part& c);
  /// Reads the rest of the input and checks its counts.
  void finish();

 private:
  bool advance();
  void fetch_records(tile_part& c);
  [[noreturn]] void changed(const std::string& what) const;
  /// changed(): file point `file_index` is not keypoint `index` as detected.
  [[noreturn]] void not_the_keypoint(std::uint64_t file_index, std::uint64_t index) const;
  const tile_plan& m_plan;
  std::unique_ptr<io::point_stream> m_stream;
  bool m_records = false;                  ///< reading only the keypoints' records
  std::vector<std::string> m_field_names;  ///< of the plan; none when only positions are fetched
  std::uint64_t m_last = 0;                ///< records: file index past the last keypoint fetched
  point_cloud m_chunk, m_next;
  std::size_t m_next_size = 0;
  std::future<void> m_reading;
  std::uint64_t m_base = 0, m_finite_base = 0;  // of m_chunk's first point
  std::size_t m_scan = 0;                       // m_chunk's points counted in m_finite
  std::uint64_t m_finite = 0;                   // finite points before m_scan
};

/// A sink that hands `to` the chunks with their records fetched by `f`
/// (and, at begin, totals whose keypoints have every field of the plan).
merge_sink fetching_sink(const tile_plan& plan, record_fetcher& f, const merge_sink& to);

// ------------------------------------------------------------------ tile cache (tile_cache.cpp)

/// Passes 1 and 2 of a run without a plan yet: the plan and the tile cache
/// in `dir`, then plan.json. `announced`: the plan was reported already.
tile_plan build_cache(const tiled_request& request, const tiled_run_options& o, const fs::path& dir, bool& announced);
std::string cache_file(const std::string& work_dir, std::uint64_t id);
/// Tile id's points from the cache.
tile_points load_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id);

// ------------------------------------------------------------------ parts (part_file.cpp)

/// write_part() with the plan's digest already known (a digest formats the
/// whole plan: of thousands of tiles, a millisecond).
void write_part_as(const std::string& path, const tile_plan& plan, const std::string& digest, const tile_part& part);

/// A part file read a piece at a time: its header at once, then its records
/// in order through a buffer (the file is opened again for each refill, so
/// that thousands of parts need no open file each).
class part_reader {
 public:
  /// `digest`: plan.digest(), computed once by the caller for all its parts.
  part_reader(const std::string& path, const tile_plan& plan, const std::string& digest);

  /// The part without its keypoints: tile, names, thresholds, counts.
  tile_part totals;
  std::uint64_t count() const noexcept { return m_count; }
  std::size_t record_bytes() const noexcept { return m_record; }

  /// The next record (record_bytes()), nullptr after the last; `buffer`
  /// bytes are read at a time.
  const char* next(std::size_t buffer);
  /// Drops the buffer (after the last record).
  void release() { std::string().swap(m_buf), m_at = 0; }

 private:
  std::string m_path;
  std::uint64_t m_count = 0, m_left = 0, m_offset = 0;
  std::size_t m_record = 0;
  std::string m_buf;
  std::size_t m_at = 0;
};

/// Decodes a record of a part (point, then one saliency a modality) into `p`'s point j.
void decode_part_record(const char* r, tile_part& p, std::size_t j);
/// Sizes p's arrays for n keypoints.
void resize_part(tile_part& p, const tile_plan& plan, std::size_t n);

// ------------------------------------------------------------------ work directory (work_dir.cpp)

/// Makes `dir` ced's: creates it (marker "created yes"), or marks an empty
/// directory (marker "created no"), or accepts one that has ced's marker.
/// Anything else is refused, with or without `resume`.
void claim_work_dir(const std::string& work_dir);
/// Empties ced's cache and parts of a work directory (a run stopped before
/// its plan was written: its cache is incomplete).
void clear_tiles(const fs::path& dir);
/// Before a second try with a longer reach: empties the cache and keeps
/// the parts of the tiles that passed (parts/ becomes kept/; when it
/// cannot, they are removed).
void keep_parts(const fs::path& dir);
/// Removes the kept parts (keep_parts()) and their directory.
void clear_kept(const fs::path& dir);

}  // namespace ced::tiled_detail
