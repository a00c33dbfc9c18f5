// SPDX-License-Identifier: MIT
// Reading and writing any supported point-cloud format, chosen by extension
// or explicitly: PLY, PCD, LAS, CSV/XYZ/TXT.
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>

#include "ced/cloud.hpp"
#include "ced/io/csv.hpp"
#include "ced/io/las.hpp"
#include "ced/io/output_file.hpp"
#include "ced/io/pcd.hpp"
#include "ced/io/ply.hpp"

namespace ced::io {

enum class file_format { automatic, ply, pcd, las, csv };

/// "ply", "pcd", "las", "csv" (also "xyz", "txt", "pts"), or "auto";
/// throws std::invalid_argument otherwise.
file_format parse_format(const std::string& name);
std::string format_name(file_format f);

/// The format a path's extension names. Throws io_error for .laz and .e57
/// (with how to convert them) and for unknown extensions.
file_format format_of(const std::string& path);

struct read_options {
  file_format format = file_format::automatic;
  csv_options csv;
  /// The fields to keep (default: all). LAS files decode only these; other
  /// formats drop the rest right after reading.
  field_selection fields;
};

/// What reading found besides the points.
struct read_report {
  file_format format = file_format::automatic;
  std::size_t nonfinite_removed = 0;  ///< PCD: NaN points of organized clouds, dropped while reading
  std::string details;                ///< e.g. "PCD binary_compressed, organized 640x480"
};

/// Reads a cloud; errors are io_error naming the file and the problem.
point_cloud read_cloud(const std::string& path, const read_options& options = {}, read_report* report = nullptr);

/// Writes `cloud` in `format` (not automatic) to a stream: PLY binary little
/// endian, PCD binary, LAS 1.4, CSV.
void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format);

/// Writes atomically to `path`, the format from its extension unless given.
void write_cloud(const std::string& path, const point_cloud& cloud, file_format format = file_format::automatic);

}  // namespace ced::io
