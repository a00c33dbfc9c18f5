// SPDX-License-Identifier: MIT
// Tiled runs: the point records of the tile cache and the parts (index,
// file index, position, the plan's fields).
#include <string>

#include "tiled/internal.hpp"

namespace ced::tiled_detail {

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

}  // namespace ced::tiled_detail
