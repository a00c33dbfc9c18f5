// SPDX-License-Identifier: MIT
// A driver for the paper's own detector (pcl::CEDKeypoint6D of
// UCR-Robotics/CED_Detector, MIT, not part of ced: paper_compare.sh fetches
// and builds it): reads a PCD file of XYZRGB points, detects with the
// paper's settings (radius = NMS radius, thresholds 0.2 and 0.1, min 5
// neighbours), writes the keypoints' indices one a line.
//
//   paper_ced6d CLOUD.pcd KEYPOINTS.txt [RADIUS]
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "ced_6d.h"

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: %s CLOUD.pcd KEYPOINTS.txt [RADIUS]\n", argv[0]);
    return 2;
  }
  const double radius = argc == 4 ? std::atof(argv[3]) : 0.05;
  using PointT = pcl::PointXYZRGB;
  pcl::PointCloud<PointT>::Ptr cloud(new pcl::PointCloud<PointT>);
  if (pcl::io::loadPCDFile<PointT>(argv[1], *cloud) != 0) {
    std::fprintf(stderr, "paper_ced6d: cannot read %s\n", argv[1]);
    return 1;
  }
  pcl::PointCloud<PointT>::Ptr keypoints(new pcl::PointCloud<PointT>);
  pcl::search::KdTree<PointT>::Ptr tree(new pcl::search::KdTree<PointT>);
  pcl::CEDKeypoint6D<PointT, PointT> ced6d;
  ced6d.setSearchMethod(tree);
  ced6d.setRadiusSearch(radius);
  ced6d.setNonMaxRadius(radius);
  ced6d.setCentroidThreshold(0.2);
  ced6d.setCentroidThresholdRGB(0.1);
  ced6d.setMinNeighbors(5);
  ced6d.setInputCloud(cloud);
  ced6d.compute(*keypoints);
  std::ofstream out(argv[2]);
  for (const int i : ced6d.getKeypointsIndices()->indices) out << i << "\n";
  return out.good() ? 0 : 1;
}
