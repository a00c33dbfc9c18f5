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
#include <tuple>
#include <type_traits>
#include <utility>

#include "ced/detect.hpp"
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

/// The input point nearest to each finite output point, with the output's
/// response (0 without one).
template <typename OutPoint>
std::vector<std::pair<std::uint32_t, float>> nearest_with_response(const pcl_cloud::Ptr& input,
                                                                   const pcl::PointCloud<OutPoint>& output) {
  pcl::KdTreeFLANN<pcl::PointXYZRGB> tree;
  tree.setInputCloud(input);
  std::vector<std::pair<std::uint32_t, float>> out;
  pcl::Indices idx(1);
  std::vector<float> d2(1);
  for (const auto& q : output) {
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) continue;  // Harris6D emits NaN points
    pcl::PointXYZRGB p;
    p.x = q.x;
    p.y = q.y;
    p.z = q.z;
    float response = 0;
    if constexpr (std::is_same_v<OutPoint, pcl::PointXYZI>) response = q.intensity;
    if (tree.nearestKSearch(p, 1, idx, d2) == 1) out.emplace_back(static_cast<std::uint32_t>(idx[0]), response);
  }
  return out;
}

/// Indices of the input points nearest to each finite output point,
/// ascending, distinct; with max_keypoints > 0, the strongest by response
/// (a point several outputs map to keeps the highest).
template <typename OutPoint>
std::vector<std::uint32_t> nearest_inputs(const pcl_cloud::Ptr& input, const pcl::PointCloud<OutPoint>& output,
                                          std::size_t max_keypoints = 0) {
  auto found = nearest_with_response(input, output);
  // By index, the highest response first among equal indices: unique keeps it.
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first != b.first ? a.first < b.first : a.second > b.second; });
  found.erase(std::unique(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
              found.end());
  std::vector<std::uint32_t> out(found.size());
  std::vector<float> response(found.size());
  for (std::size_t q = 0; q < found.size(); ++q) std::tie(out[q], response[q]) = found[q];
  if (max_keypoints) out = strongest(out, response, max_keypoints);
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
      return nearest_inputs(input, run_iss(input, params));  // no response: its natural count
    case detector::harris3d: {
      pcl::HarrisKeypoint3D<pcl::PointXYZRGB, pcl::PointXYZI> h;
      return nearest_inputs(input, run_harris(h, input, params), params.max_keypoints);
    }
    case detector::harris6d: {
      pcl::HarrisKeypoint6D<pcl::PointXYZRGB, pcl::PointXYZI> h;
      return nearest_inputs(input, run_harris(h, input, params), params.max_keypoints);
    }
    case detector::sift:
      return nearest_inputs(input, run_sift(input, params));
  }
  return {};
}

}  // namespace ced::pcl_bridge
