// SPDX-License-Identifier: MIT
// LAS, LAZ and COPC read chunk by chunk (ced/io/stream.hpp), COPC nodes by box.
#include "ced/io/stream.hpp"

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
#include "ced/version.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/las/layout.hpp"
#include "io/laz/types.hpp"

namespace ced::io {

using namespace las_detail;

namespace {
/// read_las(), chunk by chunk: the header and VLRs once, then the records.
class las_stream final : public point_stream {
 public:
  las_stream(const std::string& path, const field_selection& fields) : m_file(path), m_fields(fields) {
    const std::string head = read_head(m_file);
    const auto* d = reinterpret_cast<const unsigned char*>(head.data());
    m_header = read_header(d, static_cast<std::size_t>(m_file.size()), path);
    laz_layout layout;
    m_extras = read_vlrs(d, m_header, path, &layout, &m_copc);
    if (m_header.compressed) m_laz = open_laz(m_header, layout, m_file.size(), file_reader(m_file), path);
    las_read_info info;
    fill_info(info, m_header, d);
    info.copc = m_copc.has_value();
    m_details = las_details(info);
  }

  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    const std::uint64_t left = m_header.count - m_next;
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(left, max));
    point_cloud last = std::move(out);  // its memory, for this chunk
    out = point_cloud();
    if (n == 0) {
      m_first_pass_done = true;
      return 0;
    }
    const std::size_t stride = m_header.record_length;
    const record_source src =
        m_header.compressed ? window(n) : record_source(m_file, m_header.point_offset + m_next * stride, stride);
    // During the first pass, the chunk's own flags decide its flag fields.
    const unsigned* flag_bits = m_scan.flags;
    record_scan chunk;
    if (!m_first_pass_done) {
      chunk = scan_records(src, n);
      if (m_next == 0) m_scan.any = false;
      m_scan.merge(chunk);
      flag_bits = chunk.flags;
    }
    out = decode_records(src, n, m_header, origin, plan_columns(m_header, m_extras, m_fields, flag_bits),
                         std::move(last));
    m_next += n;
    return n;
  }
  void rewind() override { m_next = 0; }
  std::array<double, 3> origin() const override {
    if (m_header.count == 0) return {0, 0, 0};
    return las_origin(m_scan.lo, m_scan.hi, m_header);
  }
  void bounds(double lo[3], double hi[3]) const override {
    for (std::size_t k = 0; k < 3; ++k) {
      const double a = m_scan.lo[k] * m_header.scale[k] + m_header.offset[k];
      const double b = m_scan.hi[k] * m_header.scale[k] + m_header.offset[k];
      lo[k] = std::min(a, b);
      hi[k] = std::max(a, b);
    }
  }
  std::string details() const override { return m_details; }
  bool streaming() const noexcept override { return true; }
  std::uint64_t declared_points() const noexcept override { return m_header.count; }

  std::optional<std::vector<index_node>> index_nodes() override {
    if (!m_copc) return std::nullopt;
    if (!m_nodes) m_nodes = read_copc_hierarchy(*m_copc, m_file.size(), file_reader(m_file), m_file.path());
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    std::vector<index_node> out;
    out.reserve(m_nodes->size());
    for (const copc_node& n : *m_nodes) {
      const auto it = std::lower_bound(chunks.begin(), chunks.end(), n.offset,
                                       [](const laz_chunk& c, std::uint64_t o) { return c.offset < o; });
      if (it == chunks.end() || it->offset != n.offset || it->points != std::uint64_t(n.points))
        throw io_error(m_file.path(), "COPC node " + std::to_string(n.depth) + "-" + std::to_string(n.x) + "-" +
                                          std::to_string(n.y) + "-" + std::to_string(n.z) + " (" +
                                          std::to_string(n.points) + " points at byte " + std::to_string(n.offset) +
                                          ") is not a chunk of the chunk table");
      index_node& e = out.emplace_back();
      n.box(*m_copc, e.box.data());
      e.run = {it->first_point, it->points};
    }
    return out;
  }
  std::vector<point_run> chunk_runs() const override {
    std::vector<point_run> out;
    if (m_header.compressed) {
      for (const laz_chunk& c : m_laz.chunks)
        if (c.points > 0) out.push_back({c.first_point, c.points});
      return out;
    }
    return fixed_runs(m_header.count);
  }
  std::vector<std::string> flags_set() const override {
    std::vector<std::string> out;
    for (const flag_spec& fl : flags_of(m_header.layout->extended))
      if ((m_scan.flags[fl.offset - 14] >> fl.shift) & fl.mask) out.push_back(fl.name);
    return out;
  }
  bool header_bounds(double lo[3], double hi[3]) const override {
    double box[6];
    if (!las_header_box(m_header.min.data(), m_header.max.data(), m_header.scale.data(), 0, box)) return false;
    std::copy_n(m_header.min.begin(), 3, lo);
    std::copy_n(m_header.max.begin(), 3, hi);
    return true;
  }
  bool header_box(double growth, double box[6]) const override {
    return las_header_box(m_header.min.data(), m_header.max.data(), m_header.scale.data(), growth, box);
  }

