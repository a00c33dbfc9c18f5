// SPDX-License-Identifier: MIT
// Writing COPC (cloud-optimised point cloud): a LAZ 1.4 file (point formats
// 6-8, layered compression) whose points are grouped by the nodes of an
// octree, one LAZ chunk per node, with the "copc" info VLR first and the
// hierarchy as an extended VLR (https://copc.io, COPC 1.0).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/io/las.hpp"
#include "core/parallel.hpp"
#include "io/base/scalar_io.hpp"
#include "io/laz/types.hpp"

namespace ced::io::detail {
namespace {

constexpr std::size_t k_header_14 = 375, k_evlr_header = 60, k_entry = 32;
/// Cells per side of a node's sampling grid: a node keeps the first point
/// in each of its 128^3 cells and passes the others to its children.
constexpr int k_grid_bits = 7;
/// The deepest level: its nodes keep every point that reaches them.
constexpr int k_max_depth = 12;

/// The LAS 1.4 file the writer takes (ced's own output): its head, checked.
las_head parse_las14(std::string_view las, const std::string& name) {
  const las_head h = read_las_head(las, name);
  const auto bad = [&](const std::string& why) { return std::invalid_argument(name + ": " + why); };
  if (h.minor != 4 || h.header_size != k_header_14) throw bad("COPC is written from LAS 1.4 records");
  if (h.format < 6 || h.format > 8) throw bad("COPC is written for point formats 6-8");
  if (h.evlr_offset != 0 || h.evlr_count != 0) throw bad("extended VLRs are not carried into COPC");
  if (h.count >= (std::uint64_t(1) << 32)) throw bad("COPC is written for fewer than 2^32 points");
  return h;
}

/// The octree's cube: the points' bounds' centre, and half the largest
/// side; and the points' GPS time range, which the COPC info records.
struct cube {
  double center[3] = {0, 0, 0};
  double halfsize = 1;
  double gps[2] = {0, 0};
};

/// The cube and GPS range of the records, in one pass over them.
cube cube_of(const las_head& h) {
  std::int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
  cube c;
  const unsigned char* r = h.records;
  for (std::uint64_t i = 0; i < h.count; ++i, r += h.record_length) {
    for (int k = 0; k < 3; ++k) {
      const auto v = load_le<std::int32_t>(r + 4 * k);
      lo[k] = std::min(lo[k], v);
      hi[k] = std::max(hi[k], v);
    }
    const double t = load_le<double>(r + 22);
    c.gps[0] = i ? std::min(c.gps[0], t) : t;
    c.gps[1] = i ? std::max(c.gps[1], t) : t;
  }
  double half = 0;
  for (int k = 0; k < 3; ++k) {
    const double a = h.count ? lo[k] * h.scale[k] + h.offset[k] : 0, b = h.count ? hi[k] * h.scale[k] + h.offset[k] : 0;
    c.center[k] = (a + b) / 2;
    half = std::max(half, (b - a) / 2);
  }
  // A little room, so that no point lies on the cube's faces by rounding.
  c.halfsize = half > 0 ? half * (1 + 1e-9) + 1e-9 : 1;
  return c;
}

/// A node's key: depth, then x, y, z (12 bits each at most).
std::uint64_t node_key(int depth, std::uint64_t x, std::uint64_t y, std::uint64_t z) {
  return std::uint64_t(depth) << 48 | x << 32 | y << 16 | z;
}

/// The node of each point (its key), levels of detail by grid sampling: a
/// point stays at the shallowest depth where it is the first (in file order)
/// in its cell of that depth's grid.
std::vector<std::uint64_t> assign_nodes(const las_head& h, const cube& c) {
  const std::size_t n = static_cast<std::size_t>(h.count);
  std::vector<std::uint64_t> key(n, 0);
  std::vector<std::uint32_t> left(n);
  for (std::size_t i = 0; i < n; ++i) left[i] = static_cast<std::uint32_t>(i);
  std::vector<std::pair<std::uint64_t, std::uint32_t>> cells;
  const double side0 = 2 * c.halfsize;
  for (int depth = 0; depth <= k_max_depth && !left.empty(); ++depth) {
    const int bits = depth + k_grid_bits;
    const std::uint64_t cells_per_side = std::uint64_t(1) << bits;
    const double per_metre = double(cells_per_side) / side0;
    cells.resize(left.size());
    ced::detail::parallel_for(left.size(), 0, 4096, [&](std::size_t b, std::size_t e) {
      for (std::size_t j = b; j < e; ++j) {
        const unsigned char* r = h.records + std::size_t(left[j]) * h.record_length;
        std::uint64_t cell[3];
        for (int k = 0; k < 3; ++k) {
          const double p = load_le<std::int32_t>(r + 4 * k) * h.scale[k] + h.offset[k];
          const double f = std::floor((p - (c.center[k] - c.halfsize)) * per_metre);
          cell[k] = static_cast<std::uint64_t>(std::clamp(f, 0.0, double(cells_per_side - 1)));
        }
        cells[j] = {cell[0] << 2 * bits | cell[1] << bits | cell[2], left[j]};
        key[left[j]] = node_key(depth, cell[0] >> k_grid_bits, cell[1] >> k_grid_bits, cell[2] >> k_grid_bits);
      }
    });
    if (depth == k_max_depth) break;
    std::sort(cells.begin(), cells.end());
    std::size_t kept = 0;
    for (std::size_t j = 0; j < cells.size(); ++j)
      if (j > 0 && cells[j].first == cells[j - 1].first) left[kept++] = cells[j].second;
    left.resize(kept);  // in cell order: the next level sorts them by cell and index again
  }
  return key;
}

struct coded_nodes {
  std::vector<std::uint64_t> keys;  ///< of the nodes, in file order
  std::vector<std::uint32_t> points, bytes;
  std::vector<std::string> chunks;
};

/// The points grouped by node (in key order, file order within a node),
/// each node coded as one chunk, in parallel.
coded_nodes code_nodes(const las_head& h, const laz_layout& layout, const std::vector<std::uint64_t>& key) {
  std::vector<std::uint32_t> order(key.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  coded_nodes out;
  std::vector<std::size_t> first;
  for (std::size_t j = 0; j < order.size(); ++j)
    if (j == 0 || key[order[j]] != key[order[j - 1]]) {
      first.push_back(j);
      out.keys.push_back(key[order[j]]);
    }
  first.push_back(order.size());
  const std::size_t nodes = out.keys.size();
  out.points.resize(nodes);
  out.bytes.resize(nodes);
  out.chunks.resize(nodes);
  ced::detail::parallel_for(nodes, 0, 1, [&](std::size_t b, std::size_t e) {
    std::string records;
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t m = first[i + 1] - first[i];
      records.resize(m * h.record_length);
      for (std::size_t j = 0; j < m; ++j)
        std::memcpy(records.data() + j * h.record_length,
                    h.records + std::size_t(order[first[i] + j]) * h.record_length, h.record_length);
      encode_laz_chunk(layout, reinterpret_cast<const unsigned char*>(records.data()), m, out.chunks[i]);
      out.points[i] = static_cast<std::uint32_t>(std::min<std::size_t>(m, UINT32_MAX));
      out.bytes[i] = static_cast<std::uint32_t>(std::min<std::size_t>(out.chunks[i].size(), UINT32_MAX));
    }
  });
  // The hierarchy's entries hold a node's points and bytes in 32-bit signed integers.
  for (std::size_t i = 0; i < nodes; ++i)
    if (out.points[i] > INT32_MAX || out.bytes[i] > INT32_MAX)
      throw std::invalid_argument("COPC: an octree node of " + std::to_string(first[i + 1] - first[i]) +
                                  " points is more than a hierarchy entry can hold (duplicate points?)");
  return out;
}

/// The 160 bytes of the COPC info VLR.
std::string copc_info_vlr(const cube& c, std::uint64_t root_offset, std::uint64_t root_size) {
  std::string body(160, '\0');
  auto* p = reinterpret_cast<unsigned char*>(body.data());
  for (int k = 0; k < 3; ++k) store_le<double>(p + 8 * k, c.center[k]);
  store_le<double>(p + 24, c.halfsize);
  store_le<double>(p + 32, 2 * c.halfsize / double(1 << k_grid_bits));
  store_le<std::uint64_t>(p + 40, root_offset);
  store_le<std::uint64_t>(p + 48, root_size);
  store_le<double>(p + 56, c.gps[0]);
  store_le<double>(p + 64, c.gps[1]);
  return vlr_header("copc", 1, body.size(), "COPC info") + body;
}

}  // namespace

std::string copc_from_las(std::string_view las, const std::string& name) {
  const las_head h = parse_las14(las, name);
  const cube c = cube_of(h);
  const laz_layout layout = layered_layout(h.format, h.record_length);
  const coded_nodes nodes = code_nodes(h, layout, assign_nodes(h, c));
  // The head: the public header, the COPC info VLR (first, as COPC asks),
  // the LASzip VLR, the LAS file's VLRs.
  const std::string other_vlrs(las.substr(k_header_14, h.point_offset - k_header_14));
  const std::string laszip = laszip_vlr(layout);
  const std::size_t head = k_header_14 + k_vlr_header_bytes + 160 + laszip.size() + other_vlrs.size();
  std::uint64_t end_of_chunks = head + 8;
  for (const std::uint32_t b : nodes.bytes) end_of_chunks += b;
  const std::string table = encode_chunk_table(nodes.points, nodes.bytes, true);
  const std::uint64_t evlr = end_of_chunks + table.size();
  const std::uint64_t page_size = nodes.keys.size() * k_entry;
  std::string out;
  out.reserve(evlr + k_evlr_header + page_size);
  out.append(las.substr(0, k_header_14));
  auto* o = reinterpret_cast<unsigned char*>(out.data());
  store_le<std::uint32_t>(o + 96, static_cast<std::uint32_t>(head));
  store_le<std::uint32_t>(o + 100, static_cast<std::uint32_t>(h.vlrs + 2));
  o[104] = static_cast<unsigned char>(h.format | 0x80);
  store_le<std::uint64_t>(o + 235, evlr);
  store_le<std::uint32_t>(o + 243, 1);
  out += copc_info_vlr(c, evlr + k_evlr_header, page_size);
  out += laszip;
  out += other_vlrs;
  std::string offset(8, '\0');
  store_le<std::int64_t>(reinterpret_cast<unsigned char*>(offset.data()), std::int64_t(end_of_chunks));
  out += offset;
  // The hierarchy: one page, an entry for each node.
  std::string page(page_size, '\0');
  std::uint64_t at = head + 8;
  for (std::size_t i = 0; i < nodes.keys.size(); ++i) {
    out += nodes.chunks[i];
    auto* e = reinterpret_cast<unsigned char*>(page.data()) + i * k_entry;
    const std::uint64_t k = nodes.keys[i];
    store_le<std::int32_t>(e, std::int32_t(k >> 48));
    store_le<std::int32_t>(e + 4, std::int32_t((k >> 32) & 0xFFFF));
    store_le<std::int32_t>(e + 8, std::int32_t((k >> 16) & 0xFFFF));
    store_le<std::int32_t>(e + 12, std::int32_t(k & 0xFFFF));
    store_le<std::uint64_t>(e + 16, at);
    store_le<std::int32_t>(e + 24, std::int32_t(nodes.bytes[i]));
    store_le<std::int32_t>(e + 28, std::int32_t(nodes.points[i]));
    at += nodes.bytes[i];
  }
  out += table;
  std::string evlr_header(k_evlr_header, '\0');
  auto* v = reinterpret_cast<unsigned char*>(evlr_header.data());
  std::memcpy(v + 2, "copc", 4);
  store_le<std::uint16_t>(v + 18, 1000);
  store_le<std::uint64_t>(v + 20, page_size);
  std::memcpy(v + 28, "EPT hierarchy", 13);
  out += evlr_header;
  out += page;
  return out;
}

void write_copc(std::ostream& out, const point_cloud& cloud, const las_write_options* options) {
  std::ostringstream las;
  write_las(las, cloud, options ? *options : las_write_options{});  // LAS 1.4: point format 6, 7 or 8
  const std::string copc = copc_from_las(las.str(), "the LAS records of the output");
  out.write(copc.data(), static_cast<std::streamsize>(copc.size()));
}

}  // namespace ced::io::detail
