// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/error.hpp"

namespace ced::io {

/// How read_csv interprets a delimited text file.
struct csv_options {
  /// When non-empty: the column names, in order. The file then has no header
  /// line, unless skip_header is set too.
  std::vector<std::string> columns;
  /// Skip the first line that is neither blank nor a comment (a header to ignore).
  bool skip_header = false;
  /// ',' or ';', or whitespace: '\t' and ' ' both split at runs of spaces and
  /// tabs. 0 = auto: ';' when the line contains one, else ',' when it contains
  /// one, else whitespace.
  char delimiter = 0;
};

/// Reads a delimited text point cloud (.csv, .txt, .xyz, .pts, ...): one point
/// per line.
///
/// - Blank lines and comment lines (starting with `#` or `//`) are skipped. A
///   UTF-8 byte order mark and CRLF line endings are accepted. Values may be
///   surrounded by spaces or double quotes.
/// - Header: the first non-comment line is a header when it is not all
///   numeric (`x,y,z,red,green,blue,intensity`). Otherwise, the last comment
///   line before the data that names x, y and z is the header (`//X Y Z R G B`
///   as CloudCompare writes it, `# x y z`). The header's delimiter is detected
///   on its own line, the data's on the first data line.
/// - Without a header and without `columns`, the number of values on the
///   first data line decides: 3 -> x y z; 4 -> x y z intensity; 6 -> x y z red
///   green blue; 7 -> x y z intensity red green blue. Any other count is an
///   error asking for the column names (--columns). A first data line holding
///   a single integer (the point count of a Leica .pts file) is then skipped.
/// - Names: x, y, z match in any case; r, g, b (any case) become red, green,
///   blue; every other name is kept as written. Duplicate names are an error.
/// - Field types (CSV stores none): a column named red, green or blue whose
///   values are all integers in [0, 255] is uint8; any other column whose
///   values are all written as integers in the int32 range is int32;
///   everything else is float64.
/// - Positions: when the coordinates are large (|mean| > 1e4 on some axis),
///   the origin is set to the first point rounded to integers and positions
///   are stored relative to it, as read_ply does. NaN/Inf coordinates are kept.
/// - Zero data lines (a header only) give an empty cloud, not an error.
///
/// Throws io_error naming the file, and the line and column where it applies:
/// empty file, wrong number of values on a line, non-numeric value, missing
/// x/y/z column, duplicate column names, more than 4096 columns, no header and
/// an unusual column count;
/// std::invalid_argument for an unsupported delimiter option.
///
/// Threading: reentrant (no shared state).
point_cloud read_csv(const std::string& path, const csv_options& options = {});
/// Same, from the text of a file; `name` names it in messages.
point_cloud read_csv_buffer(std::string_view text, const std::string& name, const csv_options& options = {});

/// Writes `cloud` as comma-separated text to `path` atomically (see
/// atomic_output_file): a header `x,y,z,<field names>`, then one line per
/// point. Positions (origin added back) and values are written in the
/// shortest form that reads back to the same float (float32 fields and
/// positions with a zero origin) or double (everything else); integer fields
/// are rounded and clamped to their type; NaN is written as `nan`.
/// Throws io_error on I/O failure and for more than 65 536 columns (read_csv's
/// limit), before writing anything, and std::invalid_argument for fields that
/// cannot be written (name empty, x/y/z, or containing a delimiter, quote,
/// `#` or whitespace; wrong number of values).
void write_csv(const std::string& path, const point_cloud& cloud);
/// Same, to a stream.
void write_csv(std::ostream& out, const point_cloud& cloud);

}  // namespace ced::io
