// SPDX-License-Identifier: MIT
// PLY read whole: binary and ascii elements into typed columns.
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

namespace ply_detail {

/// Reads (cols != nullptr) or skips element `e` starting at data[pos]; returns
/// the offset just after it.
std::size_t read_binary_element(std::string_view data, std::size_t pos, const element_desc& e, bool swap, columns* cols,
                                const std::string& file) {
  const record_size r = record_size_of(e);
  if (e.count == 0 || r.min == 0) return pos;
  check_count(e, r, data.size() - pos, file);
  const auto n = static_cast<std::size_t>(e.count);  // <= 2 * available + 16: allocation is bounded
  if (cols)
    for (std::size_t j = 0; j < e.props.size(); ++j)
      if (!e.props[j].is_list) (*cols)[j].resize(n);

  const auto* begin = reinterpret_cast<const unsigned char*>(data.data());
  const unsigned char* p = begin + pos;
  if (r.fixed) {
    if (cols) {
      std::size_t offset = 0;
      for (std::size_t j = 0; j < e.props.size(); ++j) {
        decode_column(p + offset, r.min, n, e.props[j].type, swap, (*cols)[j].data());
        offset += size_of(e.props[j].type);
      }
    }
    return pos + n * r.min;
  }

  memory_cursor in{p, begin + data.size()};
  for (std::size_t i = 0; i < n; ++i)
    read_record(in, e, swap, i, n, file, [&](std::size_t j, double v) {
      if (cols) (*cols)[j][i] = v;
    });
  return static_cast<std::size_t>(in.p - begin);
}

// -------------------------------------------------------------- ascii body

/// Where value `tok` of record i, property `prop`, is: "vertex 12, property 'red': 'abc' ".
std::string ascii_where(const element_desc& e, std::size_t i, const property_desc& prop, std::string_view tok) {
  return e.name + " " + std::to_string(i) + ", property '" + prop.name + "': '" + std::string(tok) + "' ";
}

/// Fails: value `tok` of record i, property `prop`, is not one (status s).
[[noreturn]] void fail_ascii_value(const std::string& file, const element_desc& e, std::size_t i,
                                   const property_desc& prop, std::string_view tok, parse_status s) {
  fail_value(file, ascii_where(e, i, prop, tok), s, prop.type);
}

/// Records [first, first + count) of element e (no list properties) from the
/// lines at [p, end), one a line, blank lines skipped, into `cols`. False
/// when a line holds another number of values than the element has
/// properties (the records are then not one a line). `stop`: the end of the
/// last value read.
bool read_ascii_lines(const char* p, const char* const end, std::size_t first, std::size_t count, const element_desc& e,
                      columns& cols, const std::string& file, const char*& stop) {
  const std::size_t np = e.props.size();
  std::string_view tok;
  for (std::size_t i = first; i < first + count;) {
    const auto* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    word_reader<> words(std::string_view(p, static_cast<std::size_t>((nl ? nl : end) - p)));
    p = nl ? nl + 1 : end;
    std::size_t j = 0;
    for (; words.next(tok); ++j) {
      if (j == np) return false;
      double v = 0;
      const parse_status s = parse_ascii_value(tok, e.props[j].type, v);
      if (s != parse_status::ok) {
        // A line with too few values is not one record: that comes first.
        std::size_t more = 0;
        for (std::string_view w; words.next(w);) ++more;
        if (j + 1 + more != np) return false;
        fail_ascii_value(file, e, i, e.props[j], tok, s);
      }
      cols[j][i] = v;
      stop = words.p;
    }
    if (j == 0) continue;  // blank
    if (j != np) return false;
    ++i;
  }
  return true;
}

/// read_ascii_element() for an element of no list properties whose records
/// lie one a line, in blocks of whole lines on the threads; false (nothing
/// decided) when the body is small, there is one thread, or the records are
/// not one a line or fewer than declared (the word-by-word reader then reads
/// them and names any problem). `end_pos` receives where the element ends.
bool read_ascii_blocks(std::string_view data, std::size_t pos, const element_desc& e, columns& cols,
                       const std::string& file, std::size_t& end_pos) {
  const auto n = static_cast<std::size_t>(e.count);
  const char* const body = data.data() + pos;
  const char* const end = data.data() + data.size();
  const std::size_t blocks = ascii_blocks(data.size() - pos);
  if (blocks <= 1 || std::any_of(e.props.begin(), e.props.end(), [](const property_desc& p) { return p.is_list; }))
    return false;
  const std::vector<const char*> cut = cut_lines(body, end, blocks);
  std::vector<std::size_t> before(blocks + 1, 0);  // records (non-blank lines) before each block
  ced::detail::parallel_for(blocks, 0, 1, [&](std::size_t b, std::size_t k1) {
    for (std::size_t k = b; k < k1; ++k) before[k + 1] = count_lines(cut[k], cut[k + 1]).first;
  });
  for (std::size_t k = 1; k <= blocks; ++k) before[k] += before[k - 1];
  if (before[blocks] < n) return false;
  // A line that is not one record, met before any bad value: the
  // word-by-word reader decides (what it reads there is not what the lines say).
  struct not_one_a_line {};
  std::vector<const char*> stop(blocks, nullptr);
  try {
    for_each_block(blocks, [&](std::size_t k) {
      const std::size_t first = std::min(before[k], n), last = std::min(before[k + 1], n);
      if (!read_ascii_lines(cut[k], cut[k + 1], first, last - first, e, cols, file, stop[k])) throw not_one_a_line{};
    });
  } catch (const not_one_a_line&) {
    return false;
  }
  const auto last = std::upper_bound(before.begin(), before.end(), n - 1) - before.begin() - 1;
  end_pos = static_cast<std::size_t>(stop[static_cast<std::size_t>(last)] - data.data());
  return true;
}

std::size_t read_ascii_element(std::string_view data, std::size_t pos, const element_desc& e, columns* cols,
                               const std::string& file) {
  if (e.count == 0 || e.props.empty()) return pos;
  // Each value needs at least 2 bytes (a digit and a separator); allow a
  // factor 2 of slack so that truncated files are reported as such.
  const std::size_t remaining = data.size() - pos;
  const std::uint64_t available = (remaining + 1) / (2 * e.props.size());
  if (e.count / 2 > available + 8)
    throw io_error(file, "implausible element count: '" + e.name + "' declares " + std::to_string(e.count) +
                             " records of " + std::to_string(e.props.size()) + " values, but only " +
                             std::to_string(remaining) + " bytes follow (corrupt header?)");
  const auto n = static_cast<std::size_t>(e.count);
  if (cols)
    for (std::size_t j = 0; j < e.props.size(); ++j)
      if (!e.props[j].is_list) (*cols)[j].resize(n);
  std::size_t end_pos = 0;
  if (cols && read_ascii_blocks(data, pos, e, *cols, file, end_pos)) return end_pos;

  word_reader<> tk(data.substr(pos));
  std::string_view tok;
  const auto truncated = [&](std::size_t i) { fail_truncated(file, i, n, e); };
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < e.props.size(); ++j) {
      const property_desc& prop = e.props[j];
      if (!tk.next(tok)) truncated(i);
      if (prop.is_list) {
        std::uint64_t count = 0;
        const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), count);
        if (r.ec != std::errc() || r.ptr != tok.data() + tok.size())
          throw io_error(file, ascii_where(e, i, prop, tok) + "is not a valid list length");
        for (std::uint64_t k = 0; k < count; ++k)
          if (!tk.next(tok)) truncated(i);
      } else if (cols) {
        double v = 0;
        const parse_status s = parse_ascii_value(tok, prop.type, v);
        if (s != parse_status::ok) fail_ascii_value(file, e, i, prop, tok, s);
        (*cols)[j][i] = v;
      }
    }
  }
  return static_cast<std::size_t>(tk.p - data.data());
}

