// SPDX-License-Identifier: MIT
// The CED paper's registration pipeline on PCL: normals, FPFH or PFHRGB at
// the keypoints, mutual nearest-neighbour matching, SampleConsensusPrerejective.
#include <pcl/features/fpfh.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/features/pfhrgb.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/registration/sample_consensus_prerejective.h>
#include <pcl/search/kdtree.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "core/timing.hpp"
#include "pcl_bridge.hpp"
#include "pcl_convert.hpp"

namespace ced::pcl_bridge {

namespace {

using ced::detail::clock_type;
using ced::detail::ms_since;

using search_tree = pcl::search::KdTree<pcl::PointXYZRGB>;

pcl::PointCloud<pcl::Normal>::Ptr estimate_normals(const pcl_cloud::Ptr& cloud, const std::array<double, 3>& viewpoint,
                                                   const registration_params& p) {
  pcl::NormalEstimationOMP<pcl::PointXYZRGB, pcl::Normal> ne;
  ne.setNumberOfThreads(p.threads);
  ne.setSearchMethod(search_tree::Ptr(new search_tree));
  ne.setRadiusSearch(p.normal_radius);
  ne.setViewPoint(static_cast<float>(viewpoint[0]), static_cast<float>(viewpoint[1]), static_cast<float>(viewpoint[2]));
  ne.setInputCloud(cloud);
  pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
  ne.compute(*normals);
  return normals;
}

/// Keypoints with their descriptors, those with a non-finite descriptor dropped.
template <typename Feature>
struct described {
  pcl_cloud::Ptr points{new pcl_cloud};
  typename pcl::PointCloud<Feature>::Ptr features{new pcl::PointCloud<Feature>};
};

template <typename Feature>
bool finite(const Feature& f) {
  for (float v : f.histogram)
    if (!std::isfinite(v)) return false;
  return true;
}

template <typename Feature, typename Estimator>
described<Feature> describe(Estimator& est, const pcl_cloud::Ptr& cloud, const std::vector<std::uint32_t>& keypoints,
                            const std::array<double, 3>& viewpoint, const registration_params& p) {
  described<Feature> out;
  if (keypoints.empty()) return out;
  const auto normals = estimate_normals(cloud, viewpoint, p);
  pcl::IndicesPtr indices(new pcl::Indices(keypoints.begin(), keypoints.end()));
  est.setSearchMethod(search_tree::Ptr(new search_tree));
  est.setRadiusSearch(p.feature_radius);
  est.setInputCloud(cloud);
  est.setInputNormals(normals);
  est.setIndices(indices);
  pcl::PointCloud<Feature> features;
  est.compute(features);
  for (std::size_t i = 0; i < features.size() && i < keypoints.size(); ++i)
    if (finite(features[i])) {
      out.points->push_back((*cloud)[keypoints[i]]);
      out.features->push_back(features[i]);
    }
  return out;
}

/// (source, target) index pairs that are each other's nearest neighbour in descriptor space.
template <typename Feature>
std::vector<std::pair<int, int>> mutual_matches(const pcl::PointCloud<Feature>& source,
                                                const typename pcl::PointCloud<Feature>::Ptr& source_ptr,
                                                const typename pcl::PointCloud<Feature>::Ptr& target) {
  std::vector<std::pair<int, int>> out;
  if (source.empty() || target->empty()) return out;
  pcl::KdTreeFLANN<Feature> to_target, to_source;
  to_target.setInputCloud(target);
  to_source.setInputCloud(source_ptr);
  pcl::Indices idx(1), back(1);
  std::vector<float> d2(1);
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (to_target.nearestKSearch(source[i], 1, idx, d2) != 1) continue;
    if (to_source.nearestKSearch((*target)[std::size_t(idx[0])], 1, back, d2) != 1) continue;
    if (back[0] == static_cast<int>(i)) out.emplace_back(static_cast<int>(i), idx[0]);
  }
  return out;
}

eval::rigid_transform from_matrix(const Eigen::Matrix4f& m) {
  eval::rigid_transform t;
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 3; ++c) t.rotation[r][c] = m(int(r), int(c));
    t.translation[r] = m(int(r), 3);
  }
  return t;
}

