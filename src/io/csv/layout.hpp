// SPDX-License-Identifier: MIT
// What the parts of the CSV reader and writer share (read.cpp, write.cpp, stream.cpp):
// the preamble, the names, the rows. Private to src/io/csv/.
#pragma once

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

namespace ced::io::csv_detail {

using namespace ced::io::detail;  // scalar_io.hpp

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

std::string_view unquote(std::string_view s) noexcept;

bool is_comment(std::string_view trimmed) noexcept;

/// Splits `line` at `delim` (' ' = runs of blanks), trimming and unquoting
/// each value. Appends to `out`.
void split(std::string_view line, char delim, std::vector<std::string_view>& out);

char detect_delimiter(std::string_view line) noexcept;

/// A CSV value: false (no exception) for text that is not a number; an
/// optional '+'; infinities from overflow kept. Sets is_int when the token is
/// an integer literal that fits int64 (the column's type comes from it). Not
/// ced::parse_number, which parses option values and throws.
bool parse_csv_number(std::string_view tok, double& out, bool& is_int) noexcept;

bool is_separator(char c) noexcept;

bool is_numeric_line(std::string_view line);

/// A column name as the cloud calls it: x, y, z in lower case, r, g, b (any
/// case) as red, green, blue; any other as given.
std::string normal_name(std::string_view name);

/// The header's column names: strips a `//` or `#` prefix and normalises x/y/z
/// (any case) and r/g/b (any case: red/green/blue).
/// `delim` (0 = auto) is used when the line contains it, else detected.
std::vector<std::string> header_names(std::string_view line, char delim);

bool names_xyz(const std::vector<std::string>& names);

std::string join(const std::vector<std::string>& v);

/// Reads the comments, the header (when the options allow one) and stops
/// before the first data line. Fails when the file has neither data nor a
/// header (a commented header naming x, y and z counts: an empty cloud).
preamble read_preamble(std::string_view text, const csv_options& opt, char delim_opt, const std::string& file);

/// The column names the file or the options give: the columns option, the
/// header line, or the last commented header before the data that names x, y
/// and z. `source` receives where they came from, for messages.
std::vector<std::string> given_names(const preamble& pre, const csv_options& opt, char delim_opt, std::string& source);

/// A .pts file starts with its point count, a line holding one integer:
/// moves the data start past it (and past the comments and blank lines that
/// follow; have_data false when nothing does).
void skip_point_count(preamble& pre);

/// The names of a file without a header, from its number of columns.
std::vector<std::string> default_names(std::size_t values, std::size_t line_no, const std::string& file);

/// Checks the names (not too many, none empty, none twice); returns the
/// columns of x, y and z.
std::array<std::size_t, 3> check_names(const std::vector<std::string>& names, const std::string& source,
                                       const std::string& file);

/// The data lines of `lines` (from its position to the end of its text):
/// neither blank nor comments.
std::size_t count_data_lines(line_reader lines) noexcept;

/// The values of the data lines of `lines` (from its position to the end of
/// its text) into cols[j].values[first + r] for data line r, their statistics
/// into `stats`; `first_line`: its first data line is the file's.
void read_block(line_reader lines, bool first_line, char delim, const std::vector<std::string>& names,
                const csv_options& opt, const std::string& file, std::vector<column_state>& cols, std::size_t first,
                std::vector<column_stats>& stats);

/// The values of the data lines from `lines` on, column by column. Cut into
/// blocks of whole lines, counted (each block's data lines and line ends),
/// then parsed on the threads straight into the columns. Each block keeps
/// its first error; the earliest in the file is rethrown, as one thread
/// would have met it.
std::vector<column_state> read_rows(line_reader lines, char delim, const std::vector<std::string>& names,
                                    const csv_options& opt, const std::string& file);

/// The cloud of the columns: x, y, z as positions, the others as fields of
/// the narrowest type that holds them (uint8 colours, int32, else float64).
point_cloud make_cloud(std::vector<column_state>& cols, const std::vector<std::string>& names,
                       const std::array<std::size_t, 3>& axis);

/// Checks the delimiter option; returns it as split() takes it.
char delimiter_option(const csv_options& opt);

/// The layout of `text` (the file without its byte order mark).
csv_layout read_layout(std::string_view text, const csv_options& opt, const std::string& file);

bool has_bom(std::string_view text) noexcept;

point_cloud parse_csv(std::string_view text, const std::string& file, const csv_options& opt);

/// Throws std::invalid_argument when a field cannot be a CSV column,
/// io_error when there are more columns than the reader accepts.
void check_writable(const point_cloud& cloud);

void write_header(std::ostream& out, const point_cloud& cloud);

/// The rows of `cloud`, after the header.
void write_body(std::ostream& out, const point_cloud& cloud);

void write_csv_unchecked(std::ostream& out, const point_cloud& cloud);

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

}  // namespace ced::io::csv_detail

namespace ced::io::detail {
/// CSV in pieces (cloud_writer).
std::unique_ptr<piece_writer> csv_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n);
}  // namespace ced::io::detail
