// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <iosfwd>
#include <string>

#include "ced/cloud.hpp"
#include "ced/io/error.hpp"

namespace ced::io {

/// PLY body encodings.
enum class ply_format { ascii, binary_little_endian, binary_big_endian };

/// Reads the `vertex` element of a PLY file (ascii, binary little or big
/// endian; every PLY scalar type, plus the non-standard int64/uint64).
///
/// - x, y, z (any scalar type) become the positions. When the coordinates are
///   large (|mean| > 1e4 on some axis, e.g. georeferenced data), the cloud's
///   origin is set to the first finite point rounded to integers and the
///   positions are stored relative to it, keeping their precision.
/// - Every other scalar vertex property becomes a ced::field with its name and
///   original type, in file order; list properties and other elements (faces,
///   ...) are parsed and skipped.
/// - NaN/Inf coordinates are kept: the caller decides what to do with them.
///
/// Throws io_error, naming the file, for anything malformed: bad magic,
/// unknown format or type, missing end_header, more than 4096 elements or
/// 4096 properties in an element, missing vertex element or
/// x/y/z, impossible element counts (checked before allocating), truncated
/// bodies, unparsable or out-of-range ascii values.
///
/// Threading: reentrant (no shared state).
point_cloud read_ply(const std::string& path);
/// Same, reading the whole stream; `name_for_errors` names it in messages.
point_cloud read_ply(std::istream& in, const std::string& name_for_errors);

/// Writes `cloud` as PLY to `path` atomically (see atomic_output_file).
/// x y z are written as float when the cloud's origin is zero, otherwise as
/// double with the origin added back. Fields follow with their original type
/// (int64/uint64 fields are written as double: PLY has no 64-bit integers);
/// integer values are rounded and clamped to their type's range, NaN becomes 0.
/// Throws io_error on I/O failure and when x, y, z and the fields are more
/// than 65 536 properties (read_ply's limit), before writing anything, and
/// std::invalid_argument for fields that cannot be written (name empty,
/// containing whitespace, or x/y/z; wrong size).
void write_ply(const std::string& path, const point_cloud& cloud, ply_format fmt = ply_format::binary_little_endian);
/// Same, to a stream (opened in binary mode for the binary formats).
void write_ply(std::ostream& out, const point_cloud& cloud, ply_format fmt);

}  // namespace ced::io
