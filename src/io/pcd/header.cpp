// SPDX-License-Identifier: MIT
// PCD: the header, parsed and checked.
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

namespace pcd_detail {

// ---------------------------------------------------------------- utilities

bool parse_u64(std::string_view s, std::uint64_t& v) noexcept {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

/// The TYPE of values of t: F (floating point), I (signed) or U (unsigned).
char type_char(scalar_type t) noexcept {
  if (t == scalar_type::float32 || t == scalar_type::float64) return 'F';
  switch (t) {
    case scalar_type::int8:
    case scalar_type::int16:
    case scalar_type::int32:
    case scalar_type::int64:
      return 'I';
    default:
      return 'U';
  }
}

/// The type of the values of PCD TYPE `type` and SIZE `size`, if any.
std::optional<scalar_type> pcd_type(char type, std::uint64_t size) noexcept {
  for (int i = 0; i <= static_cast<int>(scalar_type::float64); ++i) {
    const auto t = static_cast<scalar_type>(i);
    if (type_char(t) == type && size_of(t) == size) return t;
  }
  return std::nullopt;
}

bool has_data_line(const header_source& src) { return src.text.substr(0, 4) == "DATA" || src.contains("\nDATA"); }

/// Reads the header line `w` (its words; `line` as given, number `line_no`)
/// into `l` and `h`. True when it is the DATA line, which ends the header.
bool read_header_line(const std::vector<std::string_view>& w, std::string_view line, std::size_t line_no,
                      const header_source& src, const std::string& file, header_lines& l, pcd_header& h) {
  const std::string_view kw = w[0];
  const auto where = [&] { return "header line " + std::to_string(line_no) + ": "; };
  const auto list = [&](bool& have, std::vector<std::string_view>& out) {
    if (have) throw io_error(file, where() + std::string(kw) + " is given twice");
    if (w.size() < 2) throw io_error(file, where() + std::string(kw) + " lists no values");
    have = true;
    out.assign(w.begin() + 1, w.end());
  };
  const auto number = [&](bool& have, std::uint64_t& out) {
    if (have) throw io_error(file, where() + std::string(kw) + " is given twice");
    if (w.size() != 2 || !parse_u64(w[1], out))
      throw io_error(file, where() + "invalid " + std::string(kw) + " line '" + printable(line) +
                               "' (expected one non-negative integer)");
    have = true;
  };
  if (kw == "VERSION") {
    if (w.size() != 2) throw io_error(file, where() + "malformed VERSION line '" + printable(line) + "'");
  } else if (kw == "FIELDS" || kw == "COLUMNS") {
    list(l.have_fields, l.names);
  } else if (kw == "SIZE") {
    list(l.have_size, l.sizes);
  } else if (kw == "TYPE") {
    list(l.have_type, l.types);
  } else if (kw == "COUNT") {
    list(l.have_count, l.counts);
  } else if (kw == "WIDTH") {
    number(l.have_width, h.width);
  } else if (kw == "HEIGHT") {
    number(l.have_height, h.height);
  } else if (kw == "POINTS") {
    number(l.have_points, h.points);
  } else if (kw == "VIEWPOINT") {
    if (w.size() != 8) throw io_error(file, where() + "VIEWPOINT needs 7 values (tx ty tz qw qx qy qz)");
  } else if (kw == "DATA") {
    if (w.size() != 2) throw io_error(file, where() + "malformed DATA line '" + printable(line) + "'");
    if (w[1] == "ascii")
      h.format = pcd_format::ascii;
    else if (w[1] == "binary")
      h.format = pcd_format::binary;
    else if (w[1] == "binary_compressed")
      h.format = pcd_format::binary_compressed;
    else
      throw io_error(file, where() + "unknown DATA format '" + printable(w[1]) +
                               "' (expected ascii, binary or binary_compressed)");
    h.data_name = std::string(w[1]);
    return true;
  } else {
    if (!has_data_line(src)) throw io_error(file, "the PCD header has no DATA line");
    throw io_error(file, where() + "unknown header keyword '" + printable(kw) + "'");
  }
  return false;
}

/// Reads the header lines, up to DATA, into `l` and `h` (and the body's offset and first line).
void read_header_lines(const header_source& src, const std::string& file, header_lines& l, pcd_header& h) {
  std::size_t pos = 0, line_no = 0;
  bool first = true;
  for (bool done = false; !done;) {
    std::string_view line;
    if (!src.next_line(pos, line)) throw io_error(file, "the PCD header has no DATA line");
    ++line_no;
    const auto w = split_words(line);
    if (w.empty() || w[0][0] == '#') continue;
    if (first && w[0] != "VERSION" && w[0] != "FIELDS" && w[0] != "COLUMNS")
      throw io_error(file, "not a PCD file (expected a VERSION or FIELDS line, found '" + printable(line) + "')");
    first = false;
    done = read_header_line(w, line, line_no, src, file, l, h);
  }
  h.body_offset = pos;
  h.body_line = line_no + 1;
}

/// The fields of FIELDS, with their SIZE, TYPE and COUNT (each list, when
/// given, as long as FIELDS).
void make_fields(const header_lines& l, const std::string& file, pcd_header& h) {
  if (!l.have_fields) throw io_error(file, "the PCD header has no FIELDS line");
  const std::size_t nf = l.names.size();
  const auto check_length = [&](bool have, const std::vector<std::string_view>& v, const char* kw) {
    if (have && v.size() != nf)
      throw io_error(file, std::string(kw) + " lists " + std::to_string(v.size()) + " values but FIELDS names " +
                               std::to_string(nf) + " fields");
  };
  check_length(l.have_size, l.sizes, "SIZE");
  check_length(l.have_type, l.types, "TYPE");
  check_length(l.have_count, l.counts, "COUNT");

  std::uint64_t values = 0;
  std::unordered_set<std::string_view> seen;  // names, for the duplicate check in linear time
  for (std::size_t i = 0; i < nf; ++i) {
    pcd_field f;
    f.name = std::string(l.names[i]);
    f.padding = f.name == "_";
    std::uint64_t size = 4, count = 1;
    if (l.have_size && (!parse_u64(l.sizes[i], size) || size == 0))
      throw io_error(file, "invalid SIZE '" + printable(l.sizes[i]) + "' for field '" + f.name + "'");
    if (l.have_type) {
      if (l.types[i].size() != 1)
        throw io_error(file, "invalid TYPE '" + printable(l.types[i]) + "' for field '" + f.name + "'");
      f.type = l.types[i][0];
    }
    if (l.have_count && (!parse_u64(l.counts[i], count) || count == 0))
      throw io_error(file, "invalid COUNT '" + printable(l.counts[i]) + "' for field '" + f.name + "'");
    if (count > max_values_per_point || (values += count) > max_values_per_point)
      throw io_error(file, "too many values per point (more than " + std::to_string(max_values_per_point) + ")");
    const auto t = pcd_type(f.type, size);
    if (!t) {
      if (f.type != 'I' && f.type != 'U' && f.type != 'F')
        throw io_error(file,
                       "invalid TYPE '" + std::string(1, f.type) + "' for field '" + f.name + "' (expected I, U or F)");
      throw io_error(file, "field '" + f.name + "': unsupported TYPE " + std::string(1, f.type) + " with SIZE " +
                               std::to_string(size));
    }
    f.stype = *t;
    f.size = static_cast<std::size_t>(size);
    f.count = static_cast<std::size_t>(count);
    if (!f.padding && !seen.insert(l.names[i]).second)
      throw io_error(file, "field '" + f.name + "' is declared twice in FIELDS");
    h.fields.push_back(std::move(f));
  }
}

/// WIDTH, HEIGHT and POINTS: either may stand for the other, and when both
/// are given they must agree.
void resolve_point_count(const header_lines& l, const std::string& file, pcd_header& h) {
  if (!l.have_width && !l.have_points) throw io_error(file, "the PCD header has neither WIDTH nor POINTS");
  if (!l.have_width) {
    if (l.have_height && h.height != 1) throw io_error(file, "the PCD header gives HEIGHT but no WIDTH");
    h.width = h.points;
    h.height = 1;
  }
  if (h.height != 0 && h.width > std::numeric_limits<std::uint64_t>::max() / h.height)
    throw io_error(file,
                   "WIDTH × HEIGHT (" + std::to_string(h.width) + " × " + std::to_string(h.height) + ") overflows");
  const std::uint64_t wh = h.width * h.height;
  if (!l.have_points)
    h.points = wh;
  else if (h.points != wh)
    throw io_error(file, "POINTS (" + std::to_string(h.points) + ") does not equal WIDTH × HEIGHT (" +
                             std::to_string(h.width) + " × " + std::to_string(h.height) + " = " + std::to_string(wh) +
                             ")");
}

/// Parses the header (from the whole file, or from its first bytes: see
/// header_source).
pcd_header parse_header(const header_source& src, const std::string& file) {
  header_lines l;
  pcd_header h;
  read_header_lines(src, file, l, h);
  make_fields(l, file, h);
  resolve_point_count(l, file, h);
  return h;
}

// -------------------------------------------------------------- ascii values

/// A packed rgb value in ascii: a plain integer is the packed 32 bits (PCL
/// writes it so); for TYPE F anything else is a float whose bits are taken.
parse_status parse_packed_rgb(std::string_view tok, char type, double& out) noexcept {
  const bool digits = !tok.empty() && std::all_of(tok.begin(), tok.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (type == 'F' && !digits) {
    double d = 0;
    const parse_status s = parse_double(tok, d);
    if (s != parse_status::ok) return s;
    const float f = static_cast<float>(d);
    std::uint32_t bits = 0;
    std::memcpy(&bits, &f, 4);
    out = bits;
    return parse_status::ok;
  }
  const parse_status s = parse_ascii_value(tok, type == 'I' ? scalar_type::int32 : scalar_type::uint32, out);
  if (s == parse_status::ok && out < 0) out += 4294967296.0;  // the bits of a negative int32
  return s;
}

/// The size of a point's binary record (padding included).
std::size_t point_size_of(const pcd_header& h) noexcept {
  std::size_t point_size = 0;
  for (const auto& f : h.fields) point_size += f.size * f.count;
  return point_size;
}

/// Fails when the `remaining` bytes of a binary body cannot hold POINTS points.
void check_binary_size(const pcd_header& h, std::uint64_t remaining, const std::string& file) {
  const std::size_t point_size = point_size_of(h);
  if (h.points > remaining / point_size)
    throw io_error(file, "truncated: POINTS declares " + std::to_string(h.points) + " points of " +
                             std::to_string(point_size) + " bytes, but only " + std::to_string(remaining) +
                             " bytes of binary data follow");
}

}  // namespace pcd_detail

}  // namespace ced::io
