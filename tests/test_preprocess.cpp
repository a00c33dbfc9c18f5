// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <cmath>

#include "ced/preprocess.hpp"
#include "test_support.hpp"

TEST(Preprocess, RemoveNonfiniteKeepsOrderAndFields) {
  ced::point_cloud c;
  c.push_back(0, 0, 0);
  c.push_back(std::nanf(""), 0, 0);
  c.push_back(1, 1, 1);
  c.push_back(0, INFINITY, 0);
  c.add_field("i", ced::scalar_type::uint8, {10, 11, 12, 13});
  const auto original = ced::remove_nonfinite(c);
  EXPECT_EQ(original, (std::vector<std::uint32_t>{0, 2}));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.get_field("i").values, (std::vector<double>{10, 12}));
  EXPECT_EQ(c.position(1)[0], 1.0f);
}

TEST(Preprocess, VoxelAveragesEveryChannelInPclOrder) {
  ced::point_cloud c;
  // Two points in cell (0,0,0), one in (1,0,0), one in (0,1,0).
  c.push_back(0.001f, 0.002f, 0.003f);
  c.push_back(0.013f, 0.005f, 0.001f);  // cell x = 1
  c.push_back(0.003f, 0.004f, 0.005f);
  c.push_back(0.002f, 0.015f, 0.002f);  // cell y = 1
  c.add_field("red", ced::scalar_type::uint8, {10, 50, 13, 70});
  c.add_field("f", ced::scalar_type::float32, {0.5, 1.0, 0.25, 2.0});
  const auto v = ced::voxel_downsample(c, 0.01);
  ASSERT_EQ(v.cloud.size(), 3u);
  // Order: cell index x fastest: (0,0,0), (1,0,0), (0,1,0).
  EXPECT_NEAR(v.cloud.position(0)[0], 0.002f, 1e-7);
  EXPECT_NEAR(v.cloud.position(0)[1], 0.003f, 1e-7);
  EXPECT_NEAR(v.cloud.position(1)[0], 0.013f, 1e-7);
  EXPECT_NEAR(v.cloud.position(2)[1], 0.015f, 1e-7);
  EXPECT_EQ(v.cloud.get_field("red").values, (std::vector<double>{11, 50, 70}));  // (10+13)/2 truncated
  EXPECT_EQ(v.cloud.get_field("f").values, (std::vector<double>{0.375, 1.0, 2.0}));
  EXPECT_EQ(v.counts, (std::vector<std::uint32_t>{2, 1, 1}));
  EXPECT_EQ(v.representative[1], 1u);
  EXPECT_EQ(v.representative[2], 3u);
  EXPECT_THROW(ced::voxel_downsample(c, 0), std::invalid_argument);
  EXPECT_THROW(ced::voxel_downsample(c, -1), std::invalid_argument);
  EXPECT_THROW(ced::voxel_downsample(c, std::nan("")), std::invalid_argument);
  EXPECT_THROW(ced::voxel_downsample(c, 1e-30), std::invalid_argument);
}

TEST(Preprocess, ResolutionOfAGrid) {
  ced::point_cloud c;
  for (int x = 0; x < 40; ++x)
    for (int y = 0; y < 40; ++y) c.push_back(x * 0.02f, y * 0.02f, 0);
  EXPECT_NEAR(ced::estimate_resolution(c), 0.02, 1e-6);
  ced::point_cloud one;
  one.push_back(0, 0, 0);
  EXPECT_EQ(ced::estimate_resolution(one), 0.0);
}
