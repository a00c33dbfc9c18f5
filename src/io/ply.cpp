// SPDX-License-Identifier: MIT
#include "ced/io/ply.hpp"

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

#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io {

using namespace detail;  // scalar_io.hpp

namespace {

// ---------------------------------------------------------------- utilities

// Header limits. Duplicate names are checked through sets and vertex
// properties become cloud fields through the cloud's name index, so time is
// linear in the header; the bounds only keep a header from asking for absurd
// numbers of elements or fields.
constexpr std::size_t max_elements = 65536;
constexpr std::size_t max_properties = max_values_per_point;  // per element

double read_value(const unsigned char* p, scalar_type t, bool swap) noexcept {
  double v = 0;
  visit_type(t, [&](auto tag) {
    using T = decltype(tag);
    v = swap ? static_cast<double>(load<T, true>(p)) : static_cast<double>(load<T, false>(p));
  });
  return v;
}

std::string plural(const std::string& element) {
  return element == "vertex" ? std::string("vertices") : "'" + element + "' elements";
}

// ------------------------------------------------------------------- header

struct property_desc {
  std::string name;
  scalar_type type = scalar_type::float32;
  bool is_list = false;
  scalar_type count_type = scalar_type::uint8;
};

struct element_desc {
  std::string name;
  std::uint64_t count = 0;
  std::vector<property_desc> props;
  std::unordered_set<std::string> prop_names;  // for the duplicate check
};

/// Fails: the file ends after `read` of the `count` records of element e.
[[noreturn]] void fail_truncated(const std::string& file, std::uint64_t read, std::uint64_t count,
                                 const element_desc& e) {
  throw io_error(file, "truncated: the file ends after " + std::to_string(read) + " of " + std::to_string(count) + " " +
                           plural(e.name));
}

struct ply_header {
  ply_format format = ply_format::ascii;
  std::vector<element_desc> elements;
  std::unordered_set<std::string> element_names;  // for the duplicate check
  std::size_t body_offset = 0;
};

std::optional<scalar_type> parse_type(std::string_view s) noexcept {
  using st = scalar_type;
  static constexpr std::pair<std::string_view, st> table[] = {
      {"char", st::int8},     {"int8", st::int8},       {"uchar", st::uint8},    {"uint8", st::uint8},
      {"short", st::int16},   {"int16", st::int16},     {"ushort", st::uint16},  {"uint16", st::uint16},
      {"int", st::int32},     {"int32", st::int32},     {"uint", st::uint32},    {"uint32", st::uint32},
      {"float", st::float32}, {"float32", st::float32}, {"double", st::float64}, {"float64", st::float64},
      {"int64", st::int64},   {"uint64", st::uint64}};
  for (const auto& [name, type] : table)
    if (name == s) return type;
  return std::nullopt;
}

/// One line of the header: its text, words and number (for messages).
struct header_line {
  std::string_view text;
  std::vector<std::string_view> words;
  int number = 0;
  std::string where() const { return "header line " + std::to_string(number) + ": "; }
};

/// "format ascii|binary_little_endian|binary_big_endian 1.0".
void read_format_line(const header_line& l, const std::string& file, ply_header& h) {
  const auto& w = l.words;
  if (w.size() != 3) throw io_error(file, l.where() + "malformed format line '" + std::string(l.text) + "'");
  if (w[1] == "ascii")
    h.format = ply_format::ascii;
  else if (w[1] == "binary_little_endian")
    h.format = ply_format::binary_little_endian;
  else if (w[1] == "binary_big_endian")
    h.format = ply_format::binary_big_endian;
  else
    throw io_error(file, l.where() + "unknown PLY format '" + std::string(w[1]) +
                             "' (expected ascii, binary_little_endian or binary_big_endian)");
  if (w[2] != "1.0" && w[2] != "1")
    throw io_error(file, l.where() + "unsupported PLY version '" + std::string(w[2]) + "'");
}

/// "element NAME COUNT": a new element, named once.
void read_element_line(const header_line& l, const std::string& file, ply_header& h) {
  const auto& w = l.words;
  if (w.size() != 3) throw io_error(file, l.where() + "malformed element line '" + std::string(l.text) + "'");
  element_desc e;
  e.name = std::string(w[1]);
  const auto r = std::from_chars(w[2].data(), w[2].data() + w[2].size(), e.count);
  if (r.ec != std::errc() || r.ptr != w[2].data() + w[2].size())
    throw io_error(file, l.where() + "invalid count '" + std::string(w[2]) + "' for element '" + e.name + "'");
  if (h.elements.size() >= max_elements)
    throw io_error(file, l.where() + "too many elements (more than " + std::to_string(max_elements) + ")");
  if (!h.element_names.insert(e.name).second)
    throw io_error(file, l.where() + "element '" + e.name + "' is declared twice");
  h.elements.push_back(std::move(e));
}

/// "property TYPE NAME" or "property list COUNT_TYPE TYPE NAME": a property
/// of the last element, named once in it.
void read_property_line(const header_line& l, const std::string& file, ply_header& h) {
  const auto& w = l.words;
  if (h.elements.empty()) throw io_error(file, l.where() + "property before any element");
  property_desc p;
  const auto type_of = [&](std::string_view s) {
    const auto t = parse_type(s);
    if (!t) throw io_error(file, l.where() + "unknown property type '" + std::string(s) + "'");
    return *t;
  };
  if (w.size() == 5 && w[1] == "list") {
    p.is_list = true;
    p.count_type = type_of(w[2]);
    p.type = type_of(w[3]);
    p.name = std::string(w[4]);
    if (!is_integer(p.count_type))
      throw io_error(file, l.where() + "list count type of property '" + p.name + "' must be an integer type");
  } else if (w.size() == 3 && w[1] != "list") {
    p.type = type_of(w[1]);
    p.name = std::string(w[2]);
  } else {
    throw io_error(file, l.where() + "malformed property line '" + std::string(l.text) + "'");
  }
  auto& e = h.elements.back();
  if (e.props.size() >= max_properties)
    throw io_error(file, l.where() + "element '" + e.name + "' has too many properties (more than " +
                             std::to_string(max_properties) + ")");
  if (!e.prop_names.insert(p.name).second)
    throw io_error(file, l.where() + "property '" + p.name + "' is declared twice in element '" + e.name + "'");
  e.props.push_back(std::move(p));
}

/// Parses the header (from the whole file, or from its first bytes: see
/// header_source).
ply_header parse_header(const header_source& src, const std::string& file) {
  const std::string_view data = src.text;
  if (!src.whole && data.size() < 5) throw need_more_header{};
  std::size_t pos = 0;
  if (data.substr(0, 4) == "ply\n")
    pos = 4;
  else if (data.substr(0, 5) == "ply\r\n")
    pos = 5;
  else
    throw io_error(file, "not a PLY file (it does not start with the 'ply' magic line)");
  if (!src.contains("end_header")) throw io_error(file, "the PLY header has no end_header line");

  ply_header h;
  bool have_format = false;
  header_line l;
  l.number = 1;
  for (;;) {
    if (!src.next_line(pos, l.text)) throw io_error(file, "the PLY header has no end_header line");
    ++l.number;
    l.words = split_words(l.text);
    if (l.words.empty()) continue;
    const std::string_view kw = l.words[0];
    if (kw == "end_header") break;
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "format") {
      read_format_line(l, file, h);
      have_format = true;
    } else if (kw == "element") {
      read_element_line(l, file, h);
    } else if (kw == "property") {
      read_property_line(l, file, h);
    } else {
      throw io_error(file, l.where() + "unknown header keyword '" + std::string(kw) + "'");
    }
  }
  if (!have_format) throw io_error(file, "the PLY header has no format line");
  h.body_offset = pos;
  return h;
}

