// SPDX-License-Identifier: MIT
// CSV/XYZ/TXT/PTS read whole: the preamble, the names, the rows in parallel blocks.
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

namespace csv_detail {

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

}  // namespace csv_detail

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

}  // namespace ced::io
