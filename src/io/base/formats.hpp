// SPDX-License-Identifier: MIT
// The table of file formats that read_cloud(), write_cloud(), cloud_writer
// and open_point_stream() go through (io.cpp, stream.cpp): one entry a
// format, with its names, extensions, reader, writers and streaming reader.
// A built-in format is a file that makes its entry (ply/stream.cpp: ply_entry())
// and a row in formats.cpp. Private, not installed.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "ced/io/io.hpp"
#include "ced/io/stream.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io::detail {

struct format_entry {
  file_format id = file_format::automatic;
  /// format_name(); also what parse_format() and --format take.
  std::string name;
  /// Other names parse_format() takes ("xyz" for csv).
  std::vector<std::string> aliases;
  /// Extensions, lower case, without the first dot ("ply", "copc.laz"); the
  /// longest that ends a path names its format. Those with no dot inside are
  /// listed in format_of()'s error for an unknown extension.
  std::vector<std::string> extensions;
  /// The whole file: the cloud (all fields, or at least those of
  /// options.fields), and what reading found in `report` (details, ...).
  std::function<point_cloud(const std::string& path, const read_options& options, read_report& report)> read;
  /// The whole cloud to a stream; `las` null for the format's defaults
  /// (formats other than LAS, LAZ and COPC ignore it).
  std::function<void(std::ostream& out, const point_cloud& cloud, const las_write_options* las)> write;
  /// The header of `n` points with `layout`'s fields, then the points in
  /// pieces (cloud_writer).
  std::function<std::unique_ptr<piece_writer>(std::ostream& out, const point_cloud& layout, std::uint64_t n)> pieces;
  /// Whether the pieces go back to the start of the output to rewrite the
  /// header (LAS and LAZ): cloud_writer then refuses an output it cannot seek.
  bool pieces_seek_back = false;
  /// A streaming reader, or nullptr when this file is read whole (then
  /// open_point_stream() reads it with `read`). Called for regular files
  /// only, unless `streams_any_file`.
  std::function<std::unique_ptr<point_stream>(const std::string& path, const read_options& options)> stream;
  bool streams_any_file = false;
};

/// Every format: the built-ins (formats.cpp) in the order of format_name()'s
/// list, then those added.
const std::vector<format_entry>& formats();
/// The entry of `f`; std::invalid_argument for automatic or unknown.
const format_entry& format_entry_of(file_format f);
/// Adds a format (tests; before any reading or writing, from one thread).
/// Its id must be new, e.g. static_cast<file_format>(100).
void add_format(format_entry entry);

}  // namespace ced::io::detail