/// The vertex element of `h` and the indices of its x, y and z properties.
const element_desc& find_vertex(const ply_header& h, const std::string& file, std::size_t axis[3]) {
  const element_desc* vertex = nullptr;
  for (const auto& e : h.elements)
    if (e.name == "vertex") vertex = &e;
  if (!vertex) throw io_error(file, "the PLY file has no 'vertex' element");
  for (int k = 0; k < 3; ++k) {
    const std::string name(1, static_cast<char>('x' + k));
    const auto it = std::find_if(vertex->props.begin(), vertex->props.end(),
                                 [&](const property_desc& p) { return p.name == name; });
    if (it == vertex->props.end()) throw io_error(file, "the vertex element has no '" + name + "' property");
    if (it->is_list) throw io_error(file, "the vertex property '" + name + "' is a list");
    axis[k] = static_cast<std::size_t>(it - vertex->props.begin());
  }
  return *vertex;
}

bool swapped(ply_format f) noexcept {
  return f != ply_format::ascii && (f == ply_format::binary_little_endian) != host_little_endian();
}

// ------------------------------------------------------------- binary body

using columns = std::vector<std::vector<double>>;

/// The size of a record of element e: exact when `fixed` (no list), else
/// the least one (empty lists).
struct record_size {
  std::size_t min = 0;
  bool fixed = true;
};

record_size record_size_of(const element_desc& e) noexcept {
  record_size r;
  for (const auto& p : e.props) {
    r.min += size_of(p.is_list ? p.count_type : p.type);
    r.fixed = r.fixed && !p.is_list;
  }
  return r;
}

