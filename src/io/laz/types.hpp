// SPDX-License-Identifier: MIT
// Private to src/io: LAZ, the LASzip compression of LAS point records
// (chunks.cpp, the driver; the items in items.hpp, items_v1.hpp,
// pointwise.hpp, layered.hpp and layered_encode.hpp, the coder
// in coder.hpp). The LAS reader (src/io/las/) finds a LAZ file by its
// point format byte, and asks this for its chunks, decoded back into the LAS
// point records they were made from; everything after that is the LAS reader's.
//
// The format, as its public description (the LASzip paper and sources, the
// LAZ specification) gives it: the LASzip VLR lists the items of a record
// (point10, gpstime11, rgb12, bytes, ...) and a chunk size; the point data
// starts with the byte offset of a chunk table, then the chunks, each a first
// record stored as it is and the rest arithmetic-coded item by item, each
// item predicted from the record before it in the same chunk. Chunks are
// independent, so they decode in parallel.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/las.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io::detail {

/// One item of a compressed record, as the LASzip VLR lists it.
struct laz_item {
  enum kind : std::uint16_t {
    byte = 0,
    point10 = 6,
    gpstime11 = 7,
    rgb12 = 8,
    point14 = 10,
    rgb14 = 11,
    rgbnir14 = 12,
    byte14 = 14
  };
  std::uint16_t type = 0, size = 0, version = 0;
};

/// How a LAZ file's records are compressed (its LASzip VLR), checked against
/// the point format and the record length.
struct laz_layout {
  int compressor = 0;            ///< 1: pointwise, one chunk; 2: pointwise and chunked
  std::uint32_t chunk_size = 0;  ///< points a chunk; 0xFFFFFFFF: each chunk says (chunk table)
  std::vector<laz_item> items;   ///< in record order; their sizes add up to the record length
  std::size_t record_length = 0;
  std::string describe() const;  ///< "point10 v2, gpstime11 v2, rgb12 v2"
};

/// The LASzip VLR's `len` bytes at p, for point format `format` and records
/// of `record_length` bytes. io_error naming `file` and the problem for a
/// record that is too short, an unknown compressor, coder, item type or
/// version, and items that disagree with the point format or the record length.
laz_layout parse_laszip_vlr(const unsigned char* p, std::size_t len, int format, std::size_t record_length,
                            const std::string& file);

/// One chunk of compressed records: its points and its bytes in the file.
struct laz_chunk {
  std::uint64_t first_point = 0, points = 0;
  std::uint64_t offset = 0, bytes = 0;
};

/// Reads `n` bytes at `offset` of the file into `out` (io_error when it cannot).
using laz_read_fn = std::function<void(std::uint64_t offset, std::size_t n, char* out)>;

/// The chunks of a LAZ file of `file_size` bytes whose point data starts at
/// `point_offset` and holds `points` records, from its chunk table. io_error
/// naming the file for a chunk table that is missing, out of the file or
/// corrupt, chunks that overlap or run out of the point data, and chunk
/// point counts that do not add up to `points`.
std::vector<laz_chunk> laz_chunks(const laz_layout& layout, std::uint64_t point_offset, std::uint64_t file_size,
                                  std::uint64_t points, const laz_read_fn& read, const std::string& file);

/// Which fields of a layered chunk (point formats 6-8) to decode: each is a
/// layer of its own, and a layer not decoded leaves its field at the chunk's
/// first record's value. Positions, returns and the scanner channel are always
/// decoded; pointwise chunks (formats 0-3) decode everything.
struct laz_wanted {
  bool classification = true, flags = true, intensity = true, scan_angle = true, user_data = true, point_source = true,
       gps_time = true, rgb = true, nir = true, extra = true;
};

/// Decodes chunk number `index` (`c`, its c.bytes bytes at `data`) into
/// c.points records of layout.record_length bytes at `out` (the `wanted`
/// fields of a layered chunk). io_error naming
/// the file and the chunk when the data ends before its last point or does
/// not decode. Reentrant: chunks may decode on several threads at once.
void decode_laz_chunk(const laz_layout& layout, const laz_chunk& c, std::size_t index, const unsigned char* data,
                      unsigned char* out, const std::string& file, const laz_wanted& wanted = {});

/// Decodes chunks [c0, c1) into `out`, the records of chunk c0's first point
/// on, chunks in parallel (the bytes read with `read`, a chunk at a time).
void decode_laz_chunks(const laz_layout& layout, const std::vector<laz_chunk>& chunks, std::size_t c0, std::size_t c1,
                       const laz_read_fn& read, unsigned char* out, const std::string& file,
                       const laz_wanted& wanted = {});

/// COPC: the octree of a cloud-optimised LAZ file, from its "copc" info VLR
/// (the root cube) and its hierarchy pages (each node's chunk).
struct copc_info {
  double center[3] = {0, 0, 0};
  double halfsize = 0;
  std::uint64_t root_offset = 0, root_size = 0;  ///< of the root hierarchy page
};
struct copc_node {
  std::int32_t depth = 0, x = 0, y = 0, z = 0;
  std::uint64_t offset = 0;  ///< of its chunk
  std::int32_t bytes = 0, points = 0;
  /// Its cube, absolute: {x0, y0, z0, x1, y1, z1}.
  void box(const copc_info& info, double out[6]) const noexcept;
};

