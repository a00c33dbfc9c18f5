// SPDX-License-Identifier: MIT
// The paper's PCL flow with ced's drop-in class: code written against
// UCR-Robotics/CED_Detector's pcl::CEDKeypoint6D changes only its include and
// namespace. Needs the `pcl` component (find_package(ced COMPONENTS pcl)).
//
//   example_pcl_keypoints scan.ply
#include <pcl/filters/filter.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <ced/pcl.hpp>  // was: #include "ced_6d.h"
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: example_pcl_keypoints CLOUD.ply\n";
    return 2;
  }
  using PointT = pcl::PointXYZRGB;
  pcl::PointCloud<PointT>::Ptr cloud(new pcl::PointCloud<PointT>);
  pcl::PointCloud<PointT>::Ptr keypoints(new pcl::PointCloud<PointT>);
  if (pcl::io::loadPLYFile(argv[1], *cloud) != 0) return 1;
  pcl::Indices kept;
  pcl::removeNaNFromPointCloud(*cloud, *cloud, kept);

  ced::pcl::CEDKeypoint6D<PointT, PointT> ced6d;  // was: pcl::CEDKeypoint6D<PointT, PointT>
  ced6d.setRadiusSearch(0.05);                    // metres, for a cloud at 1 cm
  ced6d.setNonMaxRadius(0.05);
  ced6d.setCentroidThreshold(0.2);     // geometry: ratio of the radius
  ced6d.setCentroidThresholdRGB(0.1);  // colour: L1 in [0, 1] per channel
  ced6d.setMinNeighbors(5);
  ced6d.setNumberOfThreads(0);  // all cores; the keypoints do not change
  ced6d.setInputCloud(cloud);
  ced6d.compute(*keypoints);

  std::cout << keypoints->size() << " keypoints of " << cloud->size() << " points\n";
  for (int i : ced6d.getKeypointsIndices()->indices) std::cout << i << '\n';
  return 0;
}
