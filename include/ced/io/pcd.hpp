// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <string_view>

#include "ced/cloud.hpp"
#include "ced/io/error.hpp"
#include "ced/io/lzf.hpp"

namespace ced::io {

/// PCD body encodings (the DATA line).
enum class pcd_format { ascii, binary, binary_compressed };

/// What read_pcd found in the file besides the points.
struct pcd_read_info {
  std::size_t width = 0, height = 0;  ///< WIDTH and HEIGHT from the header
  std::size_t points_declared = 0;    ///< POINTS (= WIDTH × HEIGHT), before non-finite points are removed
  std::size_t nonfinite_removed = 0;  ///< points dropped because x, y or z was NaN/Inf
  bool organized = false;             ///< HEIGHT > 1 (an image-shaped cloud)
  std::string data_format;            ///< "ascii", "binary" or "binary_compressed"
};

/// Reads a PCD file (PCL's Point Cloud Data format, v0.7; older v0.5/v0.6
/// headers without VERSION/VIEWPOINT and with COLUMNS for FIELDS are accepted;
/// missing SIZE/TYPE/COUNT default to 4/F/1).
///
/// - DATA ascii, binary and binary_compressed (LZF, field-major layout; as in
///   PCL, padding fields named `_` are left out of the compressed layout).
///   Binary data is little-endian.
/// - x, y, z (TYPE F, I or U, any size) become the positions. When the
///   coordinates are large (|mean| > 1e4 on some axis), the cloud's origin is
///   set to the first point rounded to integers and positions are stored
///   relative to it, as read_ply does.
/// - Points whose x, y or z is NaN or ±Inf are REMOVED (PCD marks invalid
///   pixels of organized clouds with NaN) and counted in
///   info->nonfinite_removed. The result is therefore never organized.
/// - Other fields keep their name and type (TYPE I/U/F × SIZE 1/2/4/8 -> the
///   matching scalar_type), in file order. A field with COUNT n > 1 becomes n
///   fields `name_0` ... `name_{n-1}`. Padding fields named `_` are skipped.
/// - `rgb` / `rgba` (COUNT 1, SIZE 4, any TYPE: packed into a float or an
///   integer) are unpacked into uint8 fields `red`, `green`, `blue` (bits
///   16-23, 8-15 and 0-7 of the 32 bits); the alpha byte is dropped. In ascii
///   data a TYPE F rgb value written as a plain integer (as PCL writes it) is
///   taken as the packed 32-bit integer, anything else as the float's bits.
///
/// Throws io_error, naming the file, for anything malformed: not a PCD file,
/// unknown keyword or DATA format, missing DATA/FIELDS/x/y/z, FIELDS SIZE TYPE
/// COUNT of different lengths, unsupported TYPE/SIZE, more than 4096 values
/// per point, POINTS != WIDTH ×
/// HEIGHT, point counts the remaining bytes cannot hold (checked before
/// allocating; a binary_compressed body must declare exactly POINTS × point
/// size uncompressed bytes, at most 100 × its compressed size + 1024: LZF
/// cannot expand more than 88-fold), truncated data, corrupt LZF data, bad
/// ascii values.
///
/// Threading: reentrant (no shared state).
///
/// `keep_nonfinite`: keep the points with NaN/Inf coordinates instead (point i
/// is then the file's point i, as --indices-original needs; the caller drops
/// them, e.g. with remove_nonfinite(), which returns their file indices).
point_cloud read_pcd(const std::string& path, pcd_read_info* info = nullptr, bool keep_nonfinite = false);
/// Same, from the bytes of a PCD file; `name_for_errors` names it in messages.
point_cloud read_pcd_buffer(std::string_view bytes, const std::string& name_for_errors, pcd_read_info* info = nullptr,
                            bool keep_nonfinite = false);

/// Writes `cloud` as a PCD v0.7 file to `path` atomically (see
/// atomic_output_file); unorganized (WIDTH = N, HEIGHT = 1).
/// - x y z are TYPE F SIZE 4 when the cloud's origin is zero, otherwise SIZE 8
///   with the origin added back.
/// - Fields follow with their type (int8 -> I 1, ..., float64 -> F 8); integer
///   values are rounded and clamped to their type's range, NaN becomes 0.
/// - uint8 fields named exactly red, green and blue are written as one packed
///   `rgb` field (0x00RRGGBB) at the position of `red`, as PCL does: TYPE F
///   SIZE 4 in binary data, TYPE U SIZE 4 (the integer) in ascii data.
/// - Points with NaN/Inf coordinates are written as they are (read_pcd drops
///   them).
/// Throws io_error on I/O failure (and for binary_compressed bodies of 4 GiB or
/// more, and for more than 65 536 values per point, read_pcd's limit, before
/// writing anything) and std::invalid_argument for fields that cannot be written (name
/// empty, containing whitespace, x/y/z, rgb/rgba when red/green/blue are
/// packed; wrong number of values).
void write_pcd(const std::string& path, const point_cloud& cloud, pcd_format fmt = pcd_format::binary);
/// Same, to a stream (open it in binary mode for the binary formats).
void write_pcd(std::ostream& out, const point_cloud& cloud, pcd_format fmt);

}  // namespace ced::io
