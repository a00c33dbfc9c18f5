// SPDX-License-Identifier: MIT
// LAZ: the LASzip VLR, the chunk table, and chunks decoded back into LAS
// point records (types.hpp). The items' decoders are in items.hpp.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>

#include "ced/io/error.hpp"
#include "core/parallel.hpp"
#include "io/base/scalar_io.hpp"
#include "io/laz/coder.hpp"
#include "io/laz/items.hpp"
#include "io/laz/layered.hpp"
#include "io/laz/layered_encode.hpp"
#include "io/laz/pointwise.hpp"
#include "io/laz/types.hpp"

namespace ced::io::detail {

namespace {

const char* item_name(std::uint16_t type) {
  switch (type) {
    case laz_item::byte:
      return "byte";
    case laz_item::point10:
      return "point10";
    case laz_item::gpstime11:
      return "gpstime11";
    case laz_item::rgb12:
      return "rgb12";
    case 9:
      return "wavepacket13";
    case laz_item::point14:
      return "point14";
    case laz_item::rgb14:
      return "rgb14";
    case laz_item::rgbnir14:
      return "rgbnir14";
    case 13:
      return "wavepacket14";
    case laz_item::byte14:
      return "byte14";
    default:
      return nullptr;
  }
}

std::string item_text(const laz_item& it) {
  const char* name = item_name(it.type);
  return (name ? std::string(name) : "item type " + std::to_string(it.type)) + " v" + std::to_string(it.version) +
         " (" + std::to_string(it.size) + " bytes)";
}

/// The items point format `format` is compressed with (before any extra
/// bytes): pointwise (compressor 2) for formats 0-3, layered (3) for 6-8.
std::vector<std::uint16_t> standard_items(int format) {
  switch (format) {
    case 0:
      return {laz_item::point10};
    case 1:
      return {laz_item::point10, laz_item::gpstime11};
    case 2:
      return {laz_item::point10, laz_item::rgb12};
    case 3:
      return {laz_item::point10, laz_item::gpstime11, laz_item::rgb12};
    case 6:
      return {laz_item::point14};
    case 7:
      return {laz_item::point14, laz_item::rgb14};
    case 8:
      return {laz_item::point14, laz_item::rgbnir14};
    default:
      return {};
  }
}

std::uint16_t item_size(std::uint16_t type) {
  switch (type) {
    case laz_item::point10:
      return 20;
    case laz_item::gpstime11:
      return 8;
    case laz_item::rgb12:
      return 6;
    case laz_item::point14:
      return 30;
    case laz_item::rgb14:
      return 6;
    case laz_item::rgbnir14:
      return 8;
    default:
      return 0;
  }
}

}  // namespace

std::string laz_layout::describe() const {
  std::string s;
  for (const laz_item& it : items) {
    if (!s.empty()) s += ", ";
    const char* name = item_name(it.type);
    s += (name ? std::string(name) : std::to_string(it.type)) + " v" + std::to_string(it.version);
  }
  return s;
}

laz_layout parse_laszip_vlr(const unsigned char* p, std::size_t len, int format, std::size_t record_length,
                            const std::string& file) {
  const std::string where = "LASzip VLR: ";
  if (len < 34) throw io_error(file, where + std::to_string(len) + " bytes, too short (it needs at least 34)");
  laz_layout l;
  l.record_length = record_length;
  l.compressor = load_le<std::uint16_t>(p);
  const auto coder = load_le<std::uint16_t>(p + 2);
  l.chunk_size = load_le<std::uint32_t>(p + 12);
  const std::size_t n_items = load_le<std::uint16_t>(p + 32);
  if (34 + 6 * n_items > len)
    throw io_error(file,
                   where + std::to_string(n_items) + " items do not fit in its " + std::to_string(len) + " bytes");
  if (coder != 0) throw io_error(file, where + "unknown coder " + std::to_string(coder) + " (LAZ knows 0, arithmetic)");
  if (l.compressor < 1 || l.compressor > 3)
    throw io_error(file, where + "unknown compressor " + std::to_string(l.compressor) +
                             " (1: pointwise, 2: pointwise chunked, 3: layered chunked)");
  if (l.compressor >= 2 && l.chunk_size == 0) throw io_error(file, where + "a chunk size of 0 points");
  const bool layered = format >= 6;
  if (layered != (l.compressor == 3))
    throw io_error(file, where + "compressor " + std::to_string(l.compressor) + " with point format " +
                             std::to_string(format) +
                             " (LAZ compresses formats 0-5 pointwise, compressor 1 or 2, and 6-10 layered, 3)");
  std::size_t total = 0;
  for (std::size_t i = 0; i < n_items; ++i) {
    laz_item it;
    it.type = load_le<std::uint16_t>(p + 34 + 6 * i);
    it.size = load_le<std::uint16_t>(p + 36 + 6 * i);
    it.version = load_le<std::uint16_t>(p + 38 + 6 * i);
    l.items.push_back(it);
    total += it.size;
  }
  // The items a point format is compressed with, in order, then its extra bytes.
  const std::vector<std::uint16_t> want = standard_items(format);
  if (want.empty())
    throw io_error(file, where + "point format " + std::to_string(format) +
                             " is not supported in LAZ (this reader decodes point formats 0-3 and 6-8; "
                             "4, 5, 9 and 10 carry waveforms)");
  // Pointwise items are version 1 (LASzip 1.x) or 2 (2.0 on), all the
  // same; layered ones 3 or 4.
  const auto check_version = [&](const laz_item& it) {
    if (layered ? (it.version == 3 || it.version == 4) : (it.version == 1 || it.version == 2)) {
      if (layered || it.version == l.items[0].version) return;
      throw io_error(file, where + "items [" + l.describe() + "] of versions 1 and 2 mixed (LASzip writes one)");
    }
    throw io_error(file, where + item_text(it) + ": not supported (" +
                             (layered ? "layered items are versions 3 and 4"
                                      : "pointwise items are versions 1 and 2, written by LASzip 1.x and 2.0 on") +
                             ")");
  };
  std::size_t i = 0;
  for (; i < want.size(); ++i) {
    if (i >= l.items.size() || l.items[i].type != want[i])
      throw io_error(file, where + "items [" + l.describe() + "] do not match point format " + std::to_string(format) +
                               " (it needs " + item_name(want[i]) + " as item " + std::to_string(i + 1) + ")");
    if (l.items[i].size != item_size(want[i]))
      throw io_error(file, where + "item " + std::to_string(i + 1) + ", " + item_name(want[i]) + ", says it has " +
                               std::to_string(l.items[i].size) + " bytes; that item has " +
                               std::to_string(item_size(want[i])));
    check_version(l.items[i]);
  }
  const std::uint16_t extra_type = layered ? std::uint16_t(laz_item::byte14) : std::uint16_t(laz_item::byte);
  for (; i < l.items.size(); ++i) {
    const laz_item& it = l.items[i];
    if (it.type != extra_type || i + 1 != l.items.size())
      throw io_error(
          file, where + "unexpected " + item_text(it) + " after the items of point format " + std::to_string(format));
    check_version(it);
    if (it.size == 0) throw io_error(file, where + "an extra-bytes item of 0 bytes");
  }
  if (total != record_length)
    throw io_error(file, where + "the items [" + l.describe() + "] hold " + std::to_string(total) +
                             " bytes a point, but the header's point record length is " +
                             std::to_string(record_length));
  return l;
}

namespace {

std::string chunk_error(std::size_t index, std::size_t chunks) {
  return "LAZ chunk table: chunk " + std::to_string(index) + " of " + std::to_string(chunks) + ": ";
}

/// The chunk table's entries: points (when each chunk says) and bytes of each chunk.
void read_chunk_table(const laz_layout& layout, std::uint64_t table, std::uint64_t file_size, const laz_read_fn& read,
                      std::vector<std::uint32_t>& points, std::vector<std::uint32_t>& bytes, std::uint64_t max_chunks,
                      const std::string& file) {
  unsigned char head[8];
  read(table, 8, reinterpret_cast<char*>(head));
  const auto version = load_le<std::uint32_t>(head);
  const auto count = load_le<std::uint32_t>(head + 4);
  if (version != 0)
    throw io_error(file, "LAZ chunk table at byte " + std::to_string(table) + ": unknown version " +
                             std::to_string(version) + " (expected 0)");
  if (count > max_chunks)
    throw io_error(file, "LAZ chunk table at byte " + std::to_string(table) + ": " + std::to_string(count) +
                             " chunks cannot fit in the " + std::to_string(max_chunks) + " bytes of point data");
  points.assign(count, 0);
  bytes.assign(count, 0);
  if (count == 0) return;
  const std::uint64_t start = table + 8;
  std::string coded(static_cast<std::size_t>(file_size - start), '\0');
  read(start, coded.size(), coded.data());
  const auto* d = reinterpret_cast<const unsigned char*>(coded.data());
  const bool variable = layout.chunk_size == 0xFFFFFFFFu;
  try {
    laz::decoder dec;
    dec.start(d, d + coded.size());
    laz::integer_coder ic(32, 2);
    for (std::size_t i = 0; i < count; ++i) {
      if (variable)
        points[i] = static_cast<std::uint32_t>(ic.decode(dec, i ? static_cast<std::int32_t>(points[i - 1]) : 0, 0));
      bytes[i] = static_cast<std::uint32_t>(ic.decode(dec, i ? static_cast<std::int32_t>(bytes[i - 1]) : 0, 1));
    }
  } catch (const laz::corrupt& e) {
    throw io_error(file, "LAZ chunk table at byte " + std::to_string(table) + " (" + std::to_string(count) +
                             " chunks) is corrupt: " + e.what());
  }
}

}  // namespace

std::vector<laz_chunk> laz_chunks(const laz_layout& layout, std::uint64_t point_offset, std::uint64_t file_size,
                                  std::uint64_t points, const laz_read_fn& read, const std::string& file) {
  std::vector<laz_chunk> chunks;
  if (layout.compressor == 1) {  // one chunk, no table: the point data runs to the end
    if (points > 0) chunks.push_back({0, points, point_offset, file_size - point_offset});
    return chunks;
  }
  if (file_size - point_offset < 8)
    throw io_error(file, "LAZ: the point data (from byte " + std::to_string(point_offset) +
                             ") is too short to hold the chunk table's offset");
  unsigned char word[8];
  read(point_offset, 8, reinterpret_cast<char*>(word));
  auto table = load_le<std::int64_t>(word);
  const std::uint64_t first = point_offset + 8;
  if (table == -1) {  // written to a stream: the offset is the file's last 8 bytes
    read(file_size - 8, 8, reinterpret_cast<char*>(word));
    table = load_le<std::int64_t>(word);
  }
  if (table >= 0 && std::uint64_t(table) == first && points > 0)
    throw io_error(file, "LAZ: the chunk table is missing (the compressor was interrupted before writing it)");
  if (table < 0 || std::uint64_t(table) < first || std::uint64_t(table) > file_size - 8)
    throw io_error(file, "LAZ: the chunk table's offset " + std::to_string(table) + " is outside the file (" +
                             std::to_string(file_size) + " bytes, point data from byte " + std::to_string(first) +
                             "); the file may be truncated");
  const auto end = static_cast<std::uint64_t>(table);
  std::vector<std::uint32_t> counts, sizes;
  read_chunk_table(layout, end, file_size, read, counts, sizes, end - first, file);
  const bool variable = layout.chunk_size == 0xFFFFFFFFu;
  chunks.resize(counts.size());
  std::uint64_t point = 0, offset = first;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    laz_chunk& c = chunks[i];
    c.first_point = point;
    c.points = variable ? counts[i] : std::min<std::uint64_t>(layout.chunk_size, points - std::min(points, point));
    c.offset = offset;
    c.bytes = sizes[i];
    if (c.points == 0) throw io_error(file, chunk_error(i, chunks.size()) + "no points");
    if (c.bytes == 0 || c.bytes > end - offset)
      throw io_error(file, chunk_error(i, chunks.size()) + std::to_string(c.bytes) + " bytes from byte " +
                               std::to_string(offset) + " do not fit before the chunk table at byte " +
                               std::to_string(end));
    point += c.points;
    offset += c.bytes;
  }
  if (point != points)
    throw io_error(file, "LAZ chunk table: its " + std::to_string(chunks.size()) + " chunks hold " +
                             std::to_string(point) + " points, the header declares " + std::to_string(points));
  return chunks;
}