// ------------------------------------------------------------------ reader

/// The layout of vertex records of fixed size: x, y, z and the selected
/// scalar properties, in order.
point_layout vertex_layout(const element_desc& v, const std::size_t axis[3], bool swap,
                           const field_selection& selection) {
  point_layout layout;
  std::size_t offset = 0;
  for (std::size_t j = 0; j < v.props.size(); ++j) {
    const property_desc& p = v.props[j];
    value_spec spec{p.name, offset, p.type, swap};
    offset += size_of(p.type);
    if (j == axis[0] || j == axis[1] || j == axis[2]) {
      layout.xyz[j == axis[0] ? 0 : j == axis[1] ? 1 : 2] = spec;
    } else if (selection.wants(p.name)) {
      layout.columns.push_back(std::move(spec));
    }
  }
  return layout;
}

/// The n fixed-size vertex records of `src` as a cloud (the origin of their
/// finite box), in parallel chunks.
point_cloud read_vertices(const record_source& src, std::uint64_t n, const point_layout& layout) {
  const points_scan scan = scan_points(src, n, layout);
  return decode_points(src, n, layout, choose_origin(scan.box.lo, scan.box.hi));
}

point_cloud parse_ply(std::string_view data, const std::string& file, const field_selection& selection) {
  const ply_header h = parse_header(header_source{data}, file);
  std::size_t axis[3] = {};
  const element_desc* vertex = &find_vertex(h, file, axis);

  // Binary vertices of a fixed size are decoded in place, in parallel; the
  // others as they are read.
  const bool fixed = h.format != ply_format::ascii && record_size_of(*vertex).fixed;
  columns cols(vertex->props.size());
  const bool swap = swapped(h.format);
  std::size_t pos = h.body_offset, vertex_pos = 0;
  for (const auto& e : h.elements) {
    if (&e == vertex) vertex_pos = pos;
    columns* target = &e == vertex && !fixed ? &cols : nullptr;
    pos = h.format == ply_format::ascii ? read_ascii_element(data, pos, e, target, file)
                                        : read_binary_element(data, pos, e, swap, target, file);
  }
  if (fixed) {
    const auto* records = reinterpret_cast<const unsigned char*>(data.data()) + vertex_pos;
    return read_vertices(record_source(records, record_size_of(*vertex).min), vertex->count,
                         vertex_layout(*vertex, axis, swap, selection));
  }

  const auto n = static_cast<std::size_t>(vertex->count);
  point_cloud cloud = cloud_at(cols[axis[0]].data(), cols[axis[1]].data(), cols[axis[2]].data(), n);
  for (std::size_t j = 0; j < vertex->props.size(); ++j) {
    const property_desc& p = vertex->props[j];
    if (p.is_list || j == axis[0] || j == axis[1] || j == axis[2] || !selection.wants(p.name)) continue;
    cloud.add_field(p.name, p.type, std::move(cols[j]));
  }
  return cloud;
}