/// The 160 bytes of the COPC info VLR; io_error naming the file when the
/// cube is not finite and positive.
copc_info parse_copc_info(const unsigned char* p, std::size_t len, const std::string& file);

/// Every node of the hierarchy with points (pages followed from the root).
/// io_error naming the file for a page outside the file or of a size that is
/// not whole entries, a page reached twice, a node key outside its depth's
/// grid, or more entries than the file could hold.
std::vector<copc_node> read_copc_hierarchy(const copc_info& info, std::uint64_t file_size, const laz_read_fn& read,
                                           const std::string& file);

/// Points a chunk of the LAZ that ced writes (LASzip's default).
inline constexpr std::uint32_t k_laz_chunk_points = 50000;

/// How ced compresses records of point format `format` (0-3) of
/// `record_length` bytes: pointwise, the format's items (version 2) then its
/// extra bytes, chunks of `chunk_size` points (0xFFFFFFFF: variable).
laz_layout pointwise_layout(int format, std::size_t record_length, std::uint32_t chunk_size);

/// How ced compresses records of LAS 1.4 point format `format` (6-8) of
/// `record_length` bytes: layered, the format's items (version 3) then its
/// extra bytes (byte14), variable chunks.
laz_layout layered_layout(int format, std::size_t record_length);

/// The bytes of a (variable length record) VLR's header.
inline constexpr std::size_t k_vlr_header_bytes = 54;
/// A VLR's header: `user` (16 bytes at most), record id, the payload's
/// `length`, `description` (32 at most), the reserved word.
std::string vlr_header(const std::string& user, std::uint16_t record, std::size_t length,
                       const std::string& description, std::uint16_t reserved = 0);
/// The LASzip VLR (its 54-byte header and payload) that describes `layout`.
std::string laszip_vlr(const laz_layout& layout);

/// Codes `points` records (`stride` bytes apart from `records`) as one
/// chunk of `layout` (pointwise items v2, or layered items v3), appending
/// the chunk's bytes to `out`.
void encode_laz_chunk(const laz_layout& layout, const unsigned char* records, std::uint64_t points, std::string& out);
/// The chunk table of chunks of these points (written when `variable`) and bytes.
std::string encode_chunk_table(const std::vector<std::uint32_t>& points, const std::vector<std::uint32_t>& bytes,
                               bool variable);

/// The head of an uncompressed LAS file held in `las`, checked as
/// read_las() checks it (io_error naming `name`; std::invalid_argument when
/// it is compressed): what the LAZ and COPC writers take from it.
struct las_head {
  const unsigned char* records = nullptr;  ///< the first point record
  std::size_t header_size = 0, point_offset = 0, record_length = 0;
  std::uint32_t vlrs = 0;
  std::uint64_t count = 0;
  std::uint64_t evlr_offset = 0, evlr_count = 0;  ///< LAS 1.4; 0 before
  int minor = 0, format = 0;
  std::array<double, 3> scale{}, offset{};
};
las_head read_las_head(std::string_view las, const std::string& name);

/// The LAZ file of a LAS file held in `las` (point format 0-3, pointwise, or
/// 6-8, layered; no extended VLRs): the LASzip VLR after its VLRs, its
/// records in chunks of `chunk_size` points coded in parallel, then the
/// chunk table (variable for formats 6-8); with
/// `chunk_points` not empty, chunks of those sizes instead (variable chunks;
/// they must add up to the point count). std::invalid_argument for what it
/// cannot compress. For the tests and the benchmarks' inputs.
std::string laz_from_las(std::string_view las, const std::string& name, std::uint32_t chunk_size = k_laz_chunk_points,
                         const std::vector<std::uint32_t>& chunk_points = {});

/// The point records of a LAS or LAZ file held in `bytes`, uncompressed
/// (LAZ decoded), back to back; the header's checks as read_las(). For tests
/// and the fuzz target: a LAZ file must give exactly its LAS twin's records.
std::string las_point_records(std::string_view bytes, const std::string& name);

/// LAS, LAZ and COPC written whole and in pieces (las/pieces.cpp, laz/copc.cpp).
std::unique_ptr<piece_writer> las_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n);
std::unique_ptr<piece_writer> laz_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n);
/// `cloud` as LAZ: LAS 1.2 (point formats 0-3, pointwise) without
/// `options`; with them, what write_las() writes with them, compressed
/// (formats 6-8 layered).
void write_laz(std::ostream& out, const point_cloud& cloud, const las_write_options* options = nullptr);
/// COPC in pieces: held in memory, written whole by finish() (copc.cpp).
std::unique_ptr<piece_writer> copc_pieces(const point_cloud& layout, std::uint64_t n);
/// `cloud` as COPC: LAZ 1.4 (point formats 6-8, layered) in octree nodes;
/// `options` (version 1.4, point format 6-8 or -1) as write_las() takes them.
void write_copc(std::ostream& out, const point_cloud& cloud, const las_write_options* options = nullptr);
/// The COPC file of a LAS 1.4 file held in `las` (point formats 6-8, no
/// extended VLRs): its records grouped by octree node (grid sampling, 128
/// cells a side), a LAZ chunk a node, the hierarchy in one page.
/// std::invalid_argument naming `name` for what it cannot write.
std::string copc_from_las(std::string_view las, const std::string& name);

}  // namespace ced::io::detail
