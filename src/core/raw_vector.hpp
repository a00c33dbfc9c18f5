// SPDX-License-Identifier: MIT
// Internal: a std::vector whose resize() leaves new elements uninitialised,
// for arrays that are written in full right after they are sized (zeroing
// them first costs a pass over memory for nothing).
#pragma once

#include <memory>
#include <utility>
#include <vector>

namespace ced::detail {

template <class T>
struct uninitialised_allocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = uninitialised_allocator<U>;
  };
  uninitialised_allocator() = default;
  template <class U>
  uninitialised_allocator(const uninitialised_allocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... A>
  void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
};

template <class T>
using raw_vector = std::vector<T, uninitialised_allocator<T>>;

}  // namespace ced::detail
