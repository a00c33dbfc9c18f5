// SPDX-License-Identifier: MIT
// PCD read chunk by chunk (binary), and its entry in the table of formats.
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
#include <set>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <unordered_set>

#include "ced/io/pcd.hpp"
#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/pcd/layout.hpp"

namespace ced::io {

using namespace detail;
using namespace pcd_detail;

namespace {
/// The points of a binary PCD file, chunk by chunk (read_pcd()'s semantics,
/// but every record is kept: non-finite points too).
class pcd_stream final : public box_stream {
 public:
  pcd_stream(std::unique_ptr<input_file> file, pcd_header h, const std::array<std::size_t, 3>& axis,
             const field_selection& fields)
      : m_file(std::move(file)),
        m_h(std::move(h)),
        m_layout(record_layout(m_h, axis, fields)),
        m_point_size(point_size_of(m_h)) {
    check_binary_size(m_h, m_file->size() - m_h.body_offset, m_file->path());
  }

  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(m_h.points - m_next, max));
    if (n == 0) {
      out = point_cloud();
      if (m_next == m_h.points) m_first_pass_done = true;
      return 0;
    }
    const record_source src(*m_file, m_h.body_offset + m_next * m_point_size, m_point_size);
    if (!m_first_pass_done) m_box.merge(scan_points(src, n, m_layout).box);
    out = decode_points(src, n, m_layout, origin);
    m_next += n;
    return n;
  }
  void rewind() override { m_next = 0; }
  std::string details() const override { return pcd_details(info_of(m_h)); }
  std::uint64_t declared_points() const noexcept override { return m_h.points; }
  std::vector<point_run> chunk_runs() const override { return fixed_runs(m_h.points); }
  void read_run(const point_run& r, const std::vector<std::string>& fields, const std::array<double, 3>& origin,
                point_cloud& out) override {
    (void)fields;  // PCD has no flags
    check_run(r, m_h.points, true);
    m_first_pass_done = true;
    const record_source src(*m_file, m_h.body_offset + r.first * m_point_size, m_point_size);
    out = decode_points(src, static_cast<std::size_t>(r.count), m_layout, origin);
  }
  /// The records at `at`, decoded as read() decodes them.
  bool read_points(const std::vector<std::uint64_t>& at, const std::vector<std::string>& fields,
                   const std::array<double, 3>& origin, point_cloud& out) override {
    (void)fields;  // PCD has no flags
    check_point_indices(at, m_h.points);
    m_first_pass_done = true;
    const std::string records = gather_records(*m_file, m_h.body_offset, m_point_size, at);
    out = decode_points(record_source(reinterpret_cast<const unsigned char*>(records.data()), m_point_size), at.size(),
                        m_layout, origin);
    return true;
  }

 private:
  std::unique_ptr<input_file> m_file;
  pcd_header m_h;
  point_layout m_layout;  // decoded as read_pcd() decodes binary records
  std::size_t m_point_size;
  std::uint64_t m_next = 0;
};
}  // namespace

namespace detail {

std::string pcd_details(const pcd_read_info& info) {
  return "PCD " + info.data_format +
         (info.organized ? ", organized " + std::to_string(info.width) + "x" + std::to_string(info.height)
                         : std::string());
}

std::unique_ptr<point_stream> open_pcd_stream(const std::string& path, const field_selection& fields) {
  auto file = std::make_unique<input_file>(path);
  std::array<std::size_t, 3> axis{};
  pcd_header h = file->parse_header([&](const header_source& src) { return checked_header(src, path, axis); });
  if (h.format != pcd_format::binary) return nullptr;
  return std::make_unique<pcd_stream>(std::move(file), std::move(h), axis, fields);
}

point_cloud read_pcd_file(const std::string& path, pcd_read_info* info, bool keep_nonfinite,
                          const field_selection& fields) {
  return read_pcd_path(path, info, keep_nonfinite, fields);
}

format_entry pcd_entry() {
  format_entry e;
  e.id = file_format::pcd;
  e.name = "pcd";
  e.extensions = {"pcd"};
  e.read = [](const std::string& path, const read_options& o, read_report& r) {
    pcd_read_info info;
    point_cloud c = read_pcd_file(path, &info, o.keep_nonfinite, o.fields);
    r.nonfinite_removed = info.nonfinite_removed;
    r.details = pcd_details(info);
    return c;
  };
  e.write = [](std::ostream& out, const point_cloud& c, const las_write_options*) {
    write_pcd(out, c, pcd_format::binary);
  };
  e.pieces = [](std::ostream& out, const point_cloud& layout, std::uint64_t n) { return pcd_pieces(out, layout, n); };
  e.stream = [](const std::string& path, const read_options& o) { return open_pcd_stream(path, o.fields); };
  return e;
}
}  // namespace detail

}  // namespace ced::io
