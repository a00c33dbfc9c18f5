// SPDX-License-Identifier: MIT
// Private: the neighbour pass of one spatial block, compiled once per
// instruction set (block_kernel_generic.cpp, block_kernel_avx2.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

namespace ced::detail {

/// Sub-cells are about r wide in y and z and r/x_cells_per_radius in x; a
/// block point tests one run of sub-cells per row (y, z) within one cell:
/// nine ranges of gathered points.
inline constexpr int x_cells_per_radius = 8;
inline constexpr std::size_t kernel_ranges = 9;
/// Blocks of at most fixed_channel_stride − 8 gathered points lay their
/// channels out this many floats apart, a constant, so that the kernel
/// addresses all channels from one register (with 7 or more channels it
/// otherwise runs out of general registers). 64 bytes more than a power of
/// two, so that the channels of one point do not share a cache set.
inline constexpr std::size_t fixed_channel_stride = 8192 + 16;
inline constexpr int min_fixed_stride_channels = 7;

struct block_kernel_input {
  /// Gathered points in sub-cell order (structure of arrays), each array
  /// readable 8 floats past its last point.
  const float* gx;
  const float* gy;
  const float* gz;
  /// Channel c of the gathered points at channels + c * stride (stride is
  /// fixed_channel_stride when the block allows and there are at least
  /// min_fixed_stride_channels channels), each less a
  /// reference value of the block's (any value: it cancels out, it only keeps
  /// the float sums small).
  const float* channels;
  std::size_t stride;
  std::size_t channel_count;
  /// The block's points: positions (points × 3), own channel values less
  /// the same references (points × channel_count) and [begin, end) ranges
  /// (points × 9 × 2).
  std::size_t points;
  const float* centre;
  const float* own;
  const std::uint32_t* ranges;
  float r2;
  /// Also sum the positions' second moments (only with channel_count 0).
  bool moments = false;
  /// Non-null: the any-count path (more than 16 channels), which reads the
  /// neighbours' rows where they lie (row_sources, not `channels`); this is
  /// room for 8 × (the most groups a point tests) + 8 entries.
  std::uint32_t* row_scratch = nullptr;
  /// (Any-count path.) The sources' rows: point i's `dims` values at
  /// rows + i · dims, summed to sums[first_sum ..]; the gathered points'
  /// indices into them (in sweep order) and the block's points'.
  struct row_source {
    const float* rows;
    std::size_t dims;
    std::size_t first_sum;
  };
  const row_source* row_sources = nullptr;
  std::size_t row_source_count = 0;
  const std::uint32_t* gathered_ids = nullptr;
  const std::uint32_t* point_ids = nullptr;
};
/// The any-count path sums this many channels at a time (AVX: twice as many).
inline constexpr std::size_t rows_chunk = 32;
/// Up to this many channels the pass sums them in registers (structure of
/// arrays); past it, from rows (row_scratch).
inline constexpr std::size_t max_register_channels = 16;

struct block_kernel_output {
  /// Neighbours of each point within the radius (itself included).
  std::uint32_t* counts;
  /// Per point, 3 + channel_count sums of (v_j − v_i) over its neighbours:
  /// positions first, then the channels. (Any-count path: each channel's
  /// sum is one float sum of the values as they are over the neighbours in
  /// sweep order, less n times the point's own in double; otherwise eight
  /// lanes' float sums reduced in double.) With input.moments, 9: the
  /// positions' sums, then Σ d dᵀ of d = p_j − p_i as (xx, yy, zz, xy, xz,
  /// yz), each product rounded to float and summed in the positions' lanes.
  double* sums;
  /// Per group of 8 tested points, bit l set when lane l is a neighbour;
  /// groups follow the ranges in order, point after point. nullptr: not
  /// wanted (only with channel_count 0, i.e. positions alone).
  std::uint8_t* bits;
};

/// Writes the n neighbours marked in `bits` (one point's groups over its
/// ranges) from `gathered` to out[0..n), in order. Writes nothing past n.
void compact_generic(const std::uint32_t* gathered, const std::uint32_t* ranges, const std::uint8_t* bits,
                     std::uint32_t n, std::uint32_t* out) noexcept;
void compact_avx2(const std::uint32_t* gathered, const std::uint32_t* ranges, const std::uint8_t* bits, std::uint32_t n,
                  std::uint32_t* out) noexcept;
void compact_avx512(const std::uint32_t* gathered, const std::uint32_t* ranges, const std::uint8_t* bits,
                    std::uint32_t n, std::uint32_t* out) noexcept;

/// The ball of the block's point k (positions alone): the gathered points
/// nearer than the radius, in sweep order, to ids[0..returned), with their
/// float squared distances ((dx² + dy²) + dz², as the pass computes them)
/// as bits at the same places of d2_bits, and −1 for the point itself
/// (points[k]). Needs room for 8 × (its groups of 8 tested) entries.
std::uint32_t balls_generic(const block_kernel_input& in, const std::uint32_t* gathered, const std::uint32_t* points,
                            std::size_t k, std::int32_t* d2_bits, std::uint32_t* ids) noexcept;
std::uint32_t balls_avx2(const block_kernel_input& in, const std::uint32_t* gathered, const std::uint32_t* points,
                         std::size_t k, std::int32_t* d2_bits, std::uint32_t* ids) noexcept;
std::uint32_t balls_avx512(const block_kernel_input& in, const std::uint32_t* gathered, const std::uint32_t* points,
                           std::size_t k, std::int32_t* d2_bits, std::uint32_t* ids) noexcept;

/// Splits n distances (as bits) and their ids by [lo, hi]: those below lo
/// to below_*[0..returned), those within to range_*[0..*in_range), each in
/// order. Reads up to 8 entries past n; writes up to 8 past each count.
std::uint32_t split_generic(const std::int32_t* d2_bits, const std::uint32_t* ids, std::uint32_t n, std::int32_t lo,
                            std::int32_t hi, std::int32_t* below_bits, std::uint32_t* below_ids,
                            std::int32_t* range_bits, std::uint32_t* range_ids, std::uint32_t* in_range) noexcept;
std::uint32_t split_avx2(const std::int32_t* d2_bits, const std::uint32_t* ids, std::uint32_t n, std::int32_t lo,
                         std::int32_t hi, std::int32_t* below_bits, std::uint32_t* below_ids, std::int32_t* range_bits,
                         std::uint32_t* range_ids, std::uint32_t* in_range) noexcept;
std::uint32_t split_avx512(const std::int32_t* d2_bits, const std::uint32_t* ids, std::uint32_t n, std::int32_t lo,
                           std::int32_t hi, std::int32_t* below_bits, std::uint32_t* below_ids,
                           std::int32_t* range_bits, std::uint32_t* range_ids, std::uint32_t* in_range) noexcept;

/// The points t in [b, e) of positions x, y, z (each readable 8 floats past
/// e; ids no further than e) that lie in the closed box [lo, hi], in order,
/// written to out as records of 4 floats: x, y, z and the bits of ids[t]. Returns how many;
/// writes up to 8 records past that count.
std::size_t select_in_box_generic(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                  std::size_t b, std::size_t e, const float lo[3], const float hi[3],
                                  float* out) noexcept;
std::size_t select_in_box_avx2(const float* x, const float* y, const float* z, const std::uint32_t* ids, std::size_t b,
                               std::size_t e, const float lo[3], const float hi[3], float* out) noexcept;
std::size_t select_in_box_avx512(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                 std::size_t b, std::size_t e, const float lo[3], const float hi[3],
                                 float* out) noexcept;
/// The same selection, the ids alone to out (up to 8 written past the count).
std::size_t select_ids_in_box_generic(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                      std::size_t b, std::size_t e, const float lo[3], const float hi[3],
                                      std::uint32_t* out) noexcept;
std::size_t select_ids_in_box_avx2(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                   std::size_t b, std::size_t e, const float lo[3], const float hi[3],
                                   std::uint32_t* out) noexcept;
std::size_t select_ids_in_box_avx512(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                     std::size_t b, std::size_t e, const float lo[3], const float hi[3],
                                     std::uint32_t* out) noexcept;

/// A block's sub-cell grid as the runs' set-up sees it (counted grids only:
/// `start` holds each cell's first gathered point, cells + 1 entries).
struct row_grid {
  const float* centre;  ///< the block's points, 3 floats each
  std::size_t count;
  double lo[3], inv_side[3], side_y, side_z;
  std::int64_t dims[3];
  double rc2;  ///< the squared radius with its margin
  const std::uint32_t* start;
};
/// Each point's nine runs of gathered points (18 entries a point to
/// ranges) and where its hit bits start (bit_offsets[1..count]), exactly as
/// neighbor_block's scalar set-up makes them; four points at a time.
void rows_avx2(const row_grid& g, std::uint32_t* ranges, std::uint32_t* bit_offsets) noexcept;
void rows_avx512(const row_grid& g, std::uint32_t* ranges, std::uint32_t* bit_offsets) noexcept;

/// The sub-cell keys ((c_z · dims_y + c_y) · dims_x + c_x, below 2^31) of
/// g points given as records of 4 floats (x, y, z, id), to keys[0..g),
/// exactly as neighbor_block::cell_of makes the cells.
void cell_keys_avx2(const float* records, std::size_t g, const double lo[3], const double inv_side[3],
                    const std::int64_t dims[3], std::uint32_t* keys) noexcept;
void cell_keys_avx512(const float* records, std::size_t g, const double lo[3], const double inv_side[3],
                      const std::int64_t dims[3], std::uint32_t* keys) noexcept;

/// All builds compute exactly the same numbers (same lanes, same order, no FMA).
void block_kernel_generic(const block_kernel_input& in, const block_kernel_output& out) noexcept;
void block_kernel_avx2(const block_kernel_input& in, const block_kernel_output& out) noexcept;
void block_kernel_avx512(const block_kernel_input& in, const block_kernel_output& out) noexcept;

}  // namespace ced::detail