template <typename Feature>
void estimate(const described<Feature>& s, const described<Feature>& t, const registration_params& p,
              registration_result& r) {
  const auto matches = mutual_matches(*s.features, s.features, t.features);
  r.matches = matches.size();
  if (matches.size() < 3) return;  // not enough for a hypothesis: not converged, identity
  described<Feature> ms, mt;       // the matched pairs, in the same order
  for (const auto& [i, j] : matches) {
    ms.points->push_back((*s.points)[std::size_t(i)]);
    ms.features->push_back((*s.features)[std::size_t(i)]);
    mt.points->push_back((*t.points)[std::size_t(j)]);
    mt.features->push_back((*t.features)[std::size_t(j)]);
  }
  pcl::SampleConsensusPrerejective<pcl::PointXYZRGB, pcl::PointXYZRGB, Feature> ransac;
  ransac.setInputSource(ms.points);
  ransac.setSourceFeatures(ms.features);
  ransac.setInputTarget(mt.points);
  ransac.setTargetFeatures(mt.features);
  ransac.setMaximumIterations(p.max_iterations);
  ransac.setNumberOfSamples(3);
  ransac.setCorrespondenceRandomness(1);  // each match's own partner: mutual NN matching above
  ransac.setSimilarityThreshold(static_cast<float>(p.similarity));
  ransac.setMaxCorrespondenceDistance(p.inlier_distance);
  ransac.setInlierFraction(static_cast<float>(p.inlier_fraction));
  std::srand(p.seed);  // PCL draws its samples with std::rand
  pcl_cloud aligned;
  ransac.align(aligned);
  r.converged = ransac.hasConverged();
  r.transform = from_matrix(ransac.getFinalTransformation());
  r.inliers = r.converged ? ransac.getInliers().size() : 0;
}

template <typename Feature, typename Estimator>
registration_result run(const point_cloud& source, const std::vector<std::uint32_t>& ks,
                        const std::array<double, 3>& vs, const point_cloud& target,
                        const std::vector<std::uint32_t>& kt, const std::array<double, 3>& vt,
                        const registration_params& p) {
  registration_result r;
  const auto t0 = clock_type::now();
  Estimator es, et;
  const auto s = describe<Feature>(es, to_pcl(source), ks, vs, p);
  const auto t = describe<Feature>(et, to_pcl(target), kt, vt, p);
  r.source_keypoints = s.points->size();
  r.target_keypoints = t.points->size();
  r.features_ms = ms_since(t0);
  const auto t1 = clock_type::now();
  estimate(s, t, p, r);
  r.ransac_ms = ms_since(t1);
  return r;
}

void check_keypoints(const point_cloud& cloud, const std::vector<std::uint32_t>& k, const char* which) {
  for (std::uint32_t i : k)
    if (i >= cloud.size())
      throw std::out_of_range(std::string(which) + " keypoint index " + std::to_string(i) + " out of range");
}

}  // namespace

registration_result register_keypoints(const point_cloud& source, const std::vector<std::uint32_t>& source_keypoints,
                                       const std::array<double, 3>& source_viewpoint, const point_cloud& target,
                                       const std::vector<std::uint32_t>& target_keypoints,
                                       const std::array<double, 3>& target_viewpoint,
                                       const registration_params& params) {
  if (!(params.normal_radius > 0) || !(params.feature_radius > 0) || !(params.inlier_distance > 0) ||
      params.max_iterations < 1 || !(params.similarity >= 0 && params.similarity < 1) ||
      !(params.inlier_fraction >= 0 && params.inlier_fraction <= 1))
    throw std::invalid_argument(
        "registration: radii and inlier distance must be positive, iterations >= 1, similarity in [0, 1), "
        "inlier fraction in [0, 1]");
  check_keypoints(source, source_keypoints, "source");
  check_keypoints(target, target_keypoints, "target");
  if (params.feature == descriptor::pfhrgb) {
    if (!source.has_rgb() || !target.has_rgb())
      throw std::invalid_argument("the pfhrgb descriptor needs colour (red/green/blue) in both clouds; use fpfh");
    return run<pcl::PFHRGBSignature250, pcl::PFHRGBEstimation<pcl::PointXYZRGB, pcl::Normal, pcl::PFHRGBSignature250>>(
        source, source_keypoints, source_viewpoint, target, target_keypoints, target_viewpoint, params);
  }
  return run<pcl::FPFHSignature33, pcl::FPFHEstimation<pcl::PointXYZRGB, pcl::Normal, pcl::FPFHSignature33>>(
      source, source_keypoints, source_viewpoint, target, target_keypoints, target_viewpoint, params);
}

}  // namespace ced::pcl_bridge
