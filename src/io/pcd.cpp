// SPDX-License-Identifier: MIT
#include "ced/io/pcd.hpp"

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

#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io {

using namespace detail;  // scalar_io.hpp

namespace {

// ---------------------------------------------------------------- utilities

bool parse_u64(std::string_view s, std::uint64_t& v) noexcept {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// ------------------------------------------------------------------- header

struct pcd_field {
  std::string name;
  char type = 'F';
  std::size_t size = 4;
  std::size_t count = 1;
  scalar_type stype = scalar_type::float32;
  bool padding = false;     ///< named "_": skipped
  bool packed_rgb = false;  ///< rgb/rgba, unpacked into red/green/blue
};

struct pcd_header {
  std::vector<pcd_field> fields;
  std::uint64_t width = 0, height = 1, points = 0;
  pcd_format format = pcd_format::ascii;
  std::string data_name;
  std::size_t body_offset = 0;
  std::size_t body_line = 0;  ///< 1-based line number of the line after DATA
};

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

/// The header's lines as given, before they are checked together.
struct header_lines {
  std::vector<std::string_view> names, sizes, types, counts;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_height = false, have_points = false;
};

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

// ------------------------------------------------------------------ reader

using columns = std::vector<std::vector<double>>;

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

/// The body of a binary_compressed file, uncompressed: the values field by
/// field, padding fields included when `with_padding`.
struct uncompressed_body {
  big_bytes bytes;
  bool with_padding = false;
};

uncompressed_body decompress_body(std::string_view data, const pcd_header& h, const std::string& file) {
  const std::size_t remaining = data.size() - h.body_offset;
  const auto n = static_cast<std::size_t>(h.points);
  if (remaining < 8) {
    if (n == 0) return {};
    throw io_error(
        file, "truncated: the binary_compressed data has no size header (" + std::to_string(remaining) + " bytes)");
  }
  const auto* body = reinterpret_cast<const unsigned char*>(data.data()) + h.body_offset;
  const std::uint32_t compressed = load_le<std::uint32_t>(body);
  const std::uint32_t uncompressed = load_le<std::uint32_t>(body + 4);
  if (compressed > remaining - 8)
    throw io_error(file, "truncated: the binary_compressed data declares " + std::to_string(compressed) +
                             " compressed bytes, but only " + std::to_string(remaining - 8) + " follow");
  std::size_t size_real = 0, size_all = 0;
  for (const auto& f : h.fields) {
    size_all += f.size * f.count;
    if (!f.padding) size_real += f.size * f.count;
  }
  // PCL leaves padding fields out of the compressed layout; accept them too.
  bool with_padding = false;
  if (h.points <= std::numeric_limits<std::uint32_t>::max() / size_real && uncompressed == n * size_real) {
    with_padding = false;
  } else if (size_all != size_real && h.points <= std::numeric_limits<std::uint32_t>::max() / size_all &&
             uncompressed == n * size_all) {
    with_padding = true;
  } else {
    throw io_error(file, "the uncompressed size in the binary_compressed header (" + std::to_string(uncompressed) +
                             " bytes) does not match POINTS × point size (" + std::to_string(h.points) + " × " +
                             std::to_string(size_real) + " bytes)");
  }
  // LZF expands at most 88-fold (a 3-byte back-reference copies 264 bytes):
  // refuse more before allocating.
  if (static_cast<std::uint64_t>(uncompressed) > static_cast<std::uint64_t>(compressed) * 100 + 1024)
    throw io_error(file, "implausible binary_compressed sizes: " + std::to_string(compressed) +
                             " compressed bytes cannot expand to " + std::to_string(uncompressed) + " bytes");
  uncompressed_body out{big_bytes(uncompressed), with_padding};
  lzf_decompress_into(std::string_view(reinterpret_cast<const char*>(body + 8), compressed), out.bytes.data(),
                      uncompressed, file);
  return out;
}

/// The ascii points [first, first + count) from the lines at [p, end) (the
/// first of them numbered line_no + 1), blank lines skipped, into `cols`.
/// Throws the truncation error when the lines end first.
void parse_ascii_points(const char* p, const char* const end, std::size_t first, std::size_t count, std::size_t n,
                        std::size_t line_no, const pcd_header& h, const std::vector<std::size_t>& col_of, columns& cols,
                        const std::string& file) {
  std::size_t values_all = 0, values_real = 0;
  for (const auto& f : h.fields) {
    values_all += f.count;
    if (!f.padding) values_real += f.count;
  }
  std::vector<std::string_view> tok;
  tok.reserve(values_all);
  for (std::size_t i = first; i < first + count; ++i) {
    // The next non-blank line, split into tokens.
    for (;;) {
      if (p >= end)
        throw io_error(file,
                       "truncated: the file ends after " + std::to_string(i) + " of " + std::to_string(n) + " points");
      ++line_no;
      tok.clear();
      const auto* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
      const char* line_end = nl ? nl : end;
      word_reader<> words(std::string_view(p, static_cast<std::size_t>(line_end - p)));
      for (std::string_view w; words.next(w);) tok.push_back(w);
      p = nl ? nl + 1 : end;
      if (!tok.empty()) break;
    }
    const bool with_padding = tok.size() == values_all;
    if (!with_padding && tok.size() != values_real)
      throw io_error(file, "line " + std::to_string(line_no) + ": expected " + std::to_string(values_real) +
                               " values, found " + std::to_string(tok.size()));
    std::size_t t = 0;
    for (std::size_t j = 0; j < h.fields.size(); ++j) {
      const pcd_field& f = h.fields[j];
      if (f.padding) {
        if (with_padding) t += f.count;
        continue;
      }
      for (std::size_t c = 0; c < f.count; ++c, ++t) {
        double v = 0;
        const parse_status s =
            f.packed_rgb ? parse_packed_rgb(tok[t], f.type, v) : parse_ascii_value(tok[t], f.stype, v);
        if (s != parse_status::ok) {
          const std::string what = "line " + std::to_string(line_no) + ", field '" +
                                   (f.count > 1 ? f.name + "_" + std::to_string(c) : f.name) + "': '" +
                                   printable(tok[t]) + "' ";
          fail_value(file, what, s, f.stype);
        }
        cols[col_of[j] + c][i] = v;
      }
    }
  }
}

void read_ascii(std::string_view data, const pcd_header& h, const std::vector<std::size_t>& col_of, columns& cols,
                const std::string& file) {
  std::size_t values_real = 0;
  for (const auto& f : h.fields)
    if (!f.padding) values_real += f.count;
  // A point takes at least 2 bytes per value (a digit and a separator).
  const std::size_t remaining = data.size() - h.body_offset;
  if (h.points > (remaining + 1) / (2 * values_real))
    throw io_error(file, "truncated: POINTS declares " + std::to_string(h.points) + " points of " +
                             std::to_string(values_real) + " values, but only " + std::to_string(remaining) +
                             " bytes of ascii data follow");
  const auto n = static_cast<std::size_t>(h.points);
  for (auto& c : cols) c.resize(n);
  const char* const body = data.data() + h.body_offset;
  const char* const end = data.data() + data.size();
  const std::size_t blocks = ascii_blocks(remaining);
  if (blocks <= 1) return parse_ascii_points(body, end, 0, n, n, h.body_line - 1, h, col_of, cols, file);
  // Blocks of whole lines: counted first (the points and lines before each),
  // then parsed on the threads straight into the columns. Each keeps its
  // first error; the earliest is the one one thread would have met first
  // (a truncated file only shows at its end, after every block).
  const std::vector<const char*> cut = cut_lines(body, end, blocks);
  std::vector<std::pair<std::size_t, std::size_t>> before(blocks + 1, {0, h.body_line - 1});  // points, lines
  ced::detail::parallel_for(blocks, 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) before[k + 1] = count_lines(cut[k], cut[k + 1]);
  });
  for (std::size_t k = 1; k <= blocks; ++k) {
    before[k].first += before[k - 1].first;
    before[k].second += before[k - 1].second;
  }
  for_each_block(blocks, [&](std::size_t k) {
    const std::size_t first = std::min(before[k].first, n), last = std::min(before[k + 1].first, n);
    parse_ascii_points(cut[k], cut[k + 1], first, last - first, n, before[k].second, h, col_of, cols, file);
  });
  if (before[blocks].first < n)
    throw io_error(file, "truncated: the file ends after " + std::to_string(before[blocks].first) + " of " +
                             std::to_string(n) + " points");
}

