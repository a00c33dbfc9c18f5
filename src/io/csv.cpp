// SPDX-License-Identifier: MIT
#include "ced/io/csv.hpp"

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

#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io {

using namespace detail;  // scalar_io.hpp

namespace {

// The text is read line by line: no value or name holds a '\n', and blanks
// (is_space) separate values.

std::string_view unquote(std::string_view s) noexcept {
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = trim(s.substr(1, s.size() - 2));
  return s;
}

bool is_comment(std::string_view trimmed) noexcept {
  return !trimmed.empty() && (trimmed[0] == '#' || trimmed.substr(0, 2) == "//");
}

/// Splits `line` at `delim` (' ' = runs of blanks), trimming and unquoting
/// each value. Appends to `out`.
void split(std::string_view line, char delim, std::vector<std::string_view>& out) {
  out.clear();
  if (delim == ' ') {
    word_reader<> words(line);
    for (std::string_view w; words.next(w);) out.push_back(unquote(w));
    return;
  }
  std::size_t b = 0;
  for (;;) {
    const std::size_t e = line.find(delim, b);
    out.push_back(unquote(trim(line.substr(b, e == std::string_view::npos ? std::string_view::npos : e - b))));
    if (e == std::string_view::npos) break;
    b = e + 1;
  }
}

char detect_delimiter(std::string_view line) noexcept {
  if (line.find(';') != std::string_view::npos) return ';';
  if (line.find(',') != std::string_view::npos) return ',';
  return ' ';
}

/// A CSV value: false (no exception) for text that is not a number; an
/// optional '+'; infinities from overflow kept. Sets is_int when the token is
/// an integer literal that fits int64 (the column's type comes from it). Not
/// ced::parse_number, which parses option values and throws.
bool parse_csv_number(std::string_view tok, double& out, bool& is_int) noexcept {
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (b != e && *b == '+') ++b;
  if (b == e) return false;
  std::int64_t i = 0;
  auto r = std::from_chars(b, e, i);
  if (r.ptr == e && r.ec == std::errc()) {
    out = i == 0 && tok[0] == '-' ? -0.0 : static_cast<double>(i);
    is_int = true;
    return true;
  }
  is_int = false;
  const auto rd = std::from_chars(b, e, out);
  if (rd.ptr != e) return false;
  if (rd.ec == std::errc::result_out_of_range) {  // overflow (-> inf) or underflow (-> denormal/0)
    char buf[128];
    if (tok.size() >= sizeof(buf)) return false;
    std::memcpy(buf, tok.data(), tok.size());
    buf[tok.size()] = '\0';
    out = std::strtod(buf, nullptr);
    return true;
  }
  return rd.ec == std::errc();
}

bool is_separator(char c) noexcept { return is_space(c) || c == ',' || c == ';'; }

bool is_numeric_line(std::string_view line) {
  std::size_t tokens = 0;
  word_reader<is_separator> words(line);
  for (std::string_view w; words.next(w); ++tokens) {
    double v;
    bool is_int;
    if (!parse_csv_number(unquote(w), v, is_int)) return false;
  }
  return tokens > 0;
}

/// Iterates over the lines of a text: the line without its '\n' and trailing
/// blanks, and its 1-based number.
struct line_reader {
  std::string_view text;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  bool next(std::string_view& line) noexcept {
    if (pos >= text.size()) return false;
    const std::size_t nl = text.find('\n', pos);
    const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
    line = trim(text.substr(pos, end - pos));
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_no;
    return true;
  }
};

/// A column name as the cloud calls it: x, y, z in lower case, r, g, b (any
/// case) as red, green, blue; any other as given.
std::string normal_name(std::string_view name) {
  const std::string l = to_lower(name);
  if (l == "x" || l == "y" || l == "z") return l;
  if (l == "r") return "red";
  if (l == "g") return "green";
  if (l == "b") return "blue";
  return std::string(name);
}

/// The header's column names: strips a `//` or `#` prefix and normalises x/y/z
/// (any case) and r/g/b (any case: red/green/blue).
/// `delim` (0 = auto) is used when the line contains it, else detected.
std::vector<std::string> header_names(std::string_view line, char delim) {
  line = trim(line);
  if (line.substr(0, 2) == "//")
    line.remove_prefix(2);
  else if (!line.empty() && line[0] == '#')
    line.remove_prefix(1);
  line = trim(line);
  if (delim == ' ' ? line.find_first_of(" \t") == std::string_view::npos : line.find(delim) == std::string_view::npos)
    delim = detect_delimiter(line);
  std::vector<std::string_view> tok;
  split(line, delim, tok);
  std::vector<std::string> names;
  for (auto t : tok) names.push_back(normal_name(t));
  return names;
}

bool names_xyz(const std::vector<std::string>& names) {
  for (const char* a : {"x", "y", "z"})
    if (std::find(names.begin(), names.end(), a) == names.end()) return false;
  return true;
}

std::string join(const std::vector<std::string>& v) {
  std::string r;
  for (const auto& s : v) r += (r.empty() ? "" : ", ") + s;
  return r;
}

/// What decides a column's type: whether its values are all integers, and their range.
struct column_stats {
  bool all_int = true;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v, bool is_int) noexcept {
    all_int = all_int && is_int;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  /// The statistics of both sets of values (in any order: the same).
  void merge(const column_stats& o) noexcept {
    all_int = all_int && o.all_int;
    lo = std::min(lo, o.lo);
    hi = std::max(hi, o.hi);
  }
  /// The narrowest type of the n values of column `name`: uint8 colours,
  /// int32, else float64.
  scalar_type type(const std::string& name, std::size_t n) const noexcept {
    const bool colour = name == "red" || name == "green" || name == "blue";
    if (all_int && colour && (n == 0 || (lo >= 0 && hi <= 255))) return scalar_type::uint8;
    if (all_int &&
        (n == 0 || (lo >= std::numeric_limits<std::int32_t>::min() && hi <= std::numeric_limits<std::int32_t>::max())))
      return scalar_type::int32;
    return scalar_type::float64;
  }
};

struct column_state {
  std::vector<double> values;
  column_stats stats;
};

/// What comes before the data: comments, the header line, and where the data starts.
struct preamble {
  std::string_view header;  ///< the header line, or empty
  std::size_t header_line = 0;
  std::vector<std::pair<std::size_t, std::string_view>> comments;  ///< (line number, line)
  bool have_data = false;                                          ///< a data line follows
  line_reader data_start;                                          ///< just before the first data line
};

/// Reads the comments, the header (when the options allow one) and stops
/// before the first data line. Fails when the file has neither data nor a
/// header (a commented header naming x, y and z counts: an empty cloud).
preamble read_preamble(std::string_view text, const csv_options& opt, char delim_opt, const std::string& file) {
  preamble pre;
  line_reader lines{text};
  pre.data_start = lines;
  std::string_view line;
  bool any_line = false, skipped = false;
  while (true) {
    const line_reader before = lines;
    if (!lines.next(line)) break;
    if (line.empty()) continue;
    if (is_comment(line)) {
      pre.comments.emplace_back(lines.line_no, line);
      continue;
    }
    any_line = true;
    if (opt.skip_header && !skipped) {
      skipped = true;
      pre.header_line = lines.line_no;
      continue;
    }
    if (opt.columns.empty() && !opt.skip_header && pre.header.empty() && !is_numeric_line(line)) {
      pre.header = line;
      pre.header_line = lines.line_no;
      continue;
    }
    pre.data_start = before;
    pre.have_data = true;
    break;
  }
  if (!any_line) {
    // Only comments: a CloudCompare-style header with no points is still an (empty) cloud.
    bool named = false;
    for (const auto& c : pre.comments) named = named || names_xyz(header_names(c.second, delim_opt));
    if (!named) throw io_error(file, "the file is empty (no header and no data)");
  }
  return pre;
}

/// The column names the file or the options give: the columns option, the
/// header line, or the last commented header before the data that names x, y
/// and z. `source` receives where they came from, for messages.
std::vector<std::string> given_names(const preamble& pre, const csv_options& opt, char delim_opt, std::string& source) {
  std::vector<std::string> names;
  if (!opt.columns.empty()) {
    for (const auto& c : opt.columns) names.push_back(normal_name(c));
    source = "the columns option";
  } else if (!pre.header.empty()) {
    names = header_names(pre.header, delim_opt);
    source = "the header (line " + std::to_string(pre.header_line) + ")";
  } else if (!opt.skip_header) {
    const std::size_t first_data = pre.have_data ? pre.data_start.line_no + 1 : std::numeric_limits<std::size_t>::max();
    for (auto it = pre.comments.rbegin(); it != pre.comments.rend(); ++it) {
      if (it->first > first_data) continue;
      auto n = header_names(it->second, delim_opt);
      if (names_xyz(n)) {
        names = std::move(n);
        source = "the header (line " + std::to_string(it->first) + ")";
        break;
      }
    }
  }
  return names;
}

/// A .pts file starts with its point count, a line holding one integer:
/// moves the data start past it (and past the comments and blank lines that
/// follow; have_data false when nothing does).
void skip_point_count(preamble& pre) {
  line_reader peek = pre.data_start;
  std::string_view line;
  peek.next(line);
  if (line.empty() || !std::all_of(line.begin(), line.end(), [](char c) { return c >= '0' && c <= '9'; })) return;
  pre.data_start = peek;
  pre.have_data = false;
  while (!pre.have_data) {
    const line_reader before = peek;
    if (!peek.next(line)) break;
    if (line.empty() || is_comment(line)) continue;
    pre.data_start = before;
    pre.have_data = true;
  }
}

/// The names of a file without a header, from its number of columns.
std::vector<std::string> default_names(std::size_t values, std::size_t line_no, const std::string& file) {
  switch (values) {
    case 3:
      return {"x", "y", "z"};
    case 4:
      return {"x", "y", "z", "intensity"};
    case 6:
      return {"x", "y", "z", "red", "green", "blue"};
    case 7:
      return {"x", "y", "z", "intensity", "red", "green", "blue"};
    default:
      throw io_error(file, "line " + std::to_string(line_no) + ": " + std::to_string(values) +
                               " values and no header: name the columns (--columns x,y,z,...)");
  }
}

/// Checks the names (not too many, none empty, none twice); returns the
/// columns of x, y and z.
std::array<std::size_t, 3> check_names(const std::vector<std::string>& names, const std::string& source,
                                       const std::string& file) {
  constexpr std::size_t max_columns = max_values_per_point;  // scalar_io.hpp
  if (names.size() > max_columns)
    throw io_error(file, source + " names " + std::to_string(names.size()) + " columns (at most " +
                             std::to_string(max_columns) + " are supported)");
  std::set<std::string> seen;
  for (const auto& n : names) {
    if (n.empty()) throw io_error(file, source + " has an empty column name");
    if (!seen.insert(n).second) throw io_error(file, source + " names column '" + n + "' twice");
  }
  std::array<std::size_t, 3> axis{};
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string a(1, static_cast<char>('x' + k));
    const auto it = std::find(names.begin(), names.end(), a);
    if (it == names.end()) throw io_error(file, source + " has no '" + a + "' column (columns: " + join(names) + ")");
    axis[k] = static_cast<std::size_t>(it - names.begin());
  }
  return axis;
}