/// Fails when the `remaining` bytes cannot hold the e.count records of
/// element e (r = record_size_of(e), r.min > 0): an implausible count, or a
/// truncated file when the records have a fixed size.
void check_count(const element_desc& e, const record_size& r, std::uint64_t remaining, const std::string& file) {
  const std::uint64_t available = remaining / r.min;  // complete (minimal) records present
  if (e.count > available) {
    if (e.count / 2 > available + 8)
      throw io_error(file, "implausible element count: '" + e.name + "' declares " + std::to_string(e.count) +
                               " records of at least " + std::to_string(r.min) + " bytes, but only " +
                               std::to_string(remaining) + " bytes follow (corrupt header?)");
    if (r.fixed) fail_truncated(file, available, e.count, e);
  }
}

/// The binary data after a position, as read_record() reads it: the whole
/// file in memory.
struct memory_cursor {
  const unsigned char* p;
  const unsigned char* end;
  std::uint64_t left() const noexcept { return static_cast<std::uint64_t>(end - p); }
  const unsigned char* take(std::size_t n) noexcept { return (p += n) - n; }
  void skip(std::uint64_t n) noexcept { p += n; }
};

/// The same, read from a file in pieces.
struct file_cursor {
  sequential_reader& in;
  std::uint64_t left() const noexcept { return in.left(); }
  const unsigned char* take(std::size_t n) {
    in.fill(n);
    const auto* p = reinterpret_cast<const unsigned char*>(in.data());
    in.skip(n);  // the bytes stay in memory until the next fill()
    return p;
  }
  void skip(std::uint64_t n) noexcept { in.skip(n); }
};

/// Reads record i of the n records of element e (which has lists) from `in`:
/// store(j, value) for each scalar property j, lists skipped. Fails when
/// the data ends.
template <class Cursor, class Store>
void read_record(Cursor& in, const element_desc& e, bool swap, std::size_t i, std::size_t n, const std::string& file,
                 Store&& store) {
  for (std::size_t j = 0; j < e.props.size(); ++j) {
    const property_desc& prop = e.props[j];
    if (prop.is_list) {
      const std::size_t cs = size_of(prop.count_type);
      if (in.left() < cs) fail_truncated(file, i, n, e);
      const double count = read_value(in.take(cs), prop.count_type, swap);
      if (count < 0)
        throw io_error(file, "element '" + e.name + "' " + std::to_string(i) + ", property '" + prop.name +
                                 "': negative list length " + std::to_string(static_cast<long long>(count)));
      const std::size_t item = size_of(prop.type);
      if (count > static_cast<double>(static_cast<std::size_t>(in.left()) / item)) fail_truncated(file, i, n, e);
      in.skip(static_cast<std::size_t>(count) * item);
    } else {
      const std::size_t sz = size_of(prop.type);
      if (in.left() < sz) fail_truncated(file, i, n, e);
      store(j, read_value(in.take(sz), prop.type, swap));
    }
  }
}

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

// ------------------------------------------------------------------ writer

const char* ply_type_name(scalar_type t) noexcept {
  switch (t) {
    case scalar_type::int8:
      return "char";
    case scalar_type::uint8:
      return "uchar";
    case scalar_type::int16:
      return "short";
    case scalar_type::uint16:
      return "ushort";
    case scalar_type::int32:
      return "int";
    case scalar_type::uint32:
      return "uint";
    case scalar_type::float32:
      return "float";
    default:
      return "double";  // float64, and int64/uint64 which PLY lacks
  }
}

scalar_type written_type(scalar_type t) noexcept {
  return t == scalar_type::int64 || t == scalar_type::uint64 ? scalar_type::float64 : t;
}

/// Throws std::invalid_argument when a field cannot be written as a vertex
/// property, io_error when there are more than the reader accepts.
void check_writable(const point_cloud& cloud) {
  check_values_per_point(3 + cloud.fields().size(), "PLY");
  const std::size_t n = cloud.size();
  for (const auto& f : cloud.fields()) {
    if (f.name.empty() || std::any_of(f.name.begin(), f.name.end(), [](char c) { return is_space(c); }))
      throw std::invalid_argument("field name '" + f.name + "' cannot be written to PLY (empty or has whitespace)");
    if (f.name == "x" || f.name == "y" || f.name == "z")
      throw std::invalid_argument("field '" + f.name + "' clashes with the PLY coordinate property");
    check_field_size(f, n);
  }
}

/// A vertex property to write: a coordinate or a field.
struct out_column {
  scalar_type type;
  const column* values;  // nullptr for positions
  int axis;
};

