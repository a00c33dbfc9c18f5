// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <thread>
#include <utility>
#include <vector>

#include "core/arena.hpp"

// The NMS keeps its working memory in a chunk_arena, recycled across
// detections: blocks must be aligned and disjoint, big requests served, and
// the process-wide cache bounded.
TEST(ChunkArena, AlignedDisjointBoundedAndReused) {
  using ced::detail::chunk_arena;
  const std::vector<std::size_t> sizes = {
      1,    100, 4096, 70000, chunk_arena::chunk_size, 3 * chunk_arena::chunk_size, 5, chunk_arena::chunk_size - 64,
      12345};
  {
    chunk_arena a;
    std::vector<unsigned char*> blocks;
    for (std::size_t k = 0; k < sizes.size(); ++k) {
      auto* p = static_cast<unsigned char*>(a.allocate(sizes[k]));
      ASSERT_EQ(reinterpret_cast<std::uintptr_t>(p) % 64, 0u) << k;
      std::fill_n(p, sizes[k], static_cast<unsigned char>(k + 1));
      blocks.push_back(p);
    }
    for (std::size_t k = 0; k < sizes.size(); ++k)  // an overlap would have overwritten some bytes
      ASSERT_TRUE(std::all_of(blocks[k], blocks[k] + sizes[k], [&](unsigned char b) { return b == k + 1; })) << k;
  }
  const std::size_t cached = chunk_arena::cached_bytes();
  EXPECT_GT(cached, 0u);
  EXPECT_LE(cached, chunk_arena::cache_limit);
  {
    chunk_arena b;
    b.allocate(10);  // takes a cached chunk
    EXPECT_EQ(chunk_arena::cached_bytes(), cached - chunk_arena::chunk_size);
  }
  EXPECT_EQ(chunk_arena::cached_bytes(), cached);
  {
    chunk_arena big;  // more standard chunks than the cache keeps
    for (std::size_t k = 0; k < 2 * chunk_arena::cache_limit / chunk_arena::chunk_size; ++k)
      big.allocate(chunk_arena::chunk_size - 64);
  }
  EXPECT_EQ(chunk_arena::cached_bytes(), chunk_arena::cache_limit);
}

TEST(ChunkArena, ThreadSafe) {
  ced::detail::chunk_arena a;
  constexpr int threads = 4, per_thread = 3000;
  std::vector<std::vector<std::pair<unsigned char*, std::size_t>>> got(threads);
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      std::mt19937 rng(static_cast<unsigned>(t));
      for (int k = 0; k < per_thread; ++k) {
        const std::size_t n = 1 + rng() % 5000;
        auto* p = static_cast<unsigned char*>(a.allocate(n));
        std::fill_n(p, n, static_cast<unsigned char>(t + 1));
        got[std::size_t(t)].push_back({p, n});
      }
    });
  for (auto& th : pool) th.join();
  for (int t = 0; t < threads; ++t)
    for (const auto& [p, n] : got[std::size_t(t)])
      ASSERT_TRUE(std::all_of(p, p + n, [&](unsigned char b) { return b == t + 1; })) << "thread " << t;
}
