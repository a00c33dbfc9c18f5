// SPDX-License-Identifier: MIT
// Reading and writing any supported point-cloud format, chosen by extension
// or explicitly: PLY, PCD, LAS, CSV/XYZ/TXT.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>

#include "ced/cloud.hpp"
#include "ced/io/csv.hpp"
#include "ced/io/las.hpp"
#include "ced/io/output_file.hpp"
#include "ced/io/pcd.hpp"
#include "ced/io/ply.hpp"

namespace ced::io {

/// laz: LAZ (compressed LAS). Read by the LAS reader, which decodes it;
/// written as LAS 1.2 (point formats 0-3, other fields as extra bytes),
/// compressed in chunks of 50,000 points; with las_write_options, as they
/// say (LAS 1.4 point formats 6-8 with layered compression).
/// copc: COPC (cloud-optimised LAZ, `.copc.laz`). Read as LAZ (its octree
/// serves tiled plans); written as LAZ 1.4 (point formats 6-8, layered
/// compression) grouped into octree nodes, one chunk a node.
enum class file_format { automatic, ply, pcd, las, csv, laz, copc };

/// "ply", "pcd", "las", "laz", "copc", "csv" (also "xyz", "txt", "pts"), or "auto";
/// throws std::invalid_argument otherwise.
file_format parse_format(const std::string& name);
std::string format_name(file_format f);

/// The format a path's extension names (`.copc.laz` is copc). Throws
/// io_error for .e57 (with how to convert it) and for unknown extensions.
file_format format_of(const std::string& path);

struct read_options {
  file_format format = file_format::automatic;
  csv_options csv;
  /// The fields to keep (default: all). LAS files decode only these; other
  /// formats drop the rest right after reading.
  field_selection fields;
  /// PCD: keep points with NaN/Inf coordinates (by default the reader drops
  /// them, as organized clouds mark empty pixels so), so that point i is the
  /// file's point i. Other formats always keep them.
  bool keep_nonfinite = false;
  /// Threads that decode binary records in parallel (0 = all cores). The
  /// cloud is the same for any number.
  unsigned threads = 0;
  /// Positions relative to this origin instead of the one the reader
  /// chooses (choose_origin()): how several files become one cloud
  /// (read_catalogue()). read_cloud() only.
  std::optional<std::array<double, 3>> origin;
};

/// What reading found besides the points.
struct read_report {
  file_format format = file_format::automatic;
  std::size_t nonfinite_removed = 0;  ///< PCD: NaN points of organized clouds, dropped while reading (unless kept)
  std::string details;                ///< e.g. "PCD binary_compressed, organized 640x480"
  /// LAS, LAZ and COPC: the file's header (see las_write_options_like()).
  std::optional<las_read_info> las;
};

/// Reads a cloud; errors are io_error naming the file and the problem.
point_cloud read_cloud(const std::string& path, const read_options& options = {}, read_report* report = nullptr);

/// Writes `cloud` in `format` (not automatic) to a stream: PLY binary little
/// endian, PCD binary, LAS 1.4, CSV.
void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format);
/// The same, LAS, LAZ and COPC written with `las` (e.g. from
/// las_write_options_like(), to keep a LAS source's scale, offset, point
/// format and version); the other formats ignore it.
void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format, const las_write_options& las);

/// Writes atomically to `path`, the format from its extension unless given.
void write_cloud(const std::string& path, const point_cloud& cloud, file_format format = file_format::automatic);

namespace detail {
class piece_writer;
}

/// Writes a cloud too large to hold, chunk by chunk: the header of `points`
/// points with `layout`'s fields (names, types) and origin, then write() the
/// points in order, then finish(). The bytes are those write_cloud() writes
/// of the whole cloud. LAS rewrites its header at finish() (it holds the
/// bounds), so a LAS stream must be seekable (a file).
///
///   io::atomic_output_file f("keypoints.las");
///   io::cloud_writer w(f.stream(), layout, n, io::file_format::las);
///   for (...) w.write(chunk);
///   w.finish();
///   f.commit();
class cloud_writer {
 public:
  /// Throws std::invalid_argument when `layout` cannot be written in `format`
  /// (io_error when it has more values per point than the format's reader
  /// accepts).
  cloud_writer(std::ostream& out, const point_cloud& layout, std::uint64_t points, file_format format);
  ~cloud_writer();
  cloud_writer(const cloud_writer&) = delete;
  cloud_writer& operator=(const cloud_writer&) = delete;

  /// Writes the chunk's points. Throws std::invalid_argument when its fields
  /// or origin differ from the layout's or when it has more points than
  /// announced, io_error when the stream fails.
  void write(const point_cloud& chunk);
  /// Checks that every announced point was written and completes the
  /// header; io_error otherwise.
  void finish();

  std::uint64_t written() const noexcept { return m_written; }

 private:
  std::ostream& m_out;
  point_cloud m_layout;
  std::uint64_t m_points = 0, m_written = 0;
  std::streampos m_start;
  std::unique_ptr<detail::piece_writer> m_pieces;
};

}  // namespace ced::io
