// SPDX-License-Identifier: MIT
// Tiled runs: the point records of the tile cache and the parts, and the
// header (magic, format version) that starts each of their files.
//
// Every value is little-endian whatever the host, so that a file written on
// one machine reads on another (on x86 the bytes are the host's).
//
// A record (record_size() bytes):
//   offset 0   u64 index        among the input's finite points
//   offset 8   u64 file_index   among all the input's points
//   offset 16  f32 x, y, z      relative to the plan's origin
//   offset 28  the plan's fields, each a value of its type (1, 2, 4 or 8
//              bytes), in the plan's order
// A file's header (tiled_header_bytes):
//   offset 0   8-byte magic: "CEDTILE\0" (a tile cache), "CEDPART\0" (a part)
//   offset 8   u32 format version (tiled_file_version)
// A tile cache (work_dir/cache/t<id>.bin): the header, then the records of
// the points the tile reads, in the input's order. A part: part_file.cpp.
#include <string>

#include "tiled/internal.hpp"

namespace ced::tiled_detail {

const tiled_file_kind cache_kind{"CEDTILE", "tile cache", "remove the work directory and run again", true};
const tiled_file_kind part_kind{"CEDPART", "tile part", "detect its tile again", false};

std::string tiled_header(const tiled_file_kind& kind) {
  std::string out(kind.magic, 7);
  out += '\0';
  append_le(out, tiled_file_version);
  return out;
}

void check_tiled_header(const char* p, std::size_t n, std::uint64_t size, const tiled_file_kind& kind,
                        const std::string& path) {
  const std::string what = kind.what;
  if (n < 8) throw io::io_error(path, "truncated " + what + " (" + std::to_string(size) + " bytes)");
  // Version 1 of a part began "CEDPART1"; version 1 of a cache had no header.
  const bool v1_magic = !kind.v1_headerless && p[7] == '1';
  if (std::memcmp(p, kind.magic, 7) != 0 || (p[7] != '\0' && !v1_magic)) {
    std::string hint;
    if (kind.v1_headerless) hint = " (or one of format version 1, which had no header: " + std::string(kind.redo) + ")";
    throw io::io_error(path, "not a ced " + what + hint);
  }
  std::uint32_t version = 1;
  if (!v1_magic) {
    if (n < tiled_header_bytes) throw io::io_error(path, "truncated " + what + " (" + std::to_string(size) + " bytes)");
    version = load_le<std::uint32_t>(p + 8);
  }
  if (version != tiled_file_version)
    throw io::io_error(path, what + " format version " + std::to_string(version) + ", this ced reads version " +
                                 std::to_string(tiled_file_version) + " (written by another ced version: " + kind.redo +
                                 ")");
}

std::size_t record_size(const tile_plan& p) {
  std::size_t s = 8 + 8 + 12;
  for (const auto& f : p.fields) s += size_of(f.type);
  return s;
}

field_bytes bytes_of(const point_cloud& c) {
  field_bytes out;
  for (const auto& f : c.fields()) out.push_back({f.values.bytes(), size_of(f.type())});
  return out;
}

void append_record(std::string& out, std::uint64_t index, std::uint64_t file_index, const point_cloud& c,
                   std::size_t i) {
  std::size_t size = 28;
  const field_bytes fields = bytes_of(c);
  for (const auto& f : fields) size += f.second;
  append_record(out, size, index, file_index, c.positions().data(), fields, i);
}

const char* decode_records(const char* p, std::size_t n, point_cloud& c, std::size_t at, std::uint64_t* index,
                           std::uint64_t* file_index) {
  float* xyz = c.positions().data();
  for (std::size_t i = 0; i < n; ++i) {
    index[i] = load_le<std::uint64_t>(p);
    file_index[i] = load_le<std::uint64_t>(p + 8);
    for (std::size_t k = 0; k < 3; ++k) xyz[3 * (at + i) + k] = load_le<float>(p + 16 + 4 * k);
    p += 28;
    for (auto& f : c.fields()) {
      const std::size_t w = size_of(f.type());
      copy_le(reinterpret_cast<char*>(f.values.bytes()) + w * (at + i), p, w);
      p += w;
    }
  }
  return p;
}

point_cloud empty_cloud(const tile_plan& p, std::size_t n) {
  point_cloud c;
  c.set_origin(p.origin);
  c.resize(n);
  for (const auto& f : p.fields) c.add_field(f.name, column(f.type, n)).whole_range = f.range;
  return c;
}

void copy_points(const point_cloud& from, std::size_t i, point_cloud& to, std::size_t j, std::size_t n) {
  std::copy_n(from.position(i), 3 * n, to.positions().data() + 3 * j);
  for (std::size_t f = 0; f < from.fields().size(); ++f) {
    const std::size_t w = size_of(from.fields()[f].type());
    std::memcpy(to.fields()[f].values.bytes() + w * j, from.fields()[f].values.bytes() + w * i, w * n);
  }
}

tile_points points_from_records(const tile_plan& p, std::uint64_t id, const std::string& bytes, std::size_t offset,
                                const std::string& name) {
  const std::size_t rs = record_size(p);
  if ((bytes.size() - offset) % rs != 0)
    throw io::io_error(name, "truncated tile cache (" + std::to_string(bytes.size()) + " bytes)");
  const std::size_t n = (bytes.size() - offset) / rs;
  tile_points t;
  t.tile = id;
  t.cloud = empty_cloud(p, n);
  t.index.resize(n);
  t.file_index.resize(n);
  decode_records(bytes.data() + offset, n, t.cloud, 0, t.index.data(), t.file_index.data());
  return t;
}

}  // namespace ced::tiled_detail