/// Splits the data line `line` (number `line_no`; `first` for the first data
/// line) into its values: value(j, v, is_int) for each column j. `tok` is
/// scratch space.
template <class Value>
void parse_row(std::string_view line, std::size_t line_no, bool first, char delim,
               const std::vector<std::string>& names, const csv_options& opt, const std::string& file,
               std::vector<std::string_view>& tok, Value&& value) {
  const std::size_t ncols = names.size();
  split(line, delim, tok);
  if (tok.size() != ncols)
    throw io_error(file, "line " + std::to_string(line_no) + ": expected " + std::to_string(ncols) + " values (" +
                             join(names) + "), found " + std::to_string(tok.size()));
  for (std::size_t j = 0; j < ncols; ++j) {
    double v = 0;
    bool is_int = false;
    if (!parse_csv_number(tok[j], v, is_int)) {
      std::string msg = "line " + std::to_string(line_no) + ", column " + std::to_string(j + 1) + " ('" + names[j] +
                        "'): '" + printable(tok[j]) + "' is not a number";
      if (first && !opt.columns.empty() && !opt.skip_header) msg += " (a header line? set skip_header)";
      throw io_error(file, msg);
    }
    value(j, v, is_int);
  }
}

/// The data lines of `lines` (from its position to the end of its text):
/// neither blank nor comments.
std::size_t count_data_lines(line_reader lines) noexcept {
  std::size_t n = 0;
  for (std::string_view line; lines.next(line);) n += !line.empty() && !is_comment(line);
  return n;
}

