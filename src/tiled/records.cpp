// SPDX-License-Identifier: MIT
// Tiled runs: the point records of the tile cache and the parts, and the
// header (magic, format version) that starts each of their files.
//
// Every value is little-endian whatever the host, so that a file written on
// one machine reads on another (on x86 the bytes are the host's).
//
// A part's record (record_size() bytes):
//   offset 0   u64 index        among the input's finite points
//   offset 8   u64 file_index   among all the input's points
//   offset 16  f32 x, y, z      relative to the plan's origin
//   offset 28  the plan's tile fields (tile_fields_of()), each a value of
//              its type (1, 2, 4 or 8 bytes), in the plan's order
// The tile cache's records are delta-coded: cache_coder (records.hpp).
// A file's header (tiled_header_bytes):
//   offset 0   8-byte magic: "CEDTILE\0" (a tile cache), "CEDPART\0" (a part)
//   offset 8   u32 format version (tiled_file_version)
// A tile cache (work_dir/cache/t<id>.bin): the header, then the records of
// the points the tile reads, in the input's order. A part: part_file.cpp.
#include "tiled/records.hpp"

#include <algorithm>
#include <memory>
#include <string>

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

std::vector<plan_field> tile_fields_of(const tile_plan& p) {
  if (!p.tile_fields) return p.fields;
  std::vector<plan_field> out;
  for (const auto& f : p.fields)
    if (std::find(p.tile_fields->begin(), p.tile_fields->end(), f.name) != p.tile_fields->end()) out.push_back(f);
  return out;
}

std::vector<std::string> field_names(const tile_plan& p) {
  std::vector<std::string> out;
  for (const plan_field& f : p.fields) out.push_back(f.name);
  return out;
}

std::size_t record_size(const tile_plan& p) {
  std::size_t s = 8 + 8 + 12;
  for (const auto& f : tile_fields_of(p)) s += size_of(f.type);
  return s;
}

field_bytes conform_fields(const point_cloud& c, const std::vector<plan_field>& want, std::vector<column>& keep) {
  field_bytes out;
  keep.clear();
  keep.reserve(want.size());
  for (const auto& w : want) {
    const field* f = c.find_field(w.name);
    if (f && f->type() == w.type) {
      out.push_back({f->values.bytes(), size_of(w.type)});
      continue;
    }
    keep.emplace_back(w.type, c.size());  // zeros: a LAS flag no point of the chunk sets
    if (f)
      for (std::size_t i = 0; i < c.size(); ++i) keep.back().set(i, f->values[i]);
    out.push_back({keep.back().bytes(), size_of(w.type)});
  }
  return out;
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

namespace {

point_cloud cloud_with(const tile_plan& p, const std::vector<plan_field>& fields, std::size_t n) {
  point_cloud c;
  c.set_origin(p.origin);
  c.resize(n);
  for (const auto& f : fields) {
    field& added = c.add_field(f.name, column(f.type, n));
    added.whole_range = f.range;
    added.whole_sample = f.sample;
  }
  return c;
}

/// Reads varints and bytes of a tile cache; io_error past its end.
struct cache_reader {
  const char *p, *end;
  const std::string& name;
  [[noreturn]] void truncated() const { throw io::io_error(name, "truncated or corrupt tile cache"); }
  std::uint64_t get() {
    if (end - p >= 2) {  // most values: one or two bytes
      const auto b0 = static_cast<unsigned char>(p[0]), b1 = static_cast<unsigned char>(p[1]);
      if (!(b0 & 0x80)) {
        p += 1;
        return b0;
      }
      if (!(b1 & 0x80)) {
        p += 2;
        return std::uint64_t(b0 & 0x7f) | std::uint64_t(b1) << 7;
      }
    }
    std::uint64_t v = 0;
    for (unsigned shift = 0; shift < 64; shift += 7) {
      if (p == end) truncated();
      const auto b = static_cast<unsigned char>(*p++);
      v |= std::uint64_t(b & 0x7f) << shift;
      if (!(b & 0x80)) return v;
    }
    truncated();
  }
  const char* take(std::size_t n) {
    if (std::size_t(end - p) < n) truncated();
    const char* q = p;
    p += n;
    return q;
  }
};

}  // namespace

point_cloud empty_cloud(const tile_plan& p, std::size_t n) { return cloud_with(p, tile_fields_of(p), n); }

point_cloud probe_cloud(const tile_plan& p) {
  point_cloud c = empty_cloud(p, 1);
  const auto none = std::make_shared<const std::vector<double>>();
  for (field& f : c.fields()) {
    f.values.set(0, 1);  // not all zero: sam refuses a spectrum of zeros
    if (!f.whole_sample) f.whole_sample = none;
  }
  return c;
}

point_cloud record_cloud(const tile_plan& p, std::size_t n) { return cloud_with(p, p.fields, n); }

point_cloud position_cloud(const tile_plan& p, std::size_t n) { return cloud_with(p, {}, n); }

tile_points points_from_cache(const tile_plan& p, std::uint64_t id, std::size_t n,
                              const std::vector<std::string>& pieces, std::size_t offset, const std::string& name) {
  tile_points t;
  t.tile = id;
  t.cloud = empty_cloud(p, n);
  t.index.resize(n);
  t.file_index.resize(n);
  std::vector<std::pair<unsigned char*, std::size_t>> fields;
  for (auto& f : t.cloud.fields()) fields.push_back({f.values.bytes(), size_of(f.type())});
  float* xyz = t.cloud.positions().data();
  std::size_t i = 0;
  for (const std::string& bytes : pieces) {
    cache_reader in{bytes.data() + offset, bytes.data() + bytes.size(), name};
    std::uint64_t next = 0, gap = 0;
    std::int64_t at[3] = {0, 0, 0};
    for (; in.p != in.end; ++i) {
      if (i == n) throw io::io_error(name, "the tile cache holds more than the tile's points");
      const std::uint64_t head = in.get();
      if (head & 1) gap += in.get();
      t.index[i] = next + (head >> 1);
      t.file_index[i] = t.index[i] + gap;
      next = t.index[i] + 1;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint64_t z = in.get();
        at[k] = std::int64_t(std::uint64_t(at[k]) + (std::uint64_t(z >> 1) ^ (0 - (z & 1))));  // wraps, never UB
        xyz[3 * i + k] = cache_coder::from_ordered(at[k]);
      }
      for (auto& [to, w] : fields) copy_le(reinterpret_cast<char*>(to + w * i), in.take(w), w);
    }
  }
  if (i != n)
    throw io::io_error(name, "truncated or corrupt tile cache (" + std::to_string(i) + " of the tile's " +
                                 std::to_string(n) + " points)");
  return t;
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
