// SPDX-License-Identifier: MIT
// Which build of the neighbour pass's kernels runs (generic, AVX2, AVX-512),
// chosen once by what the CPU has, and the kernels that the grid (stage 1,
// block_partition.cpp) and the neighbour pass (stage 2, neighbor_block.cpp)
// call through that choice. All builds give bitwise the same results.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/kernel/block_kernel.hpp"

namespace ced::detail {

/// One build's kernels (block_kernel.hpp).
struct kernel_set {
  void (*pass)(const block_kernel_input&, const block_kernel_output&) noexcept;
  void (*compact)(const std::uint32_t*, const std::uint32_t*, const std::uint8_t*, std::uint32_t,
                  std::uint32_t*) noexcept;
  std::uint32_t (*balls)(const block_kernel_input&, const std::uint32_t*, const std::uint32_t*, std::size_t,
                         std::int32_t*, std::uint32_t*) noexcept;
  std::uint32_t (*split)(const std::int32_t*, const std::uint32_t*, std::uint32_t, std::int32_t, std::int32_t,
                         std::int32_t*, std::uint32_t*, std::int32_t*, std::uint32_t*, std::uint32_t*) noexcept;
  std::size_t (*select)(const float*, const float*, const float*, const std::uint32_t*, std::size_t, std::size_t,
                        const float*, const float*, float*) noexcept;
  std::size_t (*select_ids)(const float*, const float*, const float*, const std::uint32_t*, std::size_t, std::size_t,
                            const float*, const float*, std::uint32_t*) noexcept;
  /// The runs' set-up of counted grids (nullptr: the scalar one).
  void (*rows)(const row_grid&, std::uint32_t*, std::uint32_t*) noexcept;
  /// The sub-cell keys of counted grids (nullptr: cell_of, point by point).
  void (*cell_keys)(const float*, std::size_t, const double*, const double*, const std::int64_t*,
                    std::uint32_t*) noexcept;
  const char* name;
};
/// The build in use (the best this CPU runs, unless a test forced another).
const kernel_set& active_kernels() noexcept;

/// Which build of the neighbour pass runs: "avx512" (F, VL, BW, DQ) or
/// "avx2" when the CPU has it, otherwise "generic". All give bitwise
/// identical results; tests force one.
const char* kernel_isa() noexcept;
/// The builds this CPU can run, best first, "generic" last.
std::vector<std::string> kernel_isas();
/// Forces one of kernel_isas() (std::invalid_argument for another name).
void force_kernel_isa(const std::string& isa);
/// Forces the generic build (true) or restores the automatic choice (false).
void force_generic_kernel(bool on) noexcept;
/// Splits n distances (as bits, with their ids) by [lo, hi] on the chosen
/// build: those below lo to below_*[0..returned), those within to
/// range_*[0..*in_range), each in order. Reads up to 8 entries past n and
/// writes up to 8 past each count.
std::uint32_t split_distances(const std::int32_t* d2_bits, const std::uint32_t* ids, std::uint32_t n, std::int32_t lo,
                              std::int32_t hi, std::int32_t* below_bits, std::uint32_t* below_ids,
                              std::int32_t* range_bits, std::uint32_t* range_ids, std::uint32_t* in_range) noexcept;
/// select_in_box_* (block_kernel.hpp) on the chosen build.
std::size_t select_in_box(const float* x, const float* y, const float* z, const std::uint32_t* ids, std::size_t b,
                          std::size_t e, const float lo[3], const float hi[3], float* out) noexcept;
/// select_ids_in_box_* (block_kernel.hpp) on the chosen build.
std::size_t select_ids_in_box(const float* x, const float* y, const float* z, const std::uint32_t* ids, std::size_t b,
                              std::size_t e, const float lo[3], const float hi[3], std::uint32_t* out) noexcept;

}  // namespace ced::detail