/// The values of the data lines of `lines` (from its position to the end of
/// its text) into cols[j].values[first + r] for data line r, their statistics
/// into `stats`; `first_line`: its first data line is the file's.
void read_block(line_reader lines, bool first_line, char delim, const std::vector<std::string>& names,
                const csv_options& opt, const std::string& file, std::vector<column_state>& cols, std::size_t first,
                std::vector<column_stats>& stats) {
  std::string_view line;
  std::vector<std::string_view> tok;
  const std::size_t rows = cols.empty() ? 0 : cols[0].values.size();
  for (std::size_t r = first; lines.next(line);) {
    if (line.empty() || is_comment(line)) continue;
    if (r == rows) return;  // more lines than values fit: an earlier line is bad (read_rows())
    parse_row(line, lines.line_no, first_line, delim, names, opt, file, tok, [&](std::size_t j, double v, bool is_int) {
      cols[j].values[r] = v;
      stats[j].add(v, is_int);
    });
    first_line = false;
    ++r;
  }
}

/// The values of the data lines from `lines` on, column by column. Cut into
/// blocks of whole lines, counted (each block's data lines and line ends),
/// then parsed on the threads straight into the columns. Each block keeps
/// its first error; the earliest in the file is rethrown, as one thread
/// would have met it.
std::vector<column_state> read_rows(line_reader lines, char delim, const std::vector<std::string>& names,
                                    const csv_options& opt, const std::string& file) {
  const std::string_view text = lines.text;
  const std::size_t blocks = ascii_blocks(text.size() - lines.pos);
  const std::vector<const char*> cut = cut_lines(text.data() + lines.pos, text.data() + text.size(), blocks);
  // Block k is text[cut[k], cut[k + 1]): whole lines, read by reader(k).
  const auto reader = [&](std::size_t k, std::size_t line_no) {
    return line_reader{text.substr(0, static_cast<std::size_t>(cut[k + 1] - text.data())),
                       static_cast<std::size_t>(cut[k] - text.data()), line_no};
  };
  std::vector<std::size_t> rows(blocks + 1, 0), line_no(blocks + 1, lines.line_no);  // before each block
  ced::detail::parallel_for(blocks, 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) {
      rows[k + 1] = count_data_lines(reader(k, 0));
      line_no[k + 1] = count_lines(cut[k], cut[k + 1]).second;
    }
  });
  for (std::size_t k = 1; k <= blocks; ++k) {
    rows[k] += rows[k - 1];
    line_no[k] += line_no[k - 1];
  }
  // A line of ncols values takes at least 2 * ncols bytes (a digit and a
  // separator each), so no more lines than that can all be good: the columns
  // stay within a few times the file size, however many columns the header
  // names, and a block whose rows would go past them stops (an earlier line
  // is bad, and its error is the one reported).
  const std::size_t ncols = names.size();
  const std::size_t fit = (text.size() - lines.pos + 1) / (2 * ncols) + 1;
  std::vector<column_state> cols(ncols);
  for (auto& c : cols) c.values.resize(std::min(rows[blocks], fit));
  std::vector<std::vector<column_stats>> stats(blocks, std::vector<column_stats>(names.size()));
  for_each_block(blocks, [&](std::size_t k) {
    read_block(reader(k, line_no[k]), k == 0, delim, names, opt, file, cols, rows[k], stats[k]);
  });
  for (std::size_t j = 0; j < cols.size(); ++j)
    for (const auto& s : stats) cols[j].stats.merge(s[j]);
  return cols;
}