/// The indices of the x, y and z fields (each of COUNT 1) in h.fields.
std::array<std::size_t, 3> find_axes(const pcd_header& h, const std::string& file) {
  std::array<std::size_t, 3> axis{};
  for (int k = 0; k < 3; ++k) {
    const std::string name(1, static_cast<char>('x' + k));
    const auto it = std::find_if(h.fields.begin(), h.fields.end(), [&](const pcd_field& f) { return f.name == name; });
    if (it == h.fields.end()) throw io_error(file, "the PCD file has no '" + name + "' field");
    if (it->count != 1)
      throw io_error(file, "field '" + name + "' has COUNT " + std::to_string(it->count) + " (expected 1)");
    axis[static_cast<std::size_t>(k)] = static_cast<std::size_t>(it - h.fields.begin());
  }
  return axis;
}

/// Marks the packed rgb fields and gives each value of each non-padding field
/// a column: col_of[j] is the first column of field j. `ncols` receives their
/// number. Fails when two fields would get the same name in the cloud.
std::vector<std::size_t> assign_columns(pcd_header& h, const std::string& file, std::size_t& ncols) {
  std::vector<std::size_t> col_of(h.fields.size(), 0);
  ncols = 0;
  std::set<std::string> out_names;
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    pcd_field& f = h.fields[j];
    if (f.padding) continue;
    f.packed_rgb = (f.name == "rgb" || f.name == "rgba") && f.count == 1 && f.size == 4;
    col_of[j] = ncols;
    ncols += f.count;
    std::vector<std::string> names;
    if (f.packed_rgb)
      names = {"red", "green", "blue"};
    else if (f.count == 1)
      names = {f.name};
    else
      for (std::size_t c = 0; c < f.count; ++c) names.push_back(f.name + "_" + std::to_string(c));
    for (const auto& name : names)
      if (!out_names.insert(name).second)
        throw io_error(file,
                       "two fields would be named '" + name + "' (field '" + f.name + "' clashes with another one)");
  }
  return col_of;
}

