// SPDX-License-Identifier: MIT
// Tiled runs in a work directory (src/tiled/run.cpp, tile_cache.cpp): a failed
// merge keeps the parts for --resume.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {
using ced_test::room_request;
using ced_test::specs;
}  // namespace

TEST(TiledRun, AFailedMergeKeepsThePartsForResume) {
  const ced::tiled_request r = room_request(4000, 11, "resume_room.las", 0.2);
  const std::string& input = r.input;
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("resume_work");
  ced::merge_sink failing;
  failing.chunk = [](const ced::tile_part&) { throw std::runtime_error("disk full"); };
  o.sink = &failing;
  EXPECT_THROW(ced::run_tiled(r, o), std::runtime_error);
  ASSERT_TRUE(std::filesystem::exists(std::filesystem::path(o.work_dir) / "plan.json"));
  const auto whole = ced::detect(ced::io::read_cloud(input), r.params, specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 5u);
  // Resumed: every part is there and the tile caches are gone (each went
  // when its part was written), so the merge runs from the parts alone.
  o.sink = nullptr;
  o.resume = true;
  const auto parts = std::distance(std::filesystem::directory_iterator(std::filesystem::path(o.work_dir) / "parts"),
                                   std::filesystem::directory_iterator{});
  EXPECT_GT(parts, 1);
  const ced::tile_part merged = ced::run_tiled(r, o);
  EXPECT_EQ(merged.index, std::vector<std::uint64_t>(whole.begin(), whole.end()));
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
}
