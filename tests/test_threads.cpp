// SPDX-License-Identifier: MIT
// The library's thread-safety promise (docs/ARCHITECTURE.md#threads):
// detections may run at once on several threads, on the same const cloud and
// on different clouds, each with its own modalities; they share the NMS's
// process-wide chunk cache, the modality registry and the kernels. Each must
// give bitwise what it gives alone. CI runs this file under ThreadSanitizer
// (CED_TSAN, with the std::thread backend: TBB is not TSan-instrumented).
#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "ced/ced.hpp"
#include "core/arena.hpp"
#include "test_support.hpp"

namespace {

struct job {
  const ced::point_cloud* cloud;
  std::vector<std::string> specs;
  unsigned threads;
};

ced::detection_result run(const job& j) {
  std::vector<ced::any_modality> m;
  for (const auto& s : j.specs) m.push_back(ced::make_modality(s));  // the registry, from many threads
  ced::detect_params p;
  p.radius = p.nms_radius = 0.06;
  p.threads = j.threads;
  return ced::detect(*j.cloud, p, m);
}

}  // namespace

TEST(Threads, ConcurrentDetectionsOnSharedAndSeparateCloudsMatchTheirSerialResults) {
  const ced::point_cloud shared = ced_test::make_room(5000, 11, 0.003f);
  const ced::point_cloud other_a = ced_test::make_room(3000, 12, 0.003f);
  const ced::point_cloud other_b = ced_test::make_room(4000, 13, 0.002f);
  const std::vector<job> jobs = {
      {&shared, {"xyz:0.2", "rgb:0.1"}, 1},
      {&shared, {"xyz:0.2,scale=3", "rgb:0.5"}, 2},  // a scaled modality: a pass of its own
      {&shared, {"normals:0.2", "lab:0.1"}, 1},      // normals: neighbour lists
      {&shared, {"xyz:0.2", "bands(nir):0.1", "intensity:0.05"}, 3},
      {&other_a, {"xyz:0.2", "rgb:0.1"}, 2},
      {&other_b, {"xyz:0.3"}, 1},
  };
  // Alone first (the cache warmed by one detection at a time).
  std::vector<ced::detection_result> alone;
  for (const auto& j : jobs) alone.push_back(run(j));
  for (const auto& r : alone) ASSERT_FALSE(r.keypoints.empty());

  // Then all at once, three rounds each, while another thread keeps
  // releasing the shared chunk cache.
  constexpr int rounds = 3;
  std::vector<std::vector<ced::detection_result>> got(jobs.size());
  std::atomic<bool> done{false};
  std::thread releaser([&] {
    while (!done.load()) {
      ced::release_cached_memory();
      std::this_thread::yield();
    }
  });
  std::vector<std::thread> workers;
  for (std::size_t k = 0; k < jobs.size(); ++k)
    workers.emplace_back([&, k] {
      for (int r = 0; r < rounds; ++r) got[k].push_back(run(jobs[k]));
    });
  for (auto& t : workers) t.join();
  done = true;
  releaser.join();
  for (std::size_t k = 0; k < jobs.size(); ++k)
    for (const auto& r : got[k]) {
      EXPECT_EQ(r.keypoints, alone[k].keypoints) << "job " << k;
      EXPECT_EQ(r.saliency, alone[k].saliency) << "job " << k;
      EXPECT_EQ(r.candidate, alone[k].candidate) << "job " << k;
    }
}

TEST(Threads, ArenasShareTheChunkCache) {
  // Many arenas on many threads take chunks from, and return them to, the
  // process-wide cache; the cache stays within its limit.
  ced::detail::chunk_arena::release_cache();
  std::vector<std::thread> workers;
  for (int t = 0; t < 6; ++t)
    workers.emplace_back([t] {
      for (int r = 0; r < 20; ++r) {
        ced::detail::chunk_arena a;
        for (int k = 0; k < 8 + t; ++k) {
          auto* p = static_cast<unsigned char*>(a.allocate(100000 + 1000 * std::size_t(k)));
          p[0] = static_cast<unsigned char>(k);
        }
      }
    });
  for (auto& w : workers) w.join();
  EXPECT_LE(ced::detail::chunk_arena::cached_bytes(), ced::detail::chunk_arena::cache_limit);
  EXPECT_GT(ced::detail::chunk_arena::cached_bytes(), 0u);
}