/// Drops, from every column, the points with a non-finite coordinate in
/// x, y or z; returns the number of points kept.
std::size_t drop_nonfinite(columns& cols, const std::vector<double>* const xyz[3], std::size_t declared) {
  std::size_t n = 0;
  std::vector<std::uint8_t> keep(declared);
  for (std::size_t i = 0; i < declared; ++i) {
    keep[i] = std::isfinite((*xyz[0])[i]) && std::isfinite((*xyz[1])[i]) && std::isfinite((*xyz[2])[i]);
    n += keep[i];
  }
  if (n != declared)
    for (auto& col : cols) {
      std::size_t o = 0;
      for (std::size_t i = 0; i < declared; ++i)
        if (keep[i]) col[o++] = col[i];
      col.resize(o);
      col.shrink_to_fit();
    }
  return n;
}

/// Adds red, green and blue uint8 fields unpacked from the packed rgb values
/// (0x00RRGGBB), then releases those.
void add_unpacked_rgb(point_cloud& cloud, std::vector<double>& packed) {
  const std::size_t n = cloud.size();
  std::vector<double> rgb[3];
  for (auto& c : rgb) c.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto bits = static_cast<std::uint32_t>(packed[i]);
    rgb[0][i] = (bits >> 16) & 0xff;
    rgb[1][i] = (bits >> 8) & 0xff;
    rgb[2][i] = bits & 0xff;
  }
  cloud.add_field("red", scalar_type::uint8, std::move(rgb[0]));
  cloud.add_field("green", scalar_type::uint8, std::move(rgb[1]));
  cloud.add_field("blue", scalar_type::uint8, std::move(rgb[2]));
  std::vector<double>().swap(packed);
}

/// Adds the fields other than x, y, z and padding: a field of COUNT c > 1 as
/// fields name_0 ... name_{c-1}.
void add_fields(point_cloud& cloud, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                const std::vector<std::size_t>& col_of, columns& cols) {
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    const pcd_field& f = h.fields[j];
    if (f.padding || j == axis[0] || j == axis[1] || j == axis[2]) continue;
    if (f.packed_rgb) {
      add_unpacked_rgb(cloud, cols[col_of[j]]);
    } else if (f.count == 1) {
      cloud.add_field(f.name, f.stype, std::move(cols[col_of[j]]));
    } else {
      for (std::size_t c = 0; c < f.count; ++c)
        cloud.add_field(f.name + "_" + std::to_string(c), f.stype, std::move(cols[col_of[j] + c]));
    }
  }
}

