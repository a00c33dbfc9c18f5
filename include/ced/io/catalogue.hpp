// SPDX-License-Identifier: MIT
// A catalogue: several point files (a delivery's tiles, a survey's
// segments) read as one cloud.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/io.hpp"
#include "ced/io/stream.hpp"

namespace ced::io {

/// The files that `inputs` name, in order: each entry a file, a folder (its
/// files in a point-cloud format, by name; not its sub-folders), or a list
/// file given as `@path` (one path a line, relative to the list's folder;
/// blank lines and lines starting with '#' skipped). Throws io_error naming
/// the path for one that does not exist, a folder with no point files, a
/// list that names none, and a file named twice (the same file by two
/// names, or two files with the same bytes).
std::vector<std::string> catalogue_files(const std::vector<std::string>& inputs);

/// The file and the point index in it of a catalogue's point `i`, given
/// where each file begins (`first`, as catalogue_report::first; i below
/// first.back()).
std::pair<std::size_t, std::uint64_t> locate(const std::vector<std::uint64_t>& first, std::uint64_t i);

/// What read_catalogue() found besides the points.
struct catalogue_report {
  std::vector<std::string> files;
  /// Point i of the cloud (before any is dropped) is point i − first[f] of
  /// files[f], for the f with first[f] ≤ i < first[f + 1] (files.size() + 1
  /// entries): the catalogue's global numbering, file after file.
  std::vector<std::uint64_t> first;
  /// Each file's read_report.
  std::vector<read_report> reports;
  /// The files and their point index of global index `i` (below first.back()).
  std::pair<std::size_t, std::uint64_t> locate(std::uint64_t i) const;
  /// One read_report for all the files: the first's format; "N files: "
  /// and each distinct description; the non-finite points dropped by all;
  /// the LAS header to write like only when every file is LAS of its point
  /// format, scale and offset.
  read_report summary() const;
};

/// Reads `files` as one cloud: their points file after file, positions
/// relative to one origin (choose_origin() of the union of the files'
/// bounds; a LAS, LAZ or COPC file's bounds are its header's), so that the
/// cloud is the one a merged file would give. Options as read_cloud()
/// (read_options::origin, when set, is the origin). Throws io_error naming the file for:
/// a field the selection needs that a file lacks; a field two files hold
/// in different types; a field (other than a LAS flag, which is 0 where a
/// file does not set it) that some files have and others not, when every
/// field is wanted; and two LAS files in different coordinate systems
/// (both named). One file is read as read_cloud() reads it.
point_cloud read_catalogue(const std::vector<std::string>& files, const read_options& options = {},
                           catalogue_report* report = nullptr);

/// Where each of `files` begins in their numbering (files.size() + 1
/// entries, catalogue_report::first): from the counts their headers
/// declare, or a pass over a file that declares none.
std::vector<std::uint64_t> catalogue_first(const std::vector<std::string>& files, const read_options& options = {});

/// Whether `path` names a catalogue: a folder, or @LIST.
bool names_catalogue(const std::string& path);

/// `files` as one point stream: their points file after file (a point's
/// index is its index in its file plus the points of the files before it),
/// every chunk with the same fields in the same types (as
/// read_catalogue()), LAS flags as a pass over every file decides them.
/// Runs and indexed reads (chunk_runs(), read_run(), read_points(),
/// index_nodes()) when every file declares its count; header_bounds() when
/// every file has them. After a complete pass, origin() is that of the
/// headers' bounds when every file has them, else of the points' bounds.
/// open_point_stream() of a folder or @LIST gives one.
std::unique_ptr<point_stream> open_catalogue_stream(const std::vector<std::string>& files,
                                                    const read_options& options = {});

}  // namespace ced::io
