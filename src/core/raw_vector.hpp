// SPDX-License-Identifier: MIT
// Internal: a std::vector whose resize() leaves new elements uninitialised,
// for arrays that are written in full right after they are sized (zeroing
// them first costs a pass over memory for nothing).
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"

namespace ced::detail {

/// Base<T>'s allocator whose construct() without arguments leaves the value
/// uninitialised.
template <class T, template <class> class Base = std::allocator>
struct uninitialised_allocator : Base<T> {
  template <class U>
  struct rebind {
    using other = uninitialised_allocator<U, Base>;
  };
  uninitialised_allocator() = default;
  template <class U>
  uninitialised_allocator(const uninitialised_allocator<U, Base>&) noexcept {}
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
/// The same in a column's memory: from 1 MiB on, whole 2 MiB pages advised
/// to be huge (ced/cloud.hpp), which this VM faults in some 15 × faster.
template <class T>
using raw_column_vector = std::vector<T, uninitialised_allocator<T, column_allocator>>;

}  // namespace ced::detail