/// What read_pcd() tells of the file, but the points it removes.
pcd_read_info info_of(const pcd_header& h) {
  pcd_read_info info;
  info.width = static_cast<std::size_t>(h.width);
  info.height = static_cast<std::size_t>(h.height);
  info.points_declared = static_cast<std::size_t>(h.points);
  info.organized = h.height > 1;
  info.data_format = h.data_name;
  return info;
}

/// Adds to `layout` the values of field f at `offset` (`stride` as in
/// value_spec): an axis when it is axis k (0 to 2), else the selected values.
void add_values(point_layout& layout, const pcd_field& f, int k, std::size_t offset, std::size_t stride,
                const field_selection& selection) {
  const bool swap = !host_little_endian();  // PCD binary data is little-endian
  const auto add = [&](std::string name, std::size_t at, scalar_type t, int shift) {
    if (selection.wants(name)) layout.columns.push_back({std::move(name), at, t, swap, shift, stride});
  };
  if (k >= 0) {
    layout.xyz[static_cast<std::size_t>(k)] = {f.name, offset, f.stype, swap, -1, stride};
  } else if (f.packed_rgb) {
    add("red", offset, scalar_type::uint32, 16);
    add("green", offset, scalar_type::uint32, 8);
    add("blue", offset, scalar_type::uint32, 0);
  } else if (f.count == 1) {
    add(f.name, offset, f.stype, -1);
  } else {
    for (std::size_t c = 0; c < f.count; ++c) add(f.name + "_" + std::to_string(c), offset + c * f.size, f.stype, -1);
  }
}

/// The axis (0 to 2) that field j is, or -1.
int axis_of(const std::array<std::size_t, 3>& axis, std::size_t j) noexcept {
  for (int k = 0; k < 3; ++k)
    if (axis[static_cast<std::size_t>(k)] == j) return k;
  return -1;
}

/// The layout of binary records: x, y, z and the selected values, in the
/// reader's order (a packed rgb as red, green, blue; COUNT c as name_0 ...).
point_layout record_layout(const pcd_header& h, const std::array<std::size_t, 3>& axis,
                           const field_selection& selection) {
  point_layout layout;
  std::size_t offset = 0;
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    const pcd_field& f = h.fields[j];
    if (!f.padding) add_values(layout, f, axis_of(axis, j), offset, 0, selection);
    offset += f.size * f.count;
  }
  return layout;
}

/// The same for an uncompressed binary_compressed body: each field's values
/// one after the other, then the next field's.
point_layout field_major_layout(const pcd_header& h, const std::array<std::size_t, 3>& axis,
                                const field_selection& selection, const uncompressed_body& body) {
  point_layout layout;
  layout.base = reinterpret_cast<const unsigned char*>(body.bytes.data());
  std::size_t offset = 0;
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    const pcd_field& f = h.fields[j];
    if (f.padding && !body.with_padding) continue;
    if (!f.padding) add_values(layout, f, axis_of(axis, j), offset, f.size * f.count, selection);
    offset += static_cast<std::size_t>(h.points) * f.size * f.count;
  }
  return layout;
}

/// The n points of `src` (`layout`), in parallel chunks; the origin of the
/// finite points; without the non-finite ones unless `keep_nonfinite`.
point_cloud read_points(const record_source& src, std::uint64_t n, const point_layout& layout, bool keep_nonfinite) {
  const points_scan scan = scan_points(src, n, layout);
  return decode_points(src, n, layout, choose_origin(scan.box.lo, scan.box.hi), keep_nonfinite ? nullptr : &scan);
}

/// The ascii body as a cloud: without the non-finite points unless `keep_nonfinite`.
point_cloud read_ascii_cloud(std::string_view data, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                             bool keep_nonfinite, const std::string& file) {
  std::size_t ncols = 0;
  pcd_header marked = h;
  const std::vector<std::size_t> col_of = assign_columns(marked, file, ncols);
  columns cols(ncols);
  read_ascii(data, h, col_of, cols, file);
  const std::vector<double>* xyz[3] = {&cols[col_of[axis[0]]], &cols[col_of[axis[1]]], &cols[col_of[axis[2]]]};
  const auto declared = static_cast<std::size_t>(h.points);
  const std::size_t n = keep_nonfinite ? declared : drop_nonfinite(cols, xyz, declared);
  point_cloud cloud = cloud_at(xyz[0]->data(), xyz[1]->data(), xyz[2]->data(), n);
  add_fields(cloud, h, axis, col_of, cols);
  return cloud;
}

