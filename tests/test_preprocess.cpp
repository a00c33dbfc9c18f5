// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

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

// Multispectral LiDAR channels merged by nearest neighbour: hand-placed
// partners, origins that differ, ties, radius, dropped or NaN.
TEST(Preprocess, MergeChannelsTakesTheNearestPartner) {
  ced::point_cloud ref;  // origin (100, 0, 0)
  ref.set_origin({100, 0, 0});
  for (int i = 0; i < 4; ++i) ref.push_back(float(i == 3 ? 6 : i), 0, 0);  // absolute x 100, 101, 102, 106
  ref.add_field("intensity", ced::scalar_type::uint16, {10, 11, 12, 13});
  ced::point_cloud c2;  // origin (0, 0, 0): absolute x 100.1, 101.3, 102.5, 101.5, 110
  for (float x : {100.1f, 101.3f, 102.5f, 101.5f, 110.0f}) c2.push_back(x, 0, 0);
  c2.add_field("intensity", ced::scalar_type::uint16, {200, 201, 202, 203, 204});
  c2.add_field("amplitude", ced::scalar_type::float32, {1.5, 2.5, 3.5, 4.5, 5.5});
  ced::channel_merge_options o;
  o.radius = 0.55;
  o.when_missing = ced::channel_merge_options::missing::nan;
  ced::channel_merge_report r;
  const auto m = ced::merge_channels(ref, {{"c2", &c2}}, o, &r);
  ASSERT_EQ(m.size(), 4u);
  const auto* f = m.find_field("intensity_c2");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->type(), ced::scalar_type::float32);
  EXPECT_EQ(f->values[0], 200);           // 0.1 away
  EXPECT_EQ(f->values[1], 201);           // 0.3 away, before 101.5 at 0.5
  EXPECT_EQ(f->values[2], 202);           // 102.5 and 101.5 both exactly 0.5 away: the smaller index
  EXPECT_TRUE(std::isnan(f->values[3]));  // nothing within 0.55 of 106
  EXPECT_EQ(r.partnered, std::vector<std::size_t>{3});
  EXPECT_EQ(m.find_field("intensity")->values[3], 13);  // the reference's own fields stay
  // Dropped: the fourth point goes; the merged field keeps its type.
  o.when_missing = ced::channel_merge_options::missing::drop;
  o.fields = {"intensity", "amplitude"};
  const auto d = ced::merge_channels(ref, {{"c2", &c2}}, o, &r);
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(r.dropped, 1u);
  EXPECT_EQ(d.find_field("intensity_c2")->type(), ced::scalar_type::uint16);
  EXPECT_EQ(d.find_field("amplitude_c2")->values[1], 2.5);
  // Errors name the problem.
  o.radius = 0;
  EXPECT_THROW(ced::merge_channels(ref, {{"c2", &c2}}, o), std::invalid_argument);
  o.radius = 0.55;
  o.fields = {"nir"};
  EXPECT_THROW(ced::merge_channels(ref, {{"c2", &c2}}, o), std::invalid_argument);
  o.fields = {"intensity"};
  EXPECT_THROW(ced::merge_channels(ref, {{"c2", &c2}, {"c2", &c2}}, o), std::invalid_argument);
  ced::point_cloud clash = ref;
  clash.add_field("intensity_c2", ced::scalar_type::uint16, {0, 0, 0, 0});
  EXPECT_THROW(ced::merge_channels(clash, {{"c2", &c2}}, o), std::invalid_argument);
  // Any thread count, the same partners (a larger random case).
  const auto a = ced_test::make_room(4000, 3), b = ced_test::make_room(3000, 4);
  o.radius = 0.02;
  o.threads = 1;
  const auto one = ced::merge_channels(a, {{"b", &b}}, o);
  o.threads = 3;
  const auto three = ced::merge_channels(a, {{"b", &b}}, o);
  ASSERT_EQ(one.size(), three.size());
  EXPECT_GT(one.size(), 100u);
  for (std::size_t i = 0; i < one.size(); ++i)
    ASSERT_EQ(one.find_field("intensity_b")->values[i], three.find_field("intensity_b")->values[i]);
}
