// SPDX-License-Identifier: MIT
// A reference implementation of CED-3D / CED-6D on PCL, written from the
// paper's description with the same numerical choices as the authors'
// implementation: PCL KdTreeFLANN radius search per point (ascending distance
// order, d² < r²), float centroid sums in that order, integer colour sums,
// a second radius search per candidate for the NMS on the float product.
// Used only to check `ced` index for index on real scans (see
// docs/ALGORITHM.md), and to time PCL's own detectors on the same cloud for
// docs/BENCHMARKS.md; built when PCL is installed.
//
//   pcl_ced CLOUD.ply ced3d|ced6d [radius nms_radius min_neighbors t_g t_c]
//   pcl_ced CLOUD.ply iss3d|harris3d|harris6d [radius]
// prints the keypoint indices (ced) or nothing (PCL detectors), one per line,
// and the count and time on stderr. Single-threaded, as the paper's timings.
#include <pcl/io/ply_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/keypoints/harris_3d.h>
#include <pcl/keypoints/harris_6d.h>
#include <pcl/keypoints/iss_3d.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using cloud_ptr = pcl::PointCloud<pcl::PointXYZRGB>::Ptr;

/// PCL's ISS3D, Harris3D or Harris6D with the paper's settings (its
/// config.yaml): radius 0.05, gamma 0.975, Harris threshold 1e-6.
void run_pcl_detector(const cloud_ptr& cloud, const std::string& method, double radius, double nms_radius,
                      int min_neighbors) {
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t count = 0;
  pcl::search::KdTree<pcl::PointXYZRGB>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZRGB>);
  if (method == "iss3d") {
    pcl::ISSKeypoint3D<pcl::PointXYZRGB, pcl::PointXYZRGB> iss;
    pcl::PointCloud<pcl::PointXYZRGB> out;
    iss.setSearchMethod(tree);
    iss.setSalientRadius(radius);
    iss.setNonMaxRadius(nms_radius);
    iss.setThreshold21(0.975);
    iss.setThreshold32(0.975);
    iss.setMinNeighbors(min_neighbors);
    iss.setNumberOfThreads(1);
    iss.setInputCloud(cloud);
    iss.compute(out);
    count = out.size();
  } else {
    auto harris = [&](auto& h) {
      pcl::PointCloud<pcl::PointXYZI> out;
      h.setSearchMethod(tree);
      h.setRadius(radius);
      h.setRadiusSearch(radius);
      h.setNonMaxSupression(true);
      h.setThreshold(1e-6f);
      h.setNumberOfThreads(1);
      h.setInputCloud(cloud);
      h.compute(out);
      count = out.size();
    };
    if (method == "harris3d") {
      pcl::HarrisKeypoint3D<pcl::PointXYZRGB, pcl::PointXYZI> h;
      harris(h);
    } else {
      pcl::HarrisKeypoint6D<pcl::PointXYZRGB, pcl::PointXYZI> h;
      harris(h);
    }
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "pcl_ced: %s %zu keypoints, %.1f ms\n", method.c_str(), count, ms);
}

/// CED-3D (colour false) or CED-6D as the paper's implementation computes it.
void run_ced(const cloud_ptr& cloud, bool colour, double radius, double nms_radius, int min_neighbors, double t_g,
             double t_c) {
  const auto t0 = std::chrono::steady_clock::now();
  pcl::KdTreeFLANN<pcl::PointXYZRGB> tree;
  tree.setInputCloud(cloud);
  const int n = static_cast<int>(cloud->size());
  std::vector<float> geo(n, 0.0f), col(n, 0.0f);
  std::vector<int> idx;
  std::vector<float> d2;
  for (int i = 0; i < n; ++i) {
    tree.radiusSearch(i, radius, idx, d2);
    const float count = static_cast<float>(idx.size());
    if (count < min_neighbors) continue;
    Eigen::Vector3f g = Eigen::Vector3f::Zero();
    Eigen::Vector3i c = Eigen::Vector3i::Zero();
    for (int j : idx) {
      g += (*cloud)[j].getVector3fMap();
      c += (*cloud)[j].getRGBVector3i();
    }
    g /= count;
    geo[i] = (g - (*cloud)[i].getVector3fMap()).norm();
    const Eigen::Vector3f mean = c.cast<float>() / count;
    col[i] = (mean - (*cloud)[i].getRGBVector3i().cast<float>()).lpNorm<1>() / 255;
  }
  std::vector<int> keypoints;
  for (int i = 0; i < n; ++i) {
    const bool candidate = geo[i] >= t_g * radius || (colour && col[i] >= t_c);
    if (!candidate) continue;
    tree.radiusSearch(i, nms_radius, idx, d2);
    const float si = colour ? geo[i] * col[i] : geo[i];
    bool maximum = true;
    for (int j : idx)
      if (si < (colour ? geo[j] * col[j] : geo[j])) {
        maximum = false;
        break;
      }
    if (maximum) keypoints.push_back(i);
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  for (int k : keypoints) std::printf("%d\n", k);
  std::fprintf(stderr, "pcl_ced: %zu keypoints, %.1f ms\n", keypoints.size(), ms);
}

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: pcl_ced CLOUD.ply ced3d|ced6d [radius nms_radius min_neighbors t_g t_c]\n");
    return 2;
  }
  const bool colour = std::string(argv[2]) == "ced6d";
  const double radius = argc > 3 ? std::atof(argv[3]) : 0.05;
  const double nms_radius = argc > 4 ? std::atof(argv[4]) : 0.05;
  const int min_neighbors = argc > 5 ? std::atoi(argv[5]) : 5;
  const double t_g = argc > 6 ? std::atof(argv[6]) : 0.2;
  const double t_c = argc > 7 ? std::atof(argv[7]) : 0.1;

  pcl::PointCloud<pcl::PointXYZRGB>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZRGB>);
  if (pcl::io::loadPLYFile(argv[1], *cloud) != 0) return 1;
  const std::string method = argv[2];
  if (method == "iss3d" || method == "harris3d" || method == "harris6d")
    run_pcl_detector(cloud, method, radius, nms_radius, min_neighbors);
  else
    run_ced(cloud, colour, radius, nms_radius, min_neighbors, t_g, t_c);
  return 0;
}
