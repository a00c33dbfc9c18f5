// SPDX-License-Identifier: MIT
// PLY: the header, parsed and checked.
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

/// Fails: the file ends after `read` of the `count` records of element e.
[[noreturn]] void fail_truncated(const std::string& file, std::uint64_t read, std::uint64_t count,
                                 const element_desc& e) {
  throw io_error(file, "truncated: the file ends after " + std::to_string(read) + " of " + std::to_string(count) + " " +
                           plural(e.name));
}

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

}  // namespace ply_detail

}  // namespace ced::io
