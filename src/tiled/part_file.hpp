// SPDX-License-Identifier: MIT
// Private to src/tiled: part files: written, and read a piece at a time (part_file.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "ced/tiled.hpp"
#include "tiled/records.hpp"

namespace ced::tiled_detail {

/// write_part() with the plan's digest already known (a digest formats the
/// whole plan: of thousands of tiles, a millisecond).
void write_part_as(const std::string& path, const tile_plan& plan, const std::string& digest, const tile_part& part);

/// A part file read a piece at a time: its header at once, then its records
/// in order through a buffer (the file is opened again for each refill, so
/// that thousands of parts need no open file each).
class part_reader {
 public:
  /// `digest`: plan.digest(), computed once by the caller for all its parts.
  part_reader(const std::string& path, const tile_plan& plan, const std::string& digest);

  /// The part without its keypoints: tile, names, thresholds, counts.
  tile_part totals;
  std::uint64_t count() const noexcept { return m_count; }
  std::size_t record_bytes() const noexcept { return m_record; }

  /// The next record (record_bytes()), nullptr after the last; `buffer`
  /// bytes are read at a time.
  const char* next(std::size_t buffer);
  /// Drops the buffer (after the last record).
  void release() { std::string().swap(m_buf), m_at = 0; }

 private:
  std::string m_path;
  std::uint64_t m_count = 0, m_left = 0, m_offset = 0;
  std::size_t m_record = 0;
  std::string m_buf;
  std::size_t m_at = 0;
};

/// Decodes a record of a part (point, then one saliency a modality) into `p`'s point j.
void decode_part_record(const char* r, tile_part& p, std::size_t j);
/// Sizes p's arrays for n keypoints.
void resize_part(tile_part& p, const tile_plan& plan, std::size_t n);

}  // namespace ced::tiled_detail
