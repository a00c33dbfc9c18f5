// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <functional>

#include "ced/params.hpp"

namespace ced::detail {

using ::ced::resolve_threads;  // ced/params.hpp

/// Calls `body(begin, end)` on disjoint chunks covering [0, n), on up to
/// `threads` threads (0 = all cores, or the limit of an enclosing
/// with_threads() or with_thread_limit() on this thread), and returns when
/// all are done. Chunks hold at least `grain` items. Exceptions thrown by
/// `body` are rethrown.
/// Which thread runs a chunk is unspecified, so `body` must write only to
/// locations owned by its items for the result to be deterministic.
void parallel_for(std::size_t n, unsigned threads, std::size_t grain,
                  const std::function<void(std::size_t, std::size_t)>& body);

/// How many threads parallel_for() with `threads` would use on this thread
/// at most: `threads`, or for 0 the enclosing limit, else all cores.
unsigned effective_threads(unsigned threads) noexcept;

/// Runs `f` where parallel_for() with threads = 0 on this thread uses up to
/// `threads` threads (0 = all cores, or an enclosing with_threads()' limit),
/// and so do TBB algorithms it calls directly (CGAL's Parallel_tag) when that
/// is more than one. With one thread `f` just runs, and TBB is not started.
void with_threads(unsigned threads, const std::function<void()>& f);

/// Runs `f` where parallel_for() with threads = 0 on this thread uses up to
/// `threads` threads, and nothing else: unlike with_threads(), no TBB arena is
/// entered (nor TBB started) unless a parallel_for() goes parallel.
void with_thread_limit(unsigned threads, const std::function<void()>& f);

}  // namespace ced::detail