void decode_laz_chunk(const laz_layout& layout, const laz_chunk& c, std::size_t index, const unsigned char* data,
                      unsigned char* out, const std::string& file, const laz_wanted& wanted) {
  if (c.points == 0) return;
  const std::size_t stride = layout.record_length;
  const auto fail = [&](const std::string& why) {
    return io_error(file, "LAZ chunk " + std::to_string(index) + " (points " + std::to_string(c.first_point) + " to " +
                              std::to_string(c.first_point + c.points - 1) + ", " + std::to_string(c.bytes) +
                              " bytes at byte " + std::to_string(c.offset) + "): " + why);
  };
  if (c.bytes < stride) throw fail("too short for its first point record");
  std::copy(data, data + stride, out);
  if (c.points == 1) return;
  try {
    if (layout.compressor == 3)
      laz::decode_layered(layout.items, data + stride, data + c.bytes, out, stride, c.points, wanted);
    else
      laz::decode_pointwise(layout.items, data + stride, data + c.bytes, out, stride, c.points, layout.compressor != 1);
  } catch (const laz::corrupt& e) {
    throw fail(e.what());
  }
}

void copc_node::box(const copc_info& info, double out[6]) const noexcept {
  const double side = 2 * info.halfsize / std::ldexp(1.0, depth);
  const std::int32_t key[3] = {x, y, z};
  for (int k = 0; k < 3; ++k) {
    out[k] = info.center[k] - info.halfsize + side * key[k];
    out[3 + k] = out[k] + side;
  }
}