/// The cloud of the columns: x, y, z as positions, the others as fields of
/// the narrowest type that holds them (uint8 colours, int32, else float64).
point_cloud make_cloud(std::vector<column_state>& cols, const std::vector<std::string>& names,
                       const std::array<std::size_t, 3>& axis) {
  const std::size_t n = cols[0].values.size();
  point_cloud cloud =
      cloud_at(cols[axis[0]].values.data(), cols[axis[1]].values.data(), cols[axis[2]].values.data(), n);
  for (std::size_t j = 0; j < cols.size(); ++j) {
    if (j == axis[0] || j == axis[1] || j == axis[2]) continue;
    cloud.add_field(names[j], cols[j].stats.type(names[j], n), std::move(cols[j].values));
  }
  return cloud;
}

/// What the lines before the data decide: the column names (none: the cloud
/// is empty), the columns of x, y and z, the data's delimiter and where the
/// data starts. Reads at most three lines that are neither blank nor
/// comments (a header or a skipped line, a .pts point count, the first data
/// line), and the lines before them.
struct csv_layout {
  std::vector<std::string> names;
  std::array<std::size_t, 3> axis{};
  char delim = 0;
  bool have_data = false;
  line_reader data_start;  ///< just before the first data line
};

/// Checks the delimiter option; returns it as split() takes it.
char delimiter_option(const csv_options& opt) {
  if (opt.delimiter != 0 && opt.delimiter != ',' && opt.delimiter != ';' && opt.delimiter != '\t' &&
      opt.delimiter != ' ')
    throw std::invalid_argument("unsupported CSV delimiter '" + std::string(1, opt.delimiter) +
                                "' (use ',', ';', tab or space)");
  return opt.delimiter == '\t' ? ' ' : opt.delimiter;  // tab: runs of blanks
}

