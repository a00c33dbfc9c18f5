// SPDX-License-Identifier: MIT
// Keypoints of an Open3D point cloud, as a new Open3D cloud. Needs the
// `open3d` component (find_package(ced COMPONENTS open3d)).
//
//   example_open3d_keypoints scan.ply keypoints.ply
#include <open3d/io/PointCloudIO.h>

#include <ced/open3d.hpp>
#include <filesystem>
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: example_open3d_keypoints CLOUD KEYPOINTS.ply\n";
    return 2;
  }
  std::error_code same;
  if (std::filesystem::equivalent(argv[1], argv[2], same)) {  // never overwrite the input
    std::cerr << "example_open3d_keypoints: the output " << argv[2] << " is the input\n";
    return 2;
  }
  open3d::geometry::PointCloud pcd;
  if (!open3d::io::ReadPointCloud(argv[1], pcd)) return 1;
  pcd.RemoveNonFinitePoints();
  const ced::detection_result r =
      ced::detect(pcd, ced::detect_params{}, ced::preset(pcd.HasColors() ? "ced6d" : "ced3d"));
  const auto keypoints = ced::keypoint_cloud(pcd, r);  // = pcd.SelectByIndex(ced::to_open3d_indices(r))
  std::cout << keypoints->points_.size() << " keypoints of " << pcd.points_.size() << " points\n";
  return open3d::io::WritePointCloud(argv[2], *keypoints) ? 0 : 1;
}
