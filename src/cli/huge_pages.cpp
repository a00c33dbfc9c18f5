// SPDX-License-Identifier: MIT
// The tools' global operator new (ced and ced-mpi only; the libraries do not
// replace it): blocks of 1 MiB and more are allocated in whole 2 MiB pages
// and advised as transparent huge pages (MADV_HUGEPAGE), smaller ones come
// from malloc, whose main heap is made ready before main() (heap_setup
// below: its first 32 MiB advised as huge pages, freed memory kept).
// Everything is released with free().
//
// Why: where transparent huge pages are used only when advised (Debian's
// default, "madvise"), every fresh 4 KiB page costs a page fault, about
// 13 us on our 2-vCPU VM: a detection's saliency columns, neighbour counts
// and kept sweeps on a 105k-point scan fault in about 1,800 pages, which
// was about a third of a whole `ced detect` process (docs/journal/benchmarks.md).
// One 2 MiB page takes one fault.
#include <malloc.h>

#include <cstddef>
#include <cstdlib>
#include <new>

#include "ced/cloud.hpp"

namespace {

/// The main heap, made ready before main(): `heap_reserve` bytes of it
/// advised as huge pages (as glibc's own glibc.malloc.hugetlb=1 tunable
/// does), and kept when freed, so that the many blocks under 1 MiB fault in
/// 2 MiB at a time and are reused, not faulted in again.
struct heap_setup {
  heap_setup() noexcept {
    constexpr std::size_t heap_reserve = std::size_t(32) << 20;
    mallopt(M_TRIM_THRESHOLD, int(heap_reserve * 2));
    mallopt(M_MMAP_THRESHOLD, int(heap_reserve * 2));
    if (void* p = std::malloc(heap_reserve)) {
      ced::detail::advise_huge_pages(p, heap_reserve);
      std::free(p);
    }
    mallopt(M_MMAP_THRESHOLD, int(std::size_t(1) << 20));
  }
};
const heap_setup heap_ready;

constexpr std::size_t large_block = std::size_t(1) << 20;

void* allocate(std::size_t n) noexcept {
  if (n < large_block) return std::malloc(n ? n : 1);
  return ced::detail::allocate_huge_pages(n);  // at most 1 MiB (and under half) more than asked for
}

void* allocate_or_throw(std::size_t n) {
  for (;;) {
    if (void* p = allocate(n)) return p;
    std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}

void* allocate_or_null(std::size_t n) noexcept {
  try {
    return allocate_or_throw(n);
  } catch (...) {
    return nullptr;
  }
}

}  // namespace

void* operator new(std::size_t n) { return allocate_or_throw(n); }
void* operator new[](std::size_t n) { return allocate_or_throw(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return allocate_or_null(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return allocate_or_null(n); }
// malloc, aligned_alloc and libstdc++'s aligned operator new all release with free().
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
