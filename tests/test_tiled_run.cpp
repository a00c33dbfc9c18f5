// SPDX-License-Identifier: MIT
// Tiled runs in a work directory (src/tiled/run.cpp, tile_cache.cpp): a failed
// merge keeps the parts for --resume; a tile cache of another format version is refused.
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

TEST(TiledRun, ATileCacheOfAnotherFormatVersionIsRefused) {
  const ced::tiled_request r = room_request(3000, 12, "cache_version.las", 0.2);
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("cache_version_work");
  const ced::tile_plan plan = ced::prepare_tiled(r, o);
  ASSERT_GT(plan.tiles.size(), 1u);
  const std::uint64_t id = plan.tiles.front().id;
  const std::string cache =
      (std::filesystem::path(o.work_dir) / "cache" / ("t" + std::to_string(id) + ".bin")).string();
  const std::string bytes = ced_test::read_bytes(cache);
  ASSERT_GT(bytes.size(), 12u);
  EXPECT_EQ(bytes.substr(0, 12), std::string("CEDTILE\0\x03\0\0\0", 12));  // magic, format version 3
  std::string bumped = bytes;
  bumped[8] = 7;
  ced_test::write_bytes(cache, bumped);
  try {
    ced::detect_cached_tile(plan, o.work_dir, id);
    ADD_FAILURE() << "a tile cache of format version 7 was read";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find(cache + ": tile cache format version 7, this ced reads version 3"),
              std::string::npos)
        << e.what();
  }
  // The cache of a ced before format versions: no header at all.
  ced_test::write_bytes(cache, bytes.substr(12));
  try {
    ced::detect_cached_tile(plan, o.work_dir, id);
    ADD_FAILURE() << "a tile cache without a header was read";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find(cache + ": not a ced tile cache (or one of format version 1"),
              std::string::npos)
        << e.what();
  }
  ced_test::write_bytes(cache, bytes);
  EXPECT_NO_THROW(ced::detect_cached_tile(plan, o.work_dir, id));
  ced::remove_work_dir(o.work_dir);
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
}