/// The layout of `text` (the file without its byte order mark).
csv_layout read_layout(std::string_view text, const csv_options& opt, const std::string& file) {
  const char delim_opt = delimiter_option(opt);
  csv_layout layout;
  preamble pre = read_preamble(text, opt, delim_opt, file);
  std::string source;  // where the names came from, for messages
  std::vector<std::string> names = given_names(pre, opt, delim_opt, source);
  if (pre.have_data && names.empty()) {
    skip_point_count(pre);
    if (!pre.have_data) return layout;  // "0" and nothing else
  }

  // Data delimiter: from the first data line; so are the names when no header gives them.
  char delim = delim_opt;
  if (pre.have_data) {
    line_reader peek = pre.data_start;
    std::string_view line;
    peek.next(line);
    if (!delim) delim = detect_delimiter(line);
    if (names.empty()) {
      std::vector<std::string_view> tok;
      split(line, delim, tok);
      names = default_names(tok.size(), peek.line_no, file);
      source = "the default columns for " + std::to_string(tok.size()) + " values";
    }
  }
  if (names.empty()) return layout;  // skip_header and nothing else

  layout.axis = check_names(names, source, file);
  layout.names = std::move(names);
  layout.delim = delim;
  layout.have_data = pre.have_data;
  layout.data_start = pre.data_start;
  return layout;
}

bool has_bom(std::string_view text) noexcept { return text.substr(0, 3) == "\xEF\xBB\xBF"; }

point_cloud parse_csv(std::string_view text, const std::string& file, const csv_options& opt) {
  if (has_bom(text)) text.remove_prefix(3);
  const csv_layout layout = read_layout(text, opt, file);
  if (layout.names.empty()) return point_cloud{};
  std::vector<column_state> cols;
  if (layout.have_data)
    cols = read_rows(layout.data_start, layout.delim, layout.names, opt, file);
  else
    cols.resize(layout.names.size());
  return make_cloud(cols, layout.names, layout.axis);
}

// ------------------------------------------------------------------ writer