copc_info parse_copc_info(const unsigned char* p, std::size_t len, const std::string& file) {
  if (len < 160) throw io_error(file, "COPC info VLR: " + std::to_string(len) + " bytes, it needs 160");
  copc_info c;
  for (int k = 0; k < 3; ++k) c.center[k] = load_le<double>(p + 8 * k);
  c.halfsize = load_le<double>(p + 24);
  c.root_offset = load_le<std::uint64_t>(p + 40);
  c.root_size = load_le<std::uint64_t>(p + 48);
  if (!(std::isfinite(c.center[0]) && std::isfinite(c.center[1]) && std::isfinite(c.center[2]) &&
        std::isfinite(c.halfsize) && c.halfsize > 0))
    throw io_error(file, "COPC info VLR: the octree's cube is not finite and positive");
  return c;
}

std::vector<copc_node> read_copc_hierarchy(const copc_info& info, std::uint64_t file_size, const laz_read_fn& read,
                                           const std::string& file) {
  constexpr std::size_t entry = 32;
  std::vector<copc_node> nodes;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> pages = {{info.root_offset, info.root_size}};
  std::set<std::uint64_t> seen;
  std::uint64_t entries = 0;
  std::string buf;
  while (!pages.empty()) {
    const auto [offset, size] = pages.back();
    pages.pop_back();
    const std::string where =
        "COPC hierarchy page at byte " + std::to_string(offset) + " (" + std::to_string(size) + " bytes): ";
    if (offset > file_size || size > file_size - offset) throw io_error(file, where + "outside the file");
    if (size % entry != 0) throw io_error(file, where + "not a whole number of 32-byte entries");
    if (!seen.insert(offset).second) throw io_error(file, where + "reached twice");
    if ((entries += size / entry) > file_size / entry) throw io_error(file, where + "more entries than the file holds");
    buf.resize(static_cast<std::size_t>(size));
    read(offset, buf.size(), buf.data());
    for (std::size_t i = 0; i < buf.size(); i += entry) {
      const auto* e = reinterpret_cast<const unsigned char*>(buf.data()) + i;
      copc_node n;
      n.depth = load_le<std::int32_t>(e);
      n.x = load_le<std::int32_t>(e + 4);
      n.y = load_le<std::int32_t>(e + 8);
      n.z = load_le<std::int32_t>(e + 12);
      n.offset = load_le<std::uint64_t>(e + 16);
      n.bytes = load_le<std::int32_t>(e + 24);
      n.points = load_le<std::int32_t>(e + 28);
      const std::int64_t cells = n.depth >= 0 && n.depth < 31 ? std::int64_t(1) << n.depth : 0;
      if (cells == 0 || n.x < 0 || n.y < 0 || n.z < 0 || n.x >= cells || n.y >= cells || n.z >= cells)
        throw io_error(file, where + "node " + std::to_string(n.depth) + "-" + std::to_string(n.x) + "-" +
                                 std::to_string(n.y) + "-" + std::to_string(n.z) + " is outside the octree");
      if (n.points == -1) {
        if (n.bytes < 0) throw io_error(file, where + "a child page of negative size");
        pages.push_back({n.offset, std::uint64_t(n.bytes)});
      } else if (n.points < -1 || n.bytes < 0) {
        throw io_error(file, where + "a node with " + std::to_string(n.points) + " points in " +
                                 std::to_string(n.bytes) + " bytes");
      } else if (n.points > 0) {
        nodes.push_back(n);
      }
    }
  }
  return nodes;
}