  bool read_points(const std::vector<std::uint64_t>& at, const std::vector<std::string>& fields,
                   const std::array<double, 3>& origin, point_cloud& out) override {
    take_flags(fields);
    if (at.empty()) {
      out = point_cloud();
      return true;
    }
    check_point_indices(at, m_header.count);
    const std::size_t stride = m_header.record_length;
    const std::string gathered =
        m_header.compressed ? gather_compressed(at) : gather_records(m_file, m_header.point_offset, stride, at);
    const record_source src(reinterpret_cast<const unsigned char*>(gathered.data()), stride);
    out = decode_records(src, at.size(), m_header, origin, plan_columns(m_header, m_extras, m_fields, m_scan.flags));
    return true;
  }

  void read_run(const point_run& r, const std::vector<std::string>& fields, const std::array<double, 3>& origin,
                point_cloud& out) override {
    take_flags(fields);
    check_run(r, m_header.count, true);
    m_next = r.first;
    read(static_cast<std::size_t>(r.count), origin, out);
  }

 private:
  /// LAZ: the records at `at` (ascending, in the file), back to back,
  /// decoding only the chunks that hold them (the chunk table says where
  /// each starts), up to 8 consecutive ones at a time, in parallel.
  std::string gather_compressed(const std::vector<std::uint64_t>& at) const {
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    const std::size_t stride = m_header.record_length, most = 8;
    std::string out(at.size() * stride, '\0');
    const auto end_of = [&](std::size_t c) { return chunks[c].first_point + chunks[c].points; };
    for (std::size_t j = 0; j < at.size();) {
      const std::size_t c0 = chunk_of(at[j]);
      std::size_t c1 = c0 + 1, e = j;
      for (;;) {  // the points of chunks [c0, c1); the next chunk joins when it holds the next point
        while (e < at.size() && at[e] < end_of(c1 - 1)) ++e;
        if (e == at.size() || c1 - c0 == most || chunk_of(at[e]) != c1) break;
        ++c1;
      }
      const big_bytes records = decode_laz(m_laz, c0, c1, file_reader(m_file), m_file.path(), wanted_of(m_fields));
      const std::uint64_t first = chunks[c0].first_point;
      for (; j < e; ++j)
        std::memcpy(&out[j * stride], records.data() + static_cast<std::size_t>((at[j] - first) * stride), stride);
    }
    return out;
  }

  /// LAZ: the chunk that holds file point `point`.
  std::size_t chunk_of(std::uint64_t point) const {
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    const auto it = std::upper_bound(chunks.begin(), chunks.end(), point,
                                     [](std::uint64_t p, const laz_chunk& c) { return p < c.first_point; });
    return static_cast<std::size_t>(it - chunks.begin()) - 1;
  }

  bool take_fields(const std::vector<std::string>& fields) override {
    take_flags(fields);
    return true;
  }

  /// The flags the whole file has, from their names (`fields`), as a
  /// complete pass decides them: the pass is then spent.
  void take_flags(const std::vector<std::string>& fields) {
    record_scan named;
    const format_layout& layout = *m_header.layout;
    for (const std::string& f : fields)
      for (const flag_spec& fl : flags_of(layout.extended))
        if (f == fl.name) named.flags[fl.offset - 14] |= fl.mask << fl.shift;
    m_scan.flags[0] = named.flags[0];
    m_scan.flags[1] = named.flags[1];
    m_first_pass_done = true;
  }

  /// LAZ: the records [m_next, m_next + n) in memory, from the chunks that hold
  /// them, decoded (the last ones are kept for the next call).
  record_source window(std::size_t n) {
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    const std::size_t stride = m_header.record_length;
    if (m_next < m_window_first || m_next + n > m_window_first + m_window.size() / stride) {
      const std::size_t c0 = chunk_of(m_next), c1 = chunk_of(m_next + n - 1) + 1;
      m_window = decode_laz(m_laz, c0, c1, file_reader(m_file), m_file.path(), wanted_of(m_fields));
      m_window_first = chunks[c0].first_point;
    }
    return {reinterpret_cast<const unsigned char*>(m_window.data()) + (m_next - m_window_first) * stride, stride};
  }

  input_file m_file;
  laz_points m_laz;                               ///< LAZ only
  std::optional<copc_info> m_copc;                ///< COPC only
  std::optional<std::vector<copc_node>> m_nodes;  ///< of the hierarchy, when asked
  big_bytes m_window;
  std::uint64_t m_window_first = 0;
  field_selection m_fields;
  las_header m_header;
  std::vector<extra_desc> m_extras;
  std::string m_details;
  std::uint64_t m_next = 0;
  bool m_first_pass_done = false;
  record_scan m_scan;  ///< of the points read in the first pass: the whole file's, once it is done
};
}  // namespace

las_read_info read_las_info(const std::string& path) {
  input_file file(path);
  const std::string head = read_head(file);
  const auto* d = reinterpret_cast<const unsigned char*>(head.data());
  const las_header h = read_header(d, static_cast<std::size_t>(file.size()), path);
  laz_layout layout;
  std::optional<copc_info> copc;
  std::vector<std::string> others;
  std::string crs;
  read_vlrs(d, h, path, &layout, &copc, &others, &crs);
  las_read_info info;
  fill_info(info, h, d);
  info.copc = copc.has_value();
  info.other_vlrs = std::move(others);
  info.coordinate_system = std::move(crs);
  return info;
}

std::unique_ptr<point_stream> open_las_stream(const std::string& path, const field_selection& fields) {
  return std::make_unique<las_stream>(path, fields);
}

}  // namespace ced::io
