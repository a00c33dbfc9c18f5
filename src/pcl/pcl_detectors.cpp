// SPDX-License-Identifier: MIT
// PCL's ISS3D, Harris3D, Harris6D and SIFT as ced detectors.
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/keypoints/harris_3d.h>
#include <pcl/keypoints/harris_6d.h>
#include <pcl/keypoints/iss_3d.h>
#include <pcl/keypoints/sift_keypoint.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "ced/modalities/rgb.hpp"
#include "pcl_bridge.hpp"
#include "pcl_convert.hpp"

namespace ced::pcl_bridge {

pcl_cloud::Ptr to_pcl(const point_cloud& cloud) {
  pcl_cloud::Ptr out(new pcl_cloud);
  out->resize(cloud.size());
  const auto f = find_rgb_fields(cloud);
  std::array<double, 3> scale{0, 0, 0};
  if (f[0]) scale = rgb::scale(f, std::nullopt);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    auto& p = (*out)[i];
    p.x = cloud.position(i)[0];
    p.y = cloud.position(i)[1];
    p.z = cloud.position(i)[2];
    std::uint8_t c[3] = {0, 0, 0};
    if (f[0])
      for (std::size_t k = 0; k < 3; ++k)
        c[k] = static_cast<std::uint8_t>(std::clamp(f[k]->values[i] * scale[k] * 255.0 + 0.5, 0.0, 255.0));
    p.r = c[0];
    p.g = c[1];
    p.b = c[2];
  }
  out->width = static_cast<std::uint32_t>(cloud.size());
  out->height = 1;
  out->is_dense = true;
  return out;
}

void require_pcl() {}  // linked with PCL: nothing to load

namespace {

/// Indices of the input points nearest to each finite output point, ascending, distinct.
template <typename OutPoint>
std::vector<std::uint32_t> nearest_inputs(const pcl_cloud::Ptr& input, const pcl::PointCloud<OutPoint>& output) {
  pcl::KdTreeFLANN<pcl::PointXYZRGB> tree;
  tree.setInputCloud(input);
  std::vector<std::uint32_t> out;
  pcl::Indices idx(1);
  std::vector<float> d2(1);
  for (const auto& q : output) {
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) continue;  // Harris6D emits NaN points
    pcl::PointXYZRGB p;
    p.x = q.x;
    p.y = q.y;
    p.z = q.z;
    if (tree.nearestKSearch(p, 1, idx, d2) == 1) out.push_back(static_cast<std::uint32_t>(idx[0]));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

pcl::PointCloud<pcl::PointXYZRGB> run_iss(const pcl_cloud::Ptr& cloud, const detector_params& p) {
  pcl::ISSKeypoint3D<pcl::PointXYZRGB, pcl::PointXYZRGB> iss;
  iss.setSearchMethod(pcl::search::KdTree<pcl::PointXYZRGB>::Ptr(new pcl::search::KdTree<pcl::PointXYZRGB>));
  iss.setSalientRadius(p.radius);
  iss.setNonMaxRadius(p.nms_radius);
  iss.setThreshold21(p.iss_gamma);
  iss.setThreshold32(p.iss_gamma);
  iss.setMinNeighbors(p.min_neighbors);
  iss.setNumberOfThreads(p.threads);
  iss.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointXYZRGB> out;
  iss.compute(out);
  return out;
}

template <typename Harris>
pcl::PointCloud<pcl::PointXYZI> run_harris(Harris& h, const pcl_cloud::Ptr& cloud, const detector_params& p) {
  h.setSearchMethod(pcl::search::KdTree<pcl::PointXYZRGB>::Ptr(new pcl::search::KdTree<pcl::PointXYZRGB>));
  h.setRadius(p.radius);
  h.setRadiusSearch(p.radius);
  h.setNonMaxSupression(true);
  h.setThreshold(p.harris_threshold);
  h.setNumberOfThreads(p.threads);
  h.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointXYZI> out;
  h.compute(out);
  return out;
}

pcl::PointCloud<pcl::PointWithScale> run_sift(const pcl_cloud::Ptr& cloud, const detector_params& p) {
  pcl::SIFTKeypoint<pcl::PointXYZRGB, pcl::PointWithScale> sift;
  sift.setSearchMethod(pcl::search::KdTree<pcl::PointXYZRGB>::Ptr(new pcl::search::KdTree<pcl::PointXYZRGB>));
  sift.setScales(static_cast<float>(p.sift_min_scale), p.sift_octaves, p.sift_scales_per_octave);
  sift.setMinimumContrast(p.sift_min_contrast);
  sift.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointWithScale> out;
  sift.compute(out);
  return out;
}

}  // namespace

std::vector<std::uint32_t> detect(const point_cloud& cloud, detector d, const detector_params& params) {
  if ((d == detector::harris6d || d == detector::sift) && !cloud.has_rgb())
    throw std::invalid_argument(std::string(d == detector::sift ? "sift" : "harris6d") +
                                " needs colour (red/green/blue fields) and the cloud has none");
  if (cloud.empty()) return {};
  const pcl_cloud::Ptr input = to_pcl(cloud);
  switch (d) {
    case detector::iss3d:
      return nearest_inputs(input, run_iss(input, params));
    case detector::harris3d: {
      pcl::HarrisKeypoint3D<pcl::PointXYZRGB, pcl::PointXYZI> h;
      return nearest_inputs(input, run_harris(h, input, params));
    }
    case detector::harris6d: {
      pcl::HarrisKeypoint6D<pcl::PointXYZRGB, pcl::PointXYZI> h;
      return nearest_inputs(input, run_harris(h, input, params));
    }
    case detector::sift:
      return nearest_inputs(input, run_sift(input, params));
  }
  return {};
}

}  // namespace ced::pcl_bridge