/// The body of the file `data` (header h, checked) as a cloud with the selected fields.
point_cloud read_body(std::string_view data, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                      bool keep_nonfinite, const field_selection& selection, const std::string& file) {
  const auto* d = reinterpret_cast<const unsigned char*>(data.data());
  if (h.format == pcd_format::binary) {
    check_binary_size(h, data.size() - h.body_offset, file);
    return read_points(record_source(d + h.body_offset, point_size_of(h)), h.points, record_layout(h, axis, selection),
                       keep_nonfinite);
  }
  if (h.format == pcd_format::binary_compressed) {
    const uncompressed_body body = decompress_body(data, h, file);
    const std::size_t stride = h.points == 0 ? 1 : body.bytes.size() / static_cast<std::size_t>(h.points);
    return read_points(record_source(reinterpret_cast<const unsigned char*>(body.bytes.data()), stride), h.points,
                       field_major_layout(h, axis, selection, body), keep_nonfinite);
  }
  point_cloud cloud = read_ascii_cloud(data, h, axis, keep_nonfinite, file);
  cloud.keep_fields(selection);
  return cloud;
}

/// The header of the file `data`, checked: its axes, and the fields marked
/// (assign_columns()).
pcd_header checked_header(const header_source& src, const std::string& file, std::array<std::size_t, 3>& axis) {
  pcd_header h = parse_header(src, file);
  axis = find_axes(h, file);
  std::size_t ncols = 0;
  assign_columns(h, file, ncols);
  return h;
}

point_cloud parse_pcd(std::string_view data, const std::string& file, pcd_read_info* info, bool keep_nonfinite,
                      const field_selection& selection) {
  std::array<std::size_t, 3> axis{};
  const pcd_header h = checked_header(header_source{data}, file, axis);
  point_cloud cloud = read_body(data, h, axis, keep_nonfinite, selection, file);
  if (info) {
    *info = info_of(h);
    info->nonfinite_removed = static_cast<std::size_t>(h.points) - cloud.size();
  }
  return cloud;
}

/// read_pcd() of a file: binary records are read in parallel chunks straight
/// from the file; the other encodings are read whole.
point_cloud read_pcd_path(const std::string& path, pcd_read_info* info, bool keep_nonfinite,
                          const field_selection& selection) {
  if (!chunked_file(path)) return parse_pcd(read_whole_file(path), path, info, keep_nonfinite, selection);
  input_file file(path);
  std::array<std::size_t, 3> axis{};
  const pcd_header h = file.parse_header([&](const header_source& src) { return checked_header(src, path, axis); });
  if (h.format != pcd_format::binary) {
    const big_bytes data = read_all(file);
    return parse_pcd(std::string_view(data.data(), data.size()), path, info, keep_nonfinite, selection);
  }
  check_binary_size(h, file.size() - h.body_offset, path);
  point_cloud cloud = read_points(record_source(file, h.body_offset, point_size_of(h)), h.points,
                                  record_layout(h, axis, selection), keep_nonfinite);
  if (info) {
    *info = info_of(h);
    info->nonfinite_removed = static_cast<std::size_t>(h.points) - cloud.size();
  }
  return cloud;
}

// ------------------------------------------------------------------ writer

struct out_column {
  std::string name;
  char type = 'F';
  std::size_t size = 4;
  scalar_type enc = scalar_type::float32;  ///< how values are encoded (rgb: uint32 bits)
  const column* values = nullptr;          ///< field values, or nullptr
  int axis = -1;                           ///< 0/1/2 for positions
  const column* rgb[3] = {nullptr, nullptr, nullptr};
};