namespace {
/// The format's standard items at `version`, then its extra bytes as one item of `extra_type`.
laz_layout layout_of(int compressor, int format, std::size_t record_length, std::uint32_t chunk_size,
                     std::uint16_t version, std::uint16_t extra_type) {
  laz_layout layout;
  layout.compressor = compressor;
  layout.chunk_size = chunk_size;
  layout.record_length = record_length;
  std::size_t standard = 0;
  for (const std::uint16_t type : standard_items(format)) {
    layout.items.push_back({type, item_size(type), version});
    standard += item_size(type);
  }
  if (record_length > standard)
    layout.items.push_back({extra_type, static_cast<std::uint16_t>(record_length - standard), version});
  return layout;
}
}  // namespace

laz_layout pointwise_layout(int format, std::size_t record_length, std::uint32_t chunk_size) {
  return layout_of(2, format, record_length, chunk_size, 2, laz_item::byte);
}

laz_layout layered_layout(int format, std::size_t record_length) {
  return layout_of(3, format, record_length, 0xFFFFFFFFu, 3, laz_item::byte14);
}

std::string vlr_header(const std::string& user, std::uint16_t record, std::size_t length,
                       const std::string& description, std::uint16_t reserved) {
  std::string v(k_vlr_header_bytes, '\0');
  auto* d = reinterpret_cast<unsigned char*>(v.data());
  store_le<std::uint16_t>(d, reserved);
  std::memcpy(d + 2, user.data(), std::min<std::size_t>(user.size(), 16));
  store_le<std::uint16_t>(d + 18, record);
  store_le<std::uint16_t>(d + 20, static_cast<std::uint16_t>(length));
  std::memcpy(d + 22, description.data(), std::min<std::size_t>(description.size(), 32));
  return v;
}

