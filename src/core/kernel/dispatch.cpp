// SPDX-License-Identifier: MIT
// The choice of the kernels' build (dispatch.hpp).
#include "core/kernel/dispatch.hpp"

#include <atomic>
#include <stdexcept>

namespace ced::detail {

namespace {
constexpr kernel_set generic_kernels{
    block_kernel_generic,      compact_generic, balls_generic, split_generic, select_in_box_generic,
    select_ids_in_box_generic, nullptr,         nullptr,       "generic"};

/// The builds this CPU can run, best first; the generic one always last.
std::vector<kernel_set> available_kernels() {
  std::vector<kernel_set> sets;
#if defined(CED_HAS_AVX512_KERNEL)
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
      __builtin_cpu_supports("avx512dq"))
    sets.push_back({block_kernel_avx512, compact_avx512, balls_avx512, split_avx512, select_in_box_avx512,
                    select_ids_in_box_avx512, rows_avx512, cell_keys_avx512, "avx512"});
#endif
#if defined(CED_HAS_AVX2_KERNEL)
  if (__builtin_cpu_supports("avx2"))
    sets.push_back({block_kernel_avx2, compact_avx2, balls_avx2, split_avx2, select_in_box_avx2, select_ids_in_box_avx2,
                    rows_avx2, cell_keys_avx2, "avx2"});
#endif
  sets.push_back(generic_kernels);
  return sets;
}
const std::vector<kernel_set>& kernels() {
  static const std::vector<kernel_set> sets = available_kernels();
  return sets;
}
/// The build tests force (an index into kernels()); 0 is the best.
std::atomic<std::size_t> g_forced{0};

}  // namespace

const kernel_set& active_kernels() noexcept { return kernels()[g_forced.load(std::memory_order_relaxed)]; }

const char* kernel_isa() noexcept { return active_kernels().name; }
std::uint32_t split_distances(const std::int32_t* d2_bits, const std::uint32_t* ids, std::uint32_t n, std::int32_t lo,
                              std::int32_t hi, std::int32_t* below_bits, std::uint32_t* below_ids,
                              std::int32_t* range_bits, std::uint32_t* range_ids, std::uint32_t* in_range) noexcept {
  return active_kernels().split(d2_bits, ids, n, lo, hi, below_bits, below_ids, range_bits, range_ids, in_range);
}
std::size_t select_in_box(const float* x, const float* y, const float* z, const std::uint32_t* ids, std::size_t b,
                          std::size_t e, const float lo[3], const float hi[3], float* out) noexcept {
  return active_kernels().select(x, y, z, ids, b, e, lo, hi, out);
}
std::size_t select_ids_in_box(const float* x, const float* y, const float* z, const std::uint32_t* ids, std::size_t b,
                              std::size_t e, const float lo[3], const float hi[3], std::uint32_t* out) noexcept {
  return active_kernels().select_ids(x, y, z, ids, b, e, lo, hi, out);
}
void force_generic_kernel(bool on) noexcept { g_forced.store(on ? kernels().size() - 1 : 0); }
std::vector<std::string> kernel_isas() {
  std::vector<std::string> names;
  for (const kernel_set& k : kernels()) names.emplace_back(k.name);
  return names;
}
void force_kernel_isa(const std::string& isa) {
  for (std::size_t i = 0; i < kernels().size(); ++i)
    if (isa == kernels()[i].name) return g_forced.store(i);
  throw std::invalid_argument("this CPU or build has no '" + isa + "' neighbour pass");
}

}  // namespace ced::detail