std::string make_header(const point_cloud& cloud, std::uint64_t n, ply_format fmt, scalar_type pos_type) {
  std::string header = "ply\nformat ";
  header += fmt == ply_format::ascii                  ? "ascii"
            : fmt == ply_format::binary_little_endian ? "binary_little_endian"
                                                      : "binary_big_endian";
  header += " 1.0\ncomment generated by ced\nelement vertex " + std::to_string(n) + "\n";
  for (int k = 0; k < 3; ++k) header += std::string("property ") + ply_type_name(pos_type) + " " + char('x' + k) + "\n";
  for (const auto& f : cloud.fields())
    header += std::string("property ") + ply_type_name(f.type()) + " " + f.name + "\n";
  header += "end_header\n";
  return header;
}

/// The vertices, in chunks of points.
void write_vertices(std::ostream& out, const point_cloud& cloud, ply_format fmt, const std::vector<out_column>& cols) {
  const auto& origin = cloud.origin();
  const float* xyz = cloud.positions().data();
  std::vector<scalar_type> types;
  for (const auto& c : cols) types.push_back(c.type);
  point_format pf;
  pf.text = fmt == ply_format::ascii;
  pf.swap = !pf.text && (fmt == ply_format::binary_little_endian) != host_little_endian();
  std::vector<const column*> direct;
  for (const auto& c : cols) direct.push_back(c.values);
  write_points(
      out, cloud.size(), types, pf,
      [&](std::size_t c, std::size_t i0, std::size_t m, double* v) {
        if (cols[c].values) {
          copy_values(*cols[c].values, i0, m, v);
        } else {
          const auto k = static_cast<std::size_t>(cols[c].axis);
          for (std::size_t i = 0; i < m; ++i) v[i] = origin[k] + static_cast<double>(xyz[3 * (i0 + i) + k]);
        }
      },
      direct);
}

/// Positions are written as double when the cloud has an origin.
scalar_type position_type(const point_cloud& cloud) {
  const auto& origin = cloud.origin();
  const bool georef = origin[0] != 0 || origin[1] != 0 || origin[2] != 0;
  return georef ? scalar_type::float64 : scalar_type::float32;
}

/// The header of a cloud with `cloud`'s fields and origin, and n points.
void write_header(std::ostream& out, const point_cloud& cloud, std::uint64_t n, ply_format fmt) {
  const std::string header = make_header(cloud, n, fmt, position_type(cloud));
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
}

/// The vertices of `cloud`, after write_header().
void write_body(std::ostream& out, const point_cloud& cloud, ply_format fmt) {
  const scalar_type pos_type = position_type(cloud);
  std::vector<out_column> cols;
  for (int k = 0; k < 3; ++k) cols.push_back({pos_type, nullptr, k});
  for (const auto& f : cloud.fields()) cols.push_back({written_type(f.type()), &f.values, -1});
  write_vertices(out, cloud, fmt, cols);
}

void write_ply_unchecked(std::ostream& out, const point_cloud& cloud, ply_format fmt) {
  check_writable(cloud);
  write_header(out, cloud, cloud.size(), fmt);
  write_body(out, cloud, fmt);
}

}  // namespace

point_cloud read_ply(const std::string& path) { return read_ply_path(path, {}); }

point_cloud read_ply(std::istream& in, const std::string& name_for_errors) {
  std::string data;
  char buf[1 << 16];
  while (in.read(buf, sizeof(buf)) || in.gcount() > 0) data.append(buf, static_cast<std::size_t>(in.gcount()));
  if (in.bad()) throw io_error(name_for_errors + ": read error");
  return parse_ply(data, name_for_errors, {});
}

void write_ply(std::ostream& out, const point_cloud& cloud, ply_format fmt) {
  detail::write_to_stream(out, "PLY", [&](std::ostream& o) { write_ply_unchecked(o, cloud, fmt); });
}

void write_ply(const std::string& path, const point_cloud& cloud, ply_format fmt) {
  detail::write_to_file(path, [&](std::ostream& o) { write_ply_unchecked(o, cloud, fmt); });
}

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
namespace {
class ply_piece_writer final : public piece_writer {
 public:
  ply_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
    check_writable(layout);
    write_header(out, layout, n, ply_format::binary_little_endian);
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    check_writable(chunk);
    write_body(out, chunk, ply_format::binary_little_endian);
  }
};
}  // namespace

point_cloud read_ply_file(const std::string& path, const field_selection& fields) {
  return read_ply_path(path, fields);
}

std::unique_ptr<piece_writer> ply_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<ply_piece_writer>(out, layout, n);
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
  e.pieces = [](std::ostream& out, const point_cloud& layout, std::uint64_t n, bool) {
    return ply_pieces(out, layout, n);
  };
  e.stream = [](const std::string& path, const read_options& o) { return open_ply_stream(path, o.fields); };
  return e;
}
}  // namespace detail

}  // namespace ced::io
