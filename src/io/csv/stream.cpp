// SPDX-License-Identifier: MIT
// CSV read chunk by chunk, and its entry in the table of formats.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <set>
#include <system_error>
#include <type_traits>

#include "ced/io/csv.hpp"
#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/csv/layout.hpp"

namespace ced::io {

using namespace detail;
using namespace csv_detail;

namespace {
/// A CSV file's points, line by line (read_csv()'s semantics). The column
/// types depend on every value: until a first pass has seen them all, the
/// fields are float64.
class csv_stream final : public box_stream {
 public:
  csv_stream(std::unique_ptr<input_file> file, const csv_options& options, const field_selection& fields)
      : m_file(std::move(file)), m_opt(options), m_fields(fields), m_in(*m_file, 0) {
    std::string text;
    m_file->read_some(0, 3, text);
    const std::uint64_t start = has_bom(text) ? 3 : 0;
    // The lines up to the third that is neither blank nor a comment: all
    // that read_layout() reads.
    m_in.seek(start);
    std::string_view line;
    for (int content = 0; content < 3 && m_in.next_line(line);) {
      line = trim(line);
      if (!line.empty() && !is_comment(line)) ++content;
    }
    m_file->read_some(start, static_cast<std::size_t>(m_in.offset() - start), text);
    m_layout = read_layout(text, m_opt, m_file->path());
    m_start = start + m_layout.data_start.pos;
    m_layout.data_start.text = {};  // that was `text`'s
    m_stats.resize(m_layout.names.size());
    m_cols.resize(m_layout.names.size());
    rewind();
  }

  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    out = point_cloud();
    if (max == 0) return 0;
    const std::vector<std::string>& names = m_layout.names;
    if (names.empty() || !m_layout.have_data) {
      m_first_pass_done = true;
      return 0;
    }
    for (auto& c : m_cols) c.clear();
    std::size_t n = 0;
    std::string_view line;
    while (n < max && m_in.next_line(line)) {
      ++m_line_no;
      line = trim(line);
      if (line.empty() || is_comment(line)) continue;
      parse_row(line, m_line_no, m_next + n == 0, m_layout.delim, names, m_opt, m_file->path(), m_tok,
                [&](std::size_t j, double v, bool is_int) {
                  m_cols[j].push_back(v);
                  if (!m_first_pass_done) m_stats[j].add(v, is_int);
                });
      ++n;
    }
    if (n == 0) {
      if (!m_first_pass_done) m_points = m_next;
      m_first_pass_done = true;
      return 0;
    }
    const auto& axis = m_layout.axis;
    set_positions(out, m_cols[axis[0]].data(), m_cols[axis[1]].data(), m_cols[axis[2]].data(), n, origin);
    for (std::size_t j = 0; j < names.size(); ++j) {
      if (j == axis[0] || j == axis[1] || j == axis[2] || !m_fields.wants(names[j])) continue;
      const scalar_type t = m_first_pass_done ? m_stats[j].type(names[j], m_points) : scalar_type::float64;
      out.add_field(names[j], t, m_cols[j]);
    }
    m_next += n;
    return n;
  }
  void rewind() override {
    m_in.seek(m_start);
    m_line_no = m_layout.data_start.line_no;
    m_next = 0;
  }
  std::string details() const override { return "CSV"; }

 private:
  std::unique_ptr<input_file> m_file;
  csv_options m_opt;
  field_selection m_fields;
  sequential_reader m_in;
  csv_layout m_layout;
  std::uint64_t m_start = 0;  // the first data line's offset
  std::size_t m_line_no = 0;  // of the last line read
  std::uint64_t m_next = 0, m_points = 0;
  std::vector<column_stats> m_stats;
  std::vector<std::vector<double>> m_cols;  // the chunk's values
  std::vector<std::string_view> m_tok;
};
}  // namespace

namespace detail {

std::unique_ptr<point_stream> open_csv_stream(const std::string& path, const csv_options& options,
                                              const field_selection& fields) {
  return std::make_unique<csv_stream>(std::make_unique<input_file>(path), options, fields);
}

format_entry csv_entry() {
  format_entry e;
  e.id = file_format::csv;
  e.name = "csv";
  e.aliases = {"xyz", "txt", "pts"};
  e.extensions = {"csv", "xyz", "txt", "pts"};
  e.read = [](const std::string& path, const read_options& o, read_report& r) {
    point_cloud c = read_csv(path, o.csv);
    r.details = "CSV";
    return c;
  };
  e.write = [](std::ostream& out, const point_cloud& c, const las_write_options*) { write_csv(out, c); };
  e.pieces = [](std::ostream& out, const point_cloud& layout, std::uint64_t n) { return csv_pieces(out, layout, n); };
  e.stream = [](const std::string& path, const read_options& o) { return open_csv_stream(path, o.csv, o.fields); };
  return e;
}
}  // namespace detail

}  // namespace ced::io
