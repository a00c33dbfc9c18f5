// SPDX-License-Identifier: MIT
// ced/open3d.hpp: Open3D clouds read by Open3D give the keypoints of the
// same file read by ced (the Redwood scans; a cloud with normals).
#include <gtest/gtest.h>
#include <open3d/io/PointCloudIO.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "ced/io/io.hpp"
#include "ced/open3d.hpp"
#include "hue_modality.hpp"  // examples/: a user's modality (neighbour lists)

namespace {

std::string data(const std::string& name) { return std::string(CED_TEST_DATA_DIR) + "/" + name; }

open3d::geometry::PointCloud read_open3d(const std::string& path) {
  open3d::geometry::PointCloud pcd;
  EXPECT_TRUE(open3d::io::ReadPointCloud(path, pcd)) << path;
  return pcd;
}

void expect_same(const ced::detection_result& got, const ced::detection_result& want) {
  EXPECT_EQ(got.keypoints, want.keypoints);
  ASSERT_EQ(got.saliency.size(), want.saliency.size());
  for (std::size_t m = 0; m < want.saliency.size(); ++m) EXPECT_EQ(got.saliency[m], want.saliency[m]) << m;
}

}  // namespace

TEST(Open3d, RedwoodScansAsTheirFiles) {
  for (const std::string scan : {"apartment_mesh_213", "apartment_mesh_214", "loft_mesh_240"}) {
    SCOPED_TRACE(scan);
    const auto file = ced::io::read_ply(data(scan + ".ply"));
    const auto pcd = read_open3d(data(scan + ".ply"));
    const auto cloud = ced::from_open3d(pcd);
    EXPECT_EQ(cloud.get_field("red").type(), ced::scalar_type::uint8);  // 8-bit colours stay 8-bit
    for (const std::string preset : {"ced6d", "ced3d", "robust6d"}) {
      SCOPED_TRACE(preset);
      auto p = ced::detect_params{};
      p.refine = ced::preset_refines(preset);
      expect_same(ced::detect(pcd, p, ced::preset(preset)), ced::detect(file, p, ced::preset(preset)));
    }
  }
  const auto pcd = read_open3d(data("apartment_mesh_214.ply"));
  // A modality written against ced::core alone works unchanged.
  expect_same(
      ced::detect(pcd, ced::detect_params{}, ced::xyz{}, example::hue{}),
      ced::detect(ced::io::read_ply(data("apartment_mesh_214.ply")), ced::detect_params{}, ced::xyz{}, example::hue{}));
  const auto r = ced::detect(pcd, ced::detect_params{}, ced::xyz{}, ced::rgb{});
  const auto kp = ced::keypoint_cloud(pcd, r);
  ASSERT_EQ(kp->points_.size(), r.keypoints.size());
  EXPECT_EQ(kp->points_[3], pcd.points_[r.keypoints[3]]);
  EXPECT_EQ(kp->colors_[3], pcd.colors_[r.keypoints[3]]);
}

// Normals travel as nx, ny, nz (the normals modality reads them); colours
// that are not 8-bit stay float in [0, 1].
TEST(Open3d, NormalsAndFloatColours) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  open3d::geometry::PointCloud pcd;
  ced::point_cloud want;
  std::vector<double> nx, ny, nz, r, g, b;
  for (int i = 0; i < 4000; ++i) {
    const double x = u(rng), y = u(rng), z = 0.1 * std::sin(6 * x) * (y > 0.5);
    Eigen::Vector3d n(-0.6 * std::cos(6 * x) * (y > 0.5), 0, 1);
    n.normalize();
    pcd.points_.emplace_back(x, y, z);
    pcd.normals_.push_back(n);
    pcd.colors_.emplace_back(u(rng), 0.5, y);
    want.push_back(float(x), float(y), float(z));
    nx.push_back(n.x()), ny.push_back(n.y()), nz.push_back(n.z());
    r.push_back(pcd.colors_.back().x()), g.push_back(0.5), b.push_back(y);
  }
  want.add_field("red", ced::scalar_type::float64, r);
  want.add_field("green", ced::scalar_type::float64, g);
  want.add_field("blue", ced::scalar_type::float64, b);
  want.add_field("nx", ced::scalar_type::float64, nx);
  want.add_field("ny", ced::scalar_type::float64, ny);
  want.add_field("nz", ced::scalar_type::float64, nz);
  const auto cloud = ced::from_open3d(pcd);
  EXPECT_EQ(cloud.get_field("red").type(), ced::scalar_type::float64);
  EXPECT_EQ(cloud.get_field("nz").values[7], nz[7]);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.08;
  const ced::normals from_fields(0.05, ced::normals::source::fields);
  const auto got = ced::detect(pcd, p, ced::xyz{}, ced::rgb{}, from_fields);
  expect_same(got, ced::detect(want, p, ced::xyz{}, ced::rgb{}, from_fields));
  EXPECT_GT(got.keypoints.size(), 10u);

  pcd.points_[11].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ced::from_open3d(pcd), std::invalid_argument);
  pcd.points_[11].y() = 0;
  pcd.normals_.pop_back();
  try {
    ced::from_open3d(pcd);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "Open3D cloud: 3999 normals for 4000 points");
  }
}