std::vector<out_column> plan_columns(const point_cloud& cloud, pcd_format fmt) {
  const std::size_t n = cloud.size();
  const field* rgb[3] = {cloud.find_field("red"), cloud.find_field("green"), cloud.find_field("blue")};
  const bool pack = rgb[0] && rgb[1] && rgb[2] && rgb[0]->type() == scalar_type::uint8 &&
                    rgb[1]->type() == scalar_type::uint8 && rgb[2]->type() == scalar_type::uint8;
  for (const auto& f : cloud.fields()) {
    if (f.name.empty() || f.name == "_" ||
        std::any_of(f.name.begin(), f.name.end(), [](char c) { return is_space(c) || c < 32 || c == 127; }))
      throw std::invalid_argument("field name '" + f.name +
                                  "' cannot be written to PCD (empty, '_' or has whitespace)");
    if (f.name == "x" || f.name == "y" || f.name == "z")
      throw std::invalid_argument("field '" + f.name + "' clashes with the PCD coordinate field");
    if (pack && (f.name == "rgb" || f.name == "rgba"))
      throw std::invalid_argument("field '" + f.name +
                                  "' clashes with the packed rgb field written for red/green/blue");
    check_field_size(f, n);
  }
  const auto& o = cloud.origin();
  const bool georef = o[0] != 0 || o[1] != 0 || o[2] != 0;
  std::vector<out_column> cols;
  for (int k = 0; k < 3; ++k) {
    out_column c;
    c.name = std::string(1, static_cast<char>('x' + k));
    c.size = georef ? 8 : 4;
    c.enc = georef ? scalar_type::float64 : scalar_type::float32;
    c.axis = k;
    cols.push_back(c);
  }
  for (const auto& f : cloud.fields()) {
    if (pack && (&f == rgb[1] || &f == rgb[2])) continue;
    out_column c;
    if (pack && &f == rgb[0]) {
      c.name = "rgb";
      c.type = fmt == pcd_format::ascii ? 'U' : 'F';
      c.size = 4;
      c.enc = scalar_type::uint32;
      for (int k = 0; k < 3; ++k) c.rgb[k] = &rgb[k]->values;
    } else {
      c.name = f.name;
      c.type = type_char(f.type());
      c.size = size_of(f.type());
      c.enc = f.type();
      c.values = &f.values;
    }
    cols.push_back(c);
  }
  check_values_per_point(cols.size(), "PCD");
  return cols;
}

std::string make_header(const std::vector<out_column>& cols, std::size_t n, pcd_format fmt) {
  std::string h = "# .PCD v0.7 - Point Cloud Data file format (written by ced)\nVERSION 0.7\nFIELDS";
  for (const auto& c : cols) h += " " + c.name;
  h += "\nSIZE";
  for (const auto& c : cols) h += " " + std::to_string(c.size);
  h += "\nTYPE";
  for (const auto& c : cols) h += std::string(" ") + c.type;
  h += "\nCOUNT";
  for (std::size_t i = 0; i < cols.size(); ++i) h += " 1";
  h += "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(n) + "\nDATA ";
  h += fmt == pcd_format::ascii ? "ascii" : fmt == pcd_format::binary ? "binary" : "binary_compressed";
  h += "\n";
  return h;
}

/// v[i] = value of column c for point i0 + i, i < m.
void column_values(const out_column& c, const point_cloud& cloud, std::size_t i0, std::size_t m, double* v) {
  if (c.values) {
    copy_values(*c.values, i0, m, v);
  } else if (c.axis >= 0) {
    const auto k = static_cast<std::size_t>(c.axis);
    const double o = cloud.origin()[k];
    const float* xyz = cloud.positions().data();
    if (o == 0)  // keeps -0
      for (std::size_t i = 0; i < m; ++i) v[i] = static_cast<double>(xyz[3 * (i0 + i) + k]);
    else
      for (std::size_t i = 0; i < m; ++i) v[i] = o + static_cast<double>(xyz[3 * (i0 + i) + k]);
  } else {
    // Packed only from uint8 fields (plan_columns()).
    const std::uint8_t* rgb[3] = {c.rgb[0]->data<std::uint8_t>() + i0, c.rgb[1]->data<std::uint8_t>() + i0,
                                  c.rgb[2]->data<std::uint8_t>() + i0};
    for (std::size_t i = 0; i < m; ++i)
      v[i] = static_cast<double>(std::uint32_t{rgb[0][i]} << 16 | std::uint32_t{rgb[1][i]} << 8 | rgb[2][i]);
  }
}

