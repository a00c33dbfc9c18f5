// SPDX-License-Identifier: MIT
// PLY read chunk by chunk (binary), and its entry in the table of formats.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <istream>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <unordered_set>

#include "ced/io/ply.hpp"
#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/ply/layout.hpp"

namespace ced::io {

using namespace detail;
using namespace ply_detail;

namespace {
/// The vertices of a binary PLY file, chunk by chunk (read_ply()'s
/// semantics): the header once, then the records read at their offsets
/// (fixed-size records) or front to back (records with lists).
class ply_stream final : public box_stream {
 public:
  ply_stream(std::unique_ptr<input_file> file, ply_header h, const std::size_t axis[3], const field_selection& fields)
      : m_file(std::move(file)), m_h(std::move(h)), m_fields(fields), m_in(*m_file, 0), m_swap(swapped(m_h.format)) {
    std::copy_n(axis, 3, m_axis);
    std::uint64_t pos = m_h.body_offset;
    for (m_vertex = 0; m_h.elements[m_vertex].name != "vertex"; ++m_vertex)
      pos = skip_element(*m_file, pos, m_h.elements[m_vertex], m_swap);
    const element_desc& v = m_h.elements[m_vertex];
    m_record = record_size_of(v);
    if (v.count != 0) check_count(v, m_record, m_file->size() - pos, m_file->path());
    m_start = pos;
    m_in.seek(m_start);
    m_cols.resize(v.props.size());
    if (m_record.fixed) m_layout = vertex_layout(v, m_axis, m_swap, m_fields);
  }

  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    const element_desc& v = m_h.elements[m_vertex];
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(v.count - m_next, max));
    if (n == 0) {
      out = point_cloud();
      if (m_next == v.count && !m_first_pass_done) {
        check_following_elements();
        m_first_pass_done = true;
      }
      return 0;
    }
    if (m_record.fixed) {
      const record_source src(*m_file, m_start + m_next * m_record.min, m_record.min);
      if (!m_first_pass_done) m_box.merge(scan_points(src, n, m_layout).box);
      out = decode_points(src, n, m_layout, origin);
    } else {
      read_listed(n, origin, out);
    }
    m_next += n;
    return n;
  }
  void rewind() override {
    m_next = 0;
    m_in.seek(m_start);
  }
  std::string details() const override { return "PLY"; }
  std::uint64_t declared_points() const noexcept override { return m_h.elements[m_vertex].count; }
  std::vector<point_run> chunk_runs() const override {
    return m_record.fixed ? fixed_runs(declared_points()) : std::vector<point_run>{};
  }
  void read_run(const point_run& r, const std::vector<std::string>& fields, const std::array<double, 3>& origin,
                point_cloud& out) override {
    (void)fields;  // PLY has no flags
    check_run(r, declared_points(), m_record.fixed);
    m_first_pass_done = true;
    const record_source src(*m_file, m_start + r.first * m_record.min, m_record.min);
    out = decode_points(src, static_cast<std::size_t>(r.count), m_layout, origin);
  }
  /// Fixed-size records only: those at `at`, decoded as read() decodes them.
  bool read_points(const std::vector<std::uint64_t>& at, const std::vector<std::string>& fields,
                   const std::array<double, 3>& origin, point_cloud& out) override {
    (void)fields;  // PLY has no flags
    if (!m_record.fixed) return false;
    check_point_indices(at, declared_points());
    m_first_pass_done = true;
    const std::string records = gather_records(*m_file, m_start, m_record.min, at);
    out = decode_points(record_source(reinterpret_cast<const unsigned char*>(records.data()), m_record.min), at.size(),
                        m_layout, origin);
    return true;
  }

 private:
  /// The next n vertices, records with lists: read front to back.
  void read_listed(std::size_t n, const std::array<double, 3>& origin, point_cloud& out) {
    const element_desc& v = m_h.elements[m_vertex];
    for (std::size_t j = 0; j < v.props.size(); ++j)
      if (!v.props[j].is_list) m_cols[j].resize(n);
    file_cursor in{m_in};
    const auto count = static_cast<std::size_t>(v.count);
    for (std::size_t i = 0; i < n; ++i)
      read_record(in, v, m_swap, static_cast<std::size_t>(m_next) + i, count, m_file->path(),
                  [&](std::size_t j, double value) { m_cols[j][i] = value; });
    set_positions(out, m_cols[m_axis[0]].data(), m_cols[m_axis[1]].data(), m_cols[m_axis[2]].data(), n, origin);
    for (std::size_t j = 0; j < v.props.size(); ++j) {
      const property_desc& p = v.props[j];
      if (p.is_list || j == m_axis[0] || j == m_axis[1] || j == m_axis[2] || !m_fields.wants(p.name)) continue;
      out.add_field(p.name, p.type, m_cols[j]);
    }
  }
  /// After the vertices: the elements that follow them must be whole too.
  void check_following_elements() {
    const element_desc& v = m_h.elements[m_vertex];
    std::uint64_t pos = m_record.fixed ? m_start + v.count * m_record.min : m_in.offset();
    for (std::size_t e = m_vertex + 1; e < m_h.elements.size(); ++e)
      pos = skip_element(*m_file, pos, m_h.elements[e], m_swap);
  }

  std::unique_ptr<input_file> m_file;
  ply_header m_h;
  field_selection m_fields;
  sequential_reader m_in;  // records with lists: read front to back
  bool m_swap;
  std::size_t m_axis[3] = {0, 0, 0};
  std::size_t m_vertex = 0;  // the vertex element's index
  record_size m_record;      // of a vertex
  std::uint64_t m_start = 0, m_next = 0;
  point_layout m_layout;  // fixed-size records: decoded as read_ply() decodes them
  columns m_cols;         // records with lists: the chunk's values, by vertex property
};
}  // namespace

namespace detail {
point_cloud read_ply_file(const std::string& path, const field_selection& fields) {
  return read_ply_path(path, fields);
}

std::unique_ptr<point_stream> open_ply_stream(const std::string& path, const field_selection& fields) {
  auto file = std::make_unique<input_file>(path);
  ply_header h = file->parse_header([&](const header_source& src) { return parse_header(src, path); });
  std::size_t axis[3] = {0, 0, 0};
  find_vertex(h, path, axis);
  if (h.format == ply_format::ascii) return nullptr;
  return std::make_unique<ply_stream>(std::move(file), std::move(h), axis, fields);
}

format_entry ply_entry() {
  format_entry e;
  e.id = file_format::ply;
  e.name = "ply";
  e.extensions = {"ply"};
  e.read = [](const std::string& path, const read_options& o, read_report& r) {
    point_cloud c = read_ply_file(path, o.fields);
    r.details = "PLY";
    return c;
  };
  e.write = [](std::ostream& out, const point_cloud& c, const las_write_options*) {
    write_ply(out, c, ply_format::binary_little_endian);
  };
  e.pieces = [](std::ostream& out, const point_cloud& layout, std::uint64_t n) { return ply_pieces(out, layout, n); };
  e.stream = [](const std::string& path, const read_options& o) { return open_ply_stream(path, o.fields); };
  return e;
}
}  // namespace detail

}  // namespace ced::io
