// Compiles against the optional adaptor components found through
// find_package(ced COMPONENTS eigen pcl open3d) (or the build tree's
// targets), each only when its library is there: CED_CONSUMER_EIGEN,
// CED_CONSUMER_PCL, CED_CONSUMER_OPEN3D. Each detects on a line whose two
// ends are its keypoints.
#include <cstdint>
#include <iostream>
#include <vector>

#ifdef CED_CONSUMER_EIGEN
#include <ced/eigen.hpp>
#endif
#ifdef CED_CONSUMER_PCL
#include <pcl/point_types.h>

#include <ced/pcl.hpp>
#endif
#ifdef CED_CONSUMER_OPEN3D
#include <ced/open3d.hpp>
#endif
#include <ced/core.hpp>

int main() {
  const std::vector<std::uint32_t> ends = {0, 49};
  bool ok = true;
#ifdef CED_CONSUMER_EIGEN
  Eigen::MatrixX3f line = Eigen::MatrixX3f::Zero(50, 3);  // the float line of consumer_core
  for (int i = 0; i < 50; ++i) line(i, 0) = float(i) * 0.01f;
  const bool eigen_ok = ced::detect(line, ced::detect_params{}, ced::xyz{0.2}).keypoints == ends;
  std::cout << "consumer_adaptors: eigen " << (eigen_ok ? "ok" : "WRONG") << "\n";
  ok = ok && eigen_ok;
#endif
#ifdef CED_CONSUMER_PCL
  ::pcl::PointCloud<::pcl::PointXYZ>::Ptr cloud(new ::pcl::PointCloud<::pcl::PointXYZ>);
  for (int i = 0; i < 50; ++i) cloud->push_back(::pcl::PointXYZ(float(i) * 0.01f, 0.0f, 0.0f));
  ced::pcl::CEDKeypoint3D<::pcl::PointXYZ, ::pcl::PointXYZ> ced3d;
  ced3d.setRadiusSearch(0.05);
  ced3d.setNonMaxRadius(0.05);
  ced3d.setInputCloud(cloud);
  ::pcl::PointCloud<::pcl::PointXYZ> keypoints;
  ced3d.compute(keypoints);
  const auto& indices = ced3d.getKeypointsIndices()->indices;
  const bool pcl_ok = keypoints.size() == 2 && std::vector<std::uint32_t>(indices.begin(), indices.end()) == ends;
  std::cout << "consumer_adaptors: pcl " << (pcl_ok ? "ok" : "WRONG") << "\n";
  ok = ok && pcl_ok;
#endif
#ifdef CED_CONSUMER_OPEN3D
  open3d::geometry::PointCloud o3d;
  for (int i = 0; i < 50; ++i) o3d.points_.emplace_back(double(float(i) * 0.01f), 0.0, 0.0);
  const bool open3d_ok = ced::detect(o3d, ced::detect_params{}, ced::xyz{0.2}).keypoints == ends;
  std::cout << "consumer_adaptors: open3d " << (open3d_ok ? "ok" : "WRONG") << "\n";
  ok = ok && open3d_ok;
#endif
  return ok ? 0 : 1;
}