/// The binary_compressed body: the sizes, then the LZF-compressed values,
/// field by field (each column of all points, then the next).
void write_compressed(std::ostream& out, const point_cloud& cloud, const std::vector<out_column>& cols,
                      std::size_t record) {
  const std::size_t n = cloud.size();
  constexpr std::size_t chunk = 4096;
  std::vector<double> vals(chunk);
  ced::detail::raw_column_vector<unsigned char> block(n * record);  // field-major; every byte is written below
  unsigned char* const base = block.data();
  std::size_t offset = 0;
  for (const auto& c : cols) {
    for (std::size_t i0 = 0; i0 < n; i0 += chunk) {
      const std::size_t m = std::min(chunk, n - i0);
      column_values(c, cloud, i0, m, vals.data());
      const double* v = vals.data();
      encode_values(c.enc, !host_little_endian(), base + offset + i0 * c.size, c.size, m,
                    [v](std::size_t i) { return v[i]; });
    }
    offset += n * c.size;
  }
  ced::detail::raw_column_vector<unsigned char> packed;
  detail::lzf_compress_into(std::string_view(reinterpret_cast<const char*>(base), block.size()), packed,
                            detail::lzf_segment_bytes(block.size()), 0);
  if (packed.size() > std::numeric_limits<std::uint32_t>::max())
    throw io_error("the compressed cloud is too large for PCD binary_compressed");
  unsigned char sizes[8];
  store_le<std::uint32_t>(sizes, static_cast<std::uint32_t>(packed.size()));
  store_le<std::uint32_t>(sizes + 4, static_cast<std::uint32_t>(block.size()));
  out.write(reinterpret_cast<const char*>(sizes), 8);
  out.write(reinterpret_cast<const char*>(packed.data()), static_cast<std::streamsize>(packed.size()));
}

/// The points of `cloud` as ascii or binary data, after the header.
void write_body(std::ostream& out, const point_cloud& cloud, const std::vector<out_column>& cols, pcd_format fmt) {
  std::vector<scalar_type> types;
  for (const auto& c : cols) types.push_back(c.enc);
  point_format pf;
  pf.text = fmt == pcd_format::ascii;
  pf.swap = !host_little_endian();
  std::vector<const column*> direct;
  for (const auto& c : cols) direct.push_back(c.values);
  write_points(
      out, cloud.size(), types, pf,
      [&](std::size_t c, std::size_t i0, std::size_t m, double* v) { column_values(cols[c], cloud, i0, m, v); },
      direct);
}

void write_pcd_unchecked(std::ostream& out, const point_cloud& cloud, pcd_format fmt) {
  const std::vector<out_column> cols = plan_columns(cloud, fmt);
  const std::size_t n = cloud.size();
  std::size_t record = 0;
  for (const auto& c : cols) record += c.size;
  if (fmt == pcd_format::binary_compressed && n > std::numeric_limits<std::uint32_t>::max() / record)
    throw io_error("the cloud is too large for PCD binary_compressed (4 GiB or more of data)");
  const std::string header = make_header(cols, n, fmt);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  if (fmt == pcd_format::binary_compressed) return write_compressed(out, cloud, cols, record);
  write_body(out, cloud, cols, fmt);
}

}  // namespace

// ------------------------------------------------------------------- public

point_cloud read_pcd_buffer(std::string_view bytes, const std::string& name_for_errors, pcd_read_info* info,
                            bool keep_nonfinite) {
  return parse_pcd(bytes, name_for_errors, info, keep_nonfinite, {});
}

point_cloud read_pcd(const std::string& path, pcd_read_info* info, bool keep_nonfinite) {
  return read_pcd_path(path, info, keep_nonfinite, {});
}

void write_pcd(std::ostream& out, const point_cloud& cloud, pcd_format fmt) {
  detail::write_to_stream(out, "PCD", [&](std::ostream& o) { write_pcd_unchecked(o, cloud, fmt); });
}

void write_pcd(const std::string& path, const point_cloud& cloud, pcd_format fmt) {
  detail::write_to_file(path, [&](std::ostream& o) { write_pcd_unchecked(o, cloud, fmt); });
}

namespace detail {
/// read_report::details of a PCD file ("PCD binary, organized 640x480").
std::string pcd_details(const pcd_read_info& info);
}  // namespace detail

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
namespace {
class pcd_piece_writer final : public piece_writer {
 public:
  pcd_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
    const std::string header = make_header(plan_columns(layout, pcd_format::binary), n, pcd_format::binary);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    write_body(out, chunk, plan_columns(chunk, pcd_format::binary), pcd_format::binary);
  }
};
}  // namespace

std::unique_ptr<piece_writer> pcd_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<pcd_piece_writer>(out, layout, n);
}

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
  e.pieces = [](std::ostream& out, const point_cloud& layout, std::uint64_t n, bool) {
    return pcd_pieces(out, layout, n);
  };
  e.stream = [](const std::string& path, const read_options& o) { return open_pcd_stream(path, o.fields); };
  return e;
}
}  // namespace detail

}  // namespace ced::io
