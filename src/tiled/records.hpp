// SPDX-License-Identifier: MIT
// Private to src/tiled: point records of the tile cache and the parts: the file header, records, the cache's delta
// coding (records.cpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/tiled.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::tiled_detail {

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

/// Tile id's points from its cache records: the records of each piece
/// (`pieces`, each from `offset` on, coded afresh: cache_coder starts anew
/// in each), `n` between them; io_error naming `name` when they are not n
/// whole records.
tile_points points_from_cache(const tile_plan& p, std::uint64_t id, std::size_t n,
                              const std::vector<std::string>& pieces, std::size_t offset, const std::string& name);

/// Decodes n records at `p` into points [at, at + n) of `c` and the index
/// arrays; returns the end of the records.
const char* decode_records(const char* p, std::size_t n, point_cloud& c, std::size_t at, std::uint64_t* index,
                           std::uint64_t* file_index);

/// An empty cloud with the plan's origin and tile fields (whole ranges set), room for n points.
point_cloud empty_cloud(const tile_plan& p, std::size_t n);
/// empty_cloud(p, 1) for binding the modalities before the plan has its
/// samples: a field without one gets an empty sample (a modality then finds
/// its fields and checks its options, and computes nothing from them), and
/// every field's value is 1 (no modality takes the point as degenerate).
point_cloud probe_cloud(const tile_plan& p);
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

}  // namespace ced::tiled_detail
