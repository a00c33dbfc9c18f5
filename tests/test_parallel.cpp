// SPDX-License-Identifier: MIT
// parallel_for and resolve_threads (core/parallel.hpp).
#include <gtest/gtest.h>

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>

#include "ced/params.hpp"
#include "core/parallel.hpp"

namespace {

struct boom : std::runtime_error {
  explicit boom(std::size_t i) : std::runtime_error("boom at " + std::to_string(i)), item(i) {}
  std::size_t item;
};

}  // namespace

TEST(Parallel, ResolveThreads) {
  EXPECT_GE(ced::resolve_threads(0), 1u);
  if (std::thread::hardware_concurrency() != 0) {
    EXPECT_EQ(ced::resolve_threads(0), std::thread::hardware_concurrency());
  }
  EXPECT_EQ(ced::resolve_threads(1), 1u);
  EXPECT_EQ(ced::resolve_threads(3), 3u);
  EXPECT_EQ(ced::resolve_threads(64), 64u);
  EXPECT_EQ(ced::detail::resolve_threads(3), 3u);  // the same function
}

TEST(Parallel, ForCoversTheRangeExactlyOnce) {
  for (const std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(7), std::size_t(100),
                              std::size_t(1000), std::size_t(4097), std::size_t(100003)})
    for (const std::size_t grain :
         {std::size_t(0), std::size_t(1), std::size_t(3), std::size_t(64), std::size_t(1000), std::size_t(1) << 20})
      for (const unsigned threads : {0u, 1u, 2u, 3u, 8u}) {
        SCOPED_TRACE(testing::Message() << "n " << n << " grain " << grain << " threads " << threads);
        const std::unique_ptr<std::atomic<int>[]> seen(new std::atomic<int>[n + 1]);
        for (std::size_t i = 0; i <= n; ++i) seen[i] = 0;
        std::atomic<std::size_t> calls{0}, bad_chunks{0};
        ced::detail::parallel_for(n, threads, grain, [&](std::size_t b, std::size_t e) {
          ++calls;
          if (!(b < e && e <= n)) {
            ++bad_chunks;
            return;
          }
          for (std::size_t i = b; i < e; ++i) ++seen[i];
        });
        EXPECT_EQ(bad_chunks.load(), 0u) << "a chunk empty or beyond n";
        std::size_t wrong = 0;
        for (std::size_t i = 0; i < n; ++i) wrong += seen[i] != 1;
        EXPECT_EQ(wrong, 0u) << "items not visited exactly once";
        EXPECT_EQ(seen[n].load(), 0);
        if (n == 0) {
          EXPECT_EQ(calls.load(), 0u) << "no call for an empty range";
        } else {
          EXPECT_GE(calls.load(), 1u);
        }
      }
}

TEST(Parallel, ForRethrowsTheBodysException) {
  for (const unsigned threads : {1u, 2u, 4u})
    for (const std::size_t n : {std::size_t(1), std::size_t(10), std::size_t(100000)}) {
      SCOPED_TRACE(testing::Message() << "n " << n << " threads " << threads);
      const std::size_t bad = n / 2;
      try {
        ced::detail::parallel_for(n, threads, 16, [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i)
            if (i == bad) throw boom(i);
        });
        ADD_FAILURE() << "no exception";
      } catch (const boom& e) {  // the same type, the same object's contents
        EXPECT_EQ(e.item, bad);
        EXPECT_EQ(std::string(e.what()), "boom at " + std::to_string(bad));
      } catch (...) {
        ADD_FAILURE() << "another exception";
      }
      // Every chunk throws: one of them is rethrown.
      EXPECT_THROW(ced::detail::parallel_for(n, threads, 1, [](std::size_t b, std::size_t) { throw boom(b); }), boom);
      // And the pool works afterwards.
      std::atomic<std::size_t> sum{0};
      ced::detail::parallel_for(n, threads, 16, [&](std::size_t b, std::size_t e) { sum += e - b; });
      EXPECT_EQ(sum.load(), n);
    }
}

TEST(Parallel, WithThreadsRunsTheFunctionOnce) {
  for (const unsigned threads : {0u, 1u, 2u}) {
    int calls = 0;
    ced::detail::with_threads(threads, [&] { ++calls; });
    EXPECT_EQ(calls, 1) << threads;
    EXPECT_THROW(ced::detail::with_threads(threads, [] { throw boom(0); }), boom);
  }
}

TEST(Parallel, WithThreadsLimitsParallelForWithoutAThreadCount) {
  // threads = 0 inside with_threads(t) means t, on this thread; an explicit
  // count still wins, and the limit ends with the call.
  const auto threads_used = [](unsigned threads) {
    std::mutex m;
    std::set<std::thread::id> ids;
    ced::detail::parallel_for(20000, threads, 1, [&](std::size_t b, std::size_t e) {
      volatile double x = 0;
      for (std::size_t i = b; i < e; ++i)
        for (int k = 0; k < 2000; ++k) x = x + double(k);
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    });
    return ids.size();
  };
  ced::detail::with_threads(1, [&] {
    EXPECT_EQ(threads_used(0), 1u);
    ced::detail::with_threads(0, [&] { EXPECT_EQ(threads_used(0), 1u) << "0 keeps the enclosing limit"; });
  });
  ced::detail::with_thread_limit(1, [&] {
    EXPECT_EQ(threads_used(0), 1u);
    ced::detail::with_threads(0, [&] { EXPECT_EQ(threads_used(0), 1u) << "0 keeps the enclosing limit"; });
  });
  if (ced::resolve_threads(0) >= 2) {
    // Nested limits and explicit counts (several threads may, not must, be used).
    ced::detail::with_threads(2, [&] { EXPECT_LE(threads_used(0), 2u); });
    ced::detail::with_thread_limit(2, [&] { EXPECT_LE(threads_used(0), 2u); });
    ced::detail::with_threads(1, [&] { EXPECT_LE(threads_used(2), 2u); });
  }
}
