// SPDX-License-Identifier: MIT
#include "core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#ifdef __linux__
#include <sched.h>
#endif

#ifdef CED_HAS_TBB
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>
#endif

namespace ced {
unsigned resolve_threads(unsigned threads) noexcept {
  if (threads != 0) return threads;
#ifdef __linux__
  // The cores this process may run on (mpirun and taskset bind to fewer
  // than the machine has; TBB warns at every arena wider than that).
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0) return unsigned(CPU_COUNT(&set));
#endif
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1u : hw;
}
}  // namespace ced

namespace ced::detail {

namespace {
/// The limit with_threads() set on this thread (0: none): what threads = 0
/// means to parallel_for() there.
thread_local unsigned t_limit = 0;

unsigned current_threads(unsigned threads) noexcept {
  if (threads != 0) return threads;
  return t_limit != 0 ? t_limit : resolve_threads(0);
}
}  // namespace

unsigned effective_threads(unsigned threads) noexcept { return current_threads(threads); }

#ifdef CED_HAS_TBB
namespace {
/// One arena per concurrency, made on first use and kept: making an arena
/// for every call cost 40-170 us a call (a detection makes a dozen calls).
oneapi::tbb::task_arena& arena_for(unsigned concurrency) {
  static std::mutex mutex;
  static std::vector<std::unique_ptr<oneapi::tbb::task_arena>> arenas;
  std::lock_guard<std::mutex> lock(mutex);
  if (arenas.size() <= concurrency) arenas.resize(concurrency + 1);
  auto& a = arenas[concurrency];
  if (!a) a = std::make_unique<oneapi::tbb::task_arena>(static_cast<int>(concurrency));
  return *a;
}
}  // namespace
#endif

void parallel_for(std::size_t n, unsigned threads, std::size_t grain,
                  const std::function<void(std::size_t, std::size_t)>& body) {
  if (n == 0) return;
  grain = std::max<std::size_t>(grain, 1);
  const unsigned t = current_threads(threads);
  if (n <= grain) {
    body(0, n);
    return;
  }
  if (t == 1) {
    // In order, in at most 256 chunks: a progress report (and with it a
    // cancellation) can come between chunks, at no measurable cost.
    const std::size_t chunk = std::max(grain, (n + 255) / 256);
    for (std::size_t b = 0; b < n; b += chunk) body(b, std::min(n, b + chunk));
    return;
  }
#ifdef CED_HAS_TBB
  // More threads than cores buys nothing (and TBB warns); the result is the same.
  arena_for(std::min(t, resolve_threads(0))).execute([&] {
    oneapi::tbb::parallel_for(oneapi::tbb::blocked_range<std::size_t>(0, n, grain),
                              [&](const oneapi::tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
  });
#else
  // Dynamic scheduling over chunks of `grain` items with plain threads.
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&] {
    for (;;) {
      const std::size_t b = next.fetch_add(grain);
      if (b >= n) return;
      try {
        body(b, std::min(n, b + grain));
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next.store(n);
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < t; ++i) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
#endif
}

namespace {
/// Sets this thread's limit for as long as it lives.
class scoped_limit {
 public:
  explicit scoped_limit(unsigned threads) noexcept : m_old(t_limit) {
    t_limit = std::min(current_threads(threads), resolve_threads(0));
  }
  ~scoped_limit() { t_limit = m_old; }
  scoped_limit(const scoped_limit&) = delete;
  scoped_limit& operator=(const scoped_limit&) = delete;

 private:
  unsigned m_old;
};
}  // namespace

void with_threads(unsigned threads, const std::function<void()>& f) {
  const scoped_limit limit(threads);
#ifdef CED_HAS_TBB
  if (t_limit > 1) {
    arena_for(t_limit).execute(f);
    return;
  }
#endif
  f();  // one thread: no arena (nor TBB's start-up) is needed
}

void with_thread_limit(unsigned threads, const std::function<void()>& f) {
  const scoped_limit limit(threads);
  f();
}

}  // namespace ced::detail