std::string laszip_vlr(const laz_layout& layout) {
  std::string body(34 + 6 * layout.items.size(), '\0');
  auto* p = reinterpret_cast<unsigned char*>(body.data());
  store_le<std::uint16_t>(p, static_cast<std::uint16_t>(layout.compressor));
  // The LASzip version the items are of: 2.2 (pointwise, v2 items), 3.4 (layered, v3).
  p[4] = layout.compressor == 3 ? 3 : 2;
  p[5] = layout.compressor == 3 ? 4 : 2;
  store_le<std::uint32_t>(p + 12, layout.chunk_size);
  store_le<std::int64_t>(p + 16, -1);  // no special EVLRs
  store_le<std::int64_t>(p + 24, -1);
  store_le<std::uint16_t>(p + 32, static_cast<std::uint16_t>(layout.items.size()));
  for (std::size_t i = 0; i < layout.items.size(); ++i) {
    store_le<std::uint16_t>(p + 34 + 6 * i, layout.items[i].type);
    store_le<std::uint16_t>(p + 36 + 6 * i, layout.items[i].size);
    store_le<std::uint16_t>(p + 38 + 6 * i, layout.items[i].version);
  }
  return vlr_header("laszip encoded", 22204, body.size(), "ced LAZ writer", 0xAABB) + body;
}

void encode_laz_chunk(const laz_layout& layout, const unsigned char* records, std::uint64_t points, std::string& out) {
  if (layout.compressor == 3)
    laz::encode_layered(layout.items, records, layout.record_length, points, out);
  else
    laz::encode_pointwise(layout.items, records, layout.record_length, points, out);
}

std::string encode_chunk_table(const std::vector<std::uint32_t>& points, const std::vector<std::uint32_t>& bytes,
                               bool variable) {
  std::string t(8, '\0');
  store_le<std::uint32_t>(reinterpret_cast<unsigned char*>(t.data()) + 4, static_cast<std::uint32_t>(bytes.size()));
  if (bytes.empty()) return t;
  laz::encoder e(t);
  laz::integer_coder ic(32, 2);
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (variable) ic.encode(e, i ? std::int32_t(points[i - 1]) : 0, std::int32_t(points[i]), 0);
    ic.encode(e, i ? std::int32_t(bytes[i - 1]) : 0, std::int32_t(bytes[i]), 1);
  }
  e.done();
  return t;
}

void decode_laz_chunks(const laz_layout& layout, const std::vector<laz_chunk>& chunks, std::size_t c0, std::size_t c1,
                       const laz_read_fn& read, unsigned char* out, const std::string& file, const laz_wanted& wanted) {
  if (c0 >= c1) return;
  const std::uint64_t base = chunks[c0].first_point;
  ced::detail::parallel_for(c1 - c0, 0, 1, [&](std::size_t b, std::size_t e) {
    std::string buf;
    for (std::size_t i = c0 + b; i < c0 + e; ++i) {
      const laz_chunk& c = chunks[i];
      buf.resize(static_cast<std::size_t>(c.bytes));
      read(c.offset, buf.size(), buf.data());
      decode_laz_chunk(layout, c, i, reinterpret_cast<const unsigned char*>(buf.data()),
                       out + (c.first_point - base) * layout.record_length, file, wanted);
    }
  });
}

}  // namespace ced::io::detail
