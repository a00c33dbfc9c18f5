// SPDX-License-Identifier: MIT
// LAS, LAZ and COPC written in pieces (cloud_writer), and LAZ made from LAS.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>
#include <type_traits>
#include <vector>

#include "ced/io/las.hpp"
#include "ced/io/stream.hpp"
#include "ced/version.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/las/layout.hpp"
#include "io/laz/types.hpp"

namespace ced::io {

using namespace las_detail;

namespace detail {
namespace {
/// The head of a LAZ file (up to its point data) from a LAS file's head (up
/// to its point data): the LASzip VLR after the VLRs (before any bytes
/// between them and the points), the format byte's compression bit, the
/// point data's offset and the VLR count.
std::string laz_head(std::string_view las_head, const laz_layout& layout) {
  const auto* d = reinterpret_cast<const unsigned char*>(las_head.data());
  const std::uint32_t n_vlrs = load_le<std::uint32_t>(d + 100);
  std::size_t vlr_end = load_le<std::uint16_t>(d + 94);
  for (std::uint32_t i = 0; i < n_vlrs; ++i) vlr_end += k_vlr_header_size + load_le<std::uint16_t>(d + vlr_end + 20);
  const std::string vlr = laszip_vlr(layout);
  std::string out(las_head.substr(0, vlr_end));
  out += vlr;
  out += las_head.substr(vlr_end);
  auto* o = reinterpret_cast<unsigned char*>(out.data());
  store_le<std::uint32_t>(o + 96, static_cast<std::uint32_t>(out.size()));
  store_le<std::uint32_t>(o + 100, n_vlrs + 1);
  o[104] = static_cast<unsigned char>(d[104] | 0x80);
  return out;
}

void append_i64(std::string& s, std::int64_t v) {
  s.append(8, '\0');
  store_le<std::int64_t>(reinterpret_cast<unsigned char*>(s.data()) + s.size() - 8, v);
}

/// LAS in pieces: a header of the right size first, rewritten with the
/// bounds and counts of all the points once they are written.
class las_piece_writer final : public piece_writer {
 public:
  las_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n, const las_write_options& options = {})
      : m_layout(layout), m_opt(options) {
    check_writable(m_layout, m_opt, n);
    const std::string header = make_header(m_layout, m_opt, plan_records(m_layout, m_opt), m_stats);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    check_writable(chunk, m_opt, m_stats.n + chunk.size());
    const las_plan plan = plan_records(chunk, m_opt);
    add_stats(chunk, m_opt, plan, m_stats);
    write_records(out, chunk, m_opt, plan);
  }
  std::string final_header() override { return make_header(m_layout, m_opt, plan_records(m_layout, m_opt), m_stats); }

 private:
  point_cloud m_layout;
  las_write_options m_opt;
  las_stats m_stats;
};
/// LAZ in pieces: the LAS 1.2 records of a las_piece_writer, coded in chunks
/// of 50,000 points as they fill, the last chunk and the chunk table at the
/// end, then the header again with its bounds and the table's offset: the
/// bytes write_laz() writes for the whole cloud.
class laz_piece_writer final : public piece_writer {
 public:
  laz_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
    las_write_options o;
    o.version_minor = 2;
    std::ostringstream head;
    m_las = std::make_unique<las_piece_writer>(head, layout, n, o);
    const std::string las_head = head.str();
    const auto* d = reinterpret_cast<const unsigned char*>(las_head.data());
    m_layout = pointwise_layout(d[104], load_le<std::uint16_t>(d + 105), k_laz_chunk_points);
    const std::string h = laz_head(las_head, m_layout);
    m_head_size = h.size();
    out.write(h.data(), static_cast<std::streamsize>(h.size()));
    out.write("\0\0\0\0\0\0\0\0", 8);  // the chunk table's offset, known at the end
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    std::ostringstream records;
    m_las->write(records, chunk);
    m_pending += records.str();
    const std::size_t full = std::size_t(k_laz_chunk_points) * m_layout.record_length;
    std::size_t at = 0;
    for (; m_pending.size() - at >= full; at += full) code(out, m_pending.data() + at, k_laz_chunk_points);
    m_pending.erase(0, at);
  }
  void finish(std::ostream& out) override {
    if (!m_pending.empty())
      code(out, m_pending.data(), static_cast<std::uint32_t>(m_pending.size() / m_layout.record_length));
    m_pending.clear();
    const std::string table = encode_chunk_table(m_points, m_bytes, false);
    out.write(table.data(), static_cast<std::streamsize>(table.size()));
  }
  std::string final_header() override {
    std::string h = laz_head(m_las->final_header(), m_layout);
    std::uint64_t table = m_head_size + 8;
    for (std::uint32_t b : m_bytes) table += b;
    append_i64(h, std::int64_t(table));
    return h;
  }

 private:
  void code(std::ostream& out, const char* records, std::uint32_t points) {
    std::string c;
    encode_laz_chunk(m_layout, reinterpret_cast<const unsigned char*>(records), points, c);
    out.write(c.data(), static_cast<std::streamsize>(c.size()));
    m_points.push_back(points);
    m_bytes.push_back(static_cast<std::uint32_t>(c.size()));
  }