/// Skips element e at `pos` of `file` (checking it as parse_ply() does);
/// returns the offset after it.
std::uint64_t skip_element(input_file& file, std::uint64_t pos, const element_desc& e, bool swap) {
  const record_size r = record_size_of(e);
  if (e.count == 0 || r.min == 0) return pos;
  check_count(e, r, file.size() - pos, file.path());
  const auto n = static_cast<std::size_t>(e.count);
  if (r.fixed) return pos + n * r.min;
  sequential_reader reader(file, pos);
  file_cursor in{reader};
  for (std::size_t i = 0; i < n; ++i) read_record(in, e, swap, i, n, file.path(), [](std::size_t, double) {});
  return reader.offset();
}

/// read_ply() of a file: binary vertices of a fixed size are read in
/// parallel chunks straight from the file, the other elements only checked;
/// anything else is read whole.
point_cloud read_ply_path(const std::string& path, const field_selection& selection) {
  if (!chunked_file(path)) return parse_ply(read_whole_file(path), path, selection);
  input_file file(path);
  const ply_header h = file.parse_header([&](const header_source& src) { return parse_header(src, path); });
  std::size_t axis[3] = {};
  const element_desc& vertex = find_vertex(h, path, axis);
  const record_size r = record_size_of(vertex);
  if (h.format == ply_format::ascii || !r.fixed) {
    const big_bytes data = read_all(file);
    return parse_ply(std::string_view(data.data(), data.size()), path, selection);
  }
  const bool swap = swapped(h.format);
  std::uint64_t pos = h.body_offset, vertex_pos = 0;
  for (const auto& e : h.elements) {
    if (&e == &vertex) vertex_pos = pos;
    pos = skip_element(file, pos, e, swap);
  }
  return read_vertices(record_source(file, vertex_pos, r.min), vertex.count,
                       vertex_layout(vertex, axis, swap, selection));
}

}  // namespace ply_detail

point_cloud read_ply(const std::string& path) { return read_ply_path(path, {}); }

point_cloud read_ply(std::istream& in, const std::string& name_for_errors) {
  std::string data;
  char buf[1 << 16];
  while (in.read(buf, sizeof(buf)) || in.gcount() > 0) data.append(buf, static_cast<std::size_t>(in.gcount()));
  if (in.bad()) throw io_error(name_for_errors + ": read error");
  return parse_ply(data, name_for_errors, {});
}

}  // namespace ced::io
