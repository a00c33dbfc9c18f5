// SPDX-License-Identifier: MIT
// Fixed-size point records decoded in parallel chunks, from memory or from a
// file, straight into typed columns (private to src/io: the binary LAS, PLY
// and PCD readers, whole-file and streaming, share it; records.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "ced/cloud.hpp"
#include "core/parallel.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io::detail {

/// Bytes in memory, backed by huge pages when large (a column's memory): a
/// whole file, or what it uncompresses to.
using big_bytes = std::vector<char, ced::detail::column_allocator<char>>;

/// True when `path` is a regular file, which the readers read in chunks at
/// offsets; anything else (a pipe) is read whole, front to back.
inline bool chunked_file(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

/// The whole of `file` (a regular file).
inline big_bytes read_all(const input_file& file) {
  big_bytes bytes(static_cast<std::size_t>(file.size()));
  file.read_at(0, bytes.size(), bytes.data());
  return bytes;
}

/// n records of `stride` bytes each, at `data` in memory or at byte `offset`
/// of a file. A chunk of them is a pointer into the memory, or read into a
/// buffer of the caller's.
class record_source {
 public:
  record_source(const unsigned char* data, std::size_t stride) noexcept : m_data(data), m_stride(stride) {}
  record_source(input_file& file, std::uint64_t offset, std::size_t stride) noexcept
      : m_file(&file), m_offset(offset), m_stride(stride) {}
  std::size_t stride() const noexcept { return m_stride; }
  /// Records [i0, i0 + m): in memory, or read into `buf` (io_error naming the
  /// file when they cannot be read). Safe to call from several threads with
  /// different buffers.
  const unsigned char* get(std::uint64_t i0, std::size_t m, std::string& buf) const {
    if (!m_file) return m_data + i0 * m_stride;
    if (buf.size() < m * m_stride) buf.resize(m * m_stride);
    m_file->read_at(m_offset + i0 * m_stride, m * m_stride, buf.data());
    return reinterpret_cast<const unsigned char*>(buf.data());
  }

 private:
  const unsigned char* m_data = nullptr;
  input_file* m_file = nullptr;
  std::uint64_t m_offset = 0;
  std::size_t m_stride;
};

/// Bytes of records a chunk holds (at least one record): small enough that a
/// thread's buffers (the chunk, its positions as doubles) stay in its L2
/// cache and a small file faults in few pages, large enough that a chunk's
/// read and task cost nothing.
constexpr std::size_t k_chunk_bytes = std::size_t(1) << 17;

/// Records per chunk of records of `stride` bytes.
inline std::size_t chunk_records(std::size_t stride) noexcept {
  return std::max<std::size_t>(1, k_chunk_bytes / std::max<std::size_t>(stride, 1));
}

/// Number of chunks of n records of `stride` bytes.
inline std::size_t chunk_count(std::uint64_t n, std::size_t stride) noexcept {
  const std::size_t per = chunk_records(stride);
  return static_cast<std::size_t>((n + per - 1) / per);
}

/// Calls body(c, i0, m, records) for each chunk c of the n records of `src`:
/// records i0 to i0 + m - 1 at `records`. The chunks are the same for any
/// number of threads and run in parallel on all cores, so `body` must write
/// only what chunk c owns (its records' values, slot c of a vector).
/// Exceptions are rethrown.
template <class Body>
void for_each_chunk(const record_source& src, std::uint64_t n, Body&& body) {
  const std::size_t per = chunk_records(src.stride());
  const std::size_t chunks = chunk_count(n, src.stride());
  ced::detail::parallel_for(chunks, 0, 1, [&](std::size_t b, std::size_t e) {
    thread_local std::string buf;  // reused: a chunk's read faults in no new memory
    for (std::size_t c = b; c < e; ++c) {
      const std::uint64_t i0 = std::uint64_t(c) * per;
      const auto m = static_cast<std::size_t>(std::min<std::uint64_t>(per, n - i0));
      body(c, i0, m, src.get(i0, m, buf));
    }
  });
}

/// One value of a record: its byte offset and type, its bytes reversed when
/// `swap`; a column of that type, or with `shift` >= 0 the byte
/// (v >> shift) & 0xff of a packed 32-bit colour (PCD rgb), a uint8 column.
struct value_spec {
  std::string name;  ///< of the column
  std::size_t offset = 0;
  scalar_type type = scalar_type::float32;
  bool swap = false;
  int shift = -1;
  /// 0: the value is in the record. Else the values are stored field by
  /// field (PCD binary_compressed): point i's at point_layout::base + offset
  /// + i * stride.
  std::size_t stride = 0;
  scalar_type stored() const noexcept { return shift >= 0 ? scalar_type::uint8 : type; }
};

/// The points of fixed-size records: positions from the values xyz (made
/// double, then float relative to an origin), and columns.
struct point_layout {
  std::array<value_spec, 3> xyz;
  std::vector<value_spec> columns;
  const unsigned char* base = nullptr;  ///< of the values stored field by field
};

/// What a first pass over the records learns: the box of the finite points
/// (as choose_origin() takes it) and how many points of each chunk are finite.
struct points_scan {
  finite_box box;
  std::vector<std::size_t> finite;  ///< by chunk
  std::uint64_t total_finite = 0;
};

/// The first pass over the n records of `src`, chunks in parallel.
points_scan scan_points(const record_source& src, std::uint64_t n, const point_layout& layout);

/// The n records of `src` as a cloud: positions relative to `origin`, the
/// layout's columns in its order. With `finite_only` (a scan of the same
/// records), only the points with finite positions, in order. Chunks are
/// decoded in parallel, each into its own points: the cloud is the same for
/// any number of threads.
point_cloud decode_points(const record_source& src, std::uint64_t n, const point_layout& layout,
                          const std::array<double, 3>& origin, const points_scan* finite_only = nullptr);

/// std::logic_error unless the point indices `at` ascend and are below
/// `count` (a caller's bug: point_stream::read_points's contract).
void check_point_indices(const std::vector<std::uint64_t>& at, std::uint64_t count);

/// The records of `stride` bytes at indices `at` (ascending) among those
/// that start at byte `offset` of `file`, back to back: read in windows, a
/// gap under a page read through (cheaper than another read), at most 1 MiB
/// a read. What point_stream::read_points reads of a binary file.
std::string gather_records(const input_file& file, std::uint64_t offset, std::size_t stride,
                           const std::vector<std::uint64_t>& at);

}  // namespace ced::io::detail