/// Throws std::invalid_argument when a field cannot be a CSV column,
/// io_error when there are more columns than the reader accepts.
void check_writable(const point_cloud& cloud) {
  check_values_per_point(3 + cloud.fields().size(), "CSV");
  const std::size_t n = cloud.size();
  for (const auto& f : cloud.fields()) {
    if (f.name.empty() || std::any_of(f.name.begin(), f.name.end(), [](char c) {
          return is_space(c) || c == ',' || c == ';' || c == '"' || c == '#' || c < 32 || c == 127;
        }))
      throw std::invalid_argument("field name '" + f.name +
                                  "' cannot be written to CSV (empty, or has whitespace, a delimiter, '\"' or '#')");
    const std::string l = to_lower(f.name);
    if (l == "x" || l == "y" || l == "z" || f.name.substr(0, 2) == "//")
      throw std::invalid_argument("field '" + f.name + "' clashes with the CSV coordinate columns");
    check_field_size(f, n);
  }
}

void write_header(std::ostream& out, const point_cloud& cloud) {
  std::string header = "x,y,z";
  for (const auto& f : cloud.fields()) header += "," + f.name;
  header += "\n";
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
}

/// The rows of `cloud`, after the header.
void write_body(std::ostream& out, const point_cloud& cloud) {
  const std::size_t n = cloud.size();
  // Positions as float (their own shortest text), or as double offset by a
  // non-zero origin; fields as their type.
  const auto& origin = cloud.origin();
  const bool georef = origin[0] != 0 || origin[1] != 0 || origin[2] != 0;
  std::vector<scalar_type> types(3, georef ? scalar_type::float64 : scalar_type::float32);
  for (const auto& f : cloud.fields()) types.push_back(f.type());
  const float* xyz = cloud.positions().data();
  point_format pf;
  pf.text = true;
  pf.separator = ',';
  write_points(out, n, types, pf, [&](std::size_t c, std::size_t i0, std::size_t m, double* v) {
    if (c >= 3) return copy_values(cloud.fields()[c - 3].values, i0, m, v);
    for (std::size_t i = 0; i < m; ++i) {
      const double p = xyz[3 * (i0 + i) + c];
      v[i] = georef ? origin[c] + p : p;  // without an origin, -0 stays -0
    }
  });
}

void write_csv_unchecked(std::ostream& out, const point_cloud& cloud) {
  check_writable(cloud);
  write_header(out, cloud);
  write_body(out, cloud);
}

}  // namespace

point_cloud read_csv_buffer(std::string_view text, const std::string& name, const csv_options& options) {
  return parse_csv(text, name, options);
}

point_cloud read_csv(const std::string& path, const csv_options& options) {
  if (!chunked_file(path)) return parse_csv(detail::read_whole_file(path), path, options);
  // A regular file: read into memory that faults in 2 MiB at a time.
  const input_file file(path);
  const big_bytes data = read_all(file);
  return parse_csv(std::string_view(data.data(), data.size()), path, options);
}

void write_csv(std::ostream& out, const point_cloud& cloud) {
  detail::write_to_stream(out, "CSV", [&](std::ostream& o) { write_csv_unchecked(o, cloud); });
}

void write_csv(const std::string& path, const point_cloud& cloud) {
  detail::write_to_file(path, [&](std::ostream& o) { write_csv_unchecked(o, cloud); });
}

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
namespace {
class csv_piece_writer final : public piece_writer {
 public:
  csv_piece_writer(std::ostream& out, const point_cloud& layout) {
    check_writable(layout);
    write_header(out, layout);
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    check_writable(chunk);
    write_body(out, chunk);
  }
};
}  // namespace

std::unique_ptr<piece_writer> csv_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t /*n*/) {
  return std::make_unique<csv_piece_writer>(out, layout);
}

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
  e.pieces = [](std::ostream& out, const point_cloud& layout, std::uint64_t n, bool) {
    return csv_pieces(out, layout, n);
  };
  e.stream = [](const std::string& path, const read_options& o) { return open_csv_stream(path, o.csv, o.fields); };
  return e;
}
}  // namespace detail

}  // namespace ced::io