  std::unique_ptr<las_piece_writer> m_las;
  laz_layout m_layout;
  std::size_t m_head_size = 0;
  std::string m_pending;  ///< records of the chunk being filled
  std::vector<std::uint32_t> m_points, m_bytes;
};
/// COPC in pieces: the LAS 1.4 file of a las_piece_writer held in memory,
/// written as COPC at the end (its octree needs every point).
class copc_piece_writer final : public piece_writer {
 public:
  copc_piece_writer(const point_cloud& layout, std::uint64_t n) : m_las(m_buffer, layout, n) {}
  void write(std::ostream&, const point_cloud& chunk) override { m_las.write(m_buffer, chunk); }
  void finish(std::ostream& out) override {
    std::string las = m_buffer.str();
    const std::string header = m_las.final_header();
    las.replace(0, header.size(), header);
    const std::string copc = copc_from_las(las, "the LAS records of the output");
    out.write(copc.data(), static_cast<std::streamsize>(copc.size()));
  }

 private:
  std::ostringstream m_buffer;
  las_piece_writer m_las;
};
}  // namespace

std::unique_ptr<piece_writer> copc_pieces(const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<copc_piece_writer>(layout, n);
}

std::unique_ptr<piece_writer> las_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<las_piece_writer>(out, layout, n);
}

std::unique_ptr<piece_writer> laz_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<laz_piece_writer>(out, layout, n);
}

std::string las_point_records(std::string_view bytes, const std::string& name) {
  const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
  const las_header h = read_header(d, bytes.size(), name);
  laz_layout layout;
  read_vlrs(d, h, name, &layout);
  if (!h.compressed) return std::string(bytes.substr(h.point_offset, h.count * h.record_length));
  const laz_read_fn read = memory_reader(bytes, name);
  const laz_points z = open_laz(h, layout, bytes.size(), read, name);
  const big_bytes records = decode_laz(z, 0, z.chunks.size(), read, name);
  return std::string(records.data(), records.size());
}

las_head read_las_head(std::string_view las, const std::string& name) {
  const auto* d = reinterpret_cast<const unsigned char*>(las.data());
  const las_header h = read_header(d, las.size(), name);
  read_vlrs(d, h, name);
  if (h.compressed) throw std::invalid_argument(name + ": already compressed");
  las_head out;
  out.records = d + h.point_offset;
  out.header_size = h.header_size;
  out.point_offset = h.point_offset;
  out.record_length = h.record_length;
  out.vlrs = h.n_vlrs;
  out.count = h.count;
  if (h.minor >= 4) {
    out.evlr_offset = load_le<std::uint64_t>(d + 235);
    out.evlr_count = load_le<std::uint32_t>(d + 243);
  }
  out.minor = h.minor;
  out.format = h.format;
  out.scale = h.scale;
  out.offset = h.offset;
  return out;
}

std::string laz_from_las(std::string_view las, const std::string& name, std::uint32_t chunk_size,
                         const std::vector<std::uint32_t>& chunk_points) {
  const las_head h = read_las_head(las, name);
  const bool layered = h.format >= 6 && h.format <= 8;
  if (h.format > 3 && !layered)
    throw std::invalid_argument(name + ": LAZ is written for point formats 0-3 and 6-8 only");
  if (h.evlr_offset != 0 || h.evlr_count != 0)
    throw std::invalid_argument(name + ": extended VLRs are not carried into LAZ");
  // Layered chunks (formats 6-8) are variable: chunks of chunk_size points
  // unless chunk_points says otherwise.
  std::vector<std::uint32_t> points = chunk_points;
  if (layered && points.empty() && chunk_size > 0)
    for (std::uint64_t left = h.count; left > 0; left -= points.back())
      points.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(left, chunk_size)));
  const bool variable = !points.empty() || layered;
  if (!variable && chunk_size == 0) throw std::invalid_argument("laz_from_las: a chunk size of 0");
  const laz_layout layout = layered ? layered_layout(h.format, h.record_length)
                                    : pointwise_layout(h.format, h.record_length, variable ? 0xFFFFFFFFu : chunk_size);
  // The chunks' points, and their bytes coded in parallel.
  if (!variable)
    for (std::uint64_t left = h.count; left > 0; left -= points.back())
      points.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(left, chunk_size)));
  std::vector<std::uint64_t> first(points.size() + 1, 0);
  for (std::size_t i = 0; i < points.size(); ++i) first[i + 1] = first[i] + points[i];
  if (first.back() != h.count) throw std::invalid_argument("laz_from_las: the chunks do not hold the points");
  std::vector<std::string> coded(points.size());
  ced::detail::parallel_for(points.size(), 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i)
      encode_laz_chunk(layout, h.records + first[i] * h.record_length, points[i], coded[i]);
  });
  std::vector<std::uint32_t> bytes;
  for (const std::string& c : coded) bytes.push_back(static_cast<std::uint32_t>(c.size()));
  std::string out = laz_head(las.substr(0, h.point_offset), layout);
  std::uint64_t table = out.size() + 8;
  for (const std::string& c : coded) table += c.size();
  append_i64(out, std::int64_t(table));
  for (const std::string& c : coded) out += c;
  out += encode_chunk_table(points, bytes, variable);
  return out;
}

void write_laz(std::ostream& out, const point_cloud& cloud, const las_write_options* options) {
  std::ostringstream las;
  las_write_options o;
  if (options)
    o = *options;
  else
    o.version_minor = 2;
  write_las(las, cloud, o);
  const std::string laz = laz_from_las(las.str(), "the LAS records of the output");
  out.write(laz.data(), static_cast<std::streamsize>(laz.size()));
}

}  // namespace detail

}  // namespace ced::io
