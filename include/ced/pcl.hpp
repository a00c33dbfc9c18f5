// SPDX-License-Identifier: MIT
// PCL clouds in and out of ced's detector, and a drop-in for the paper's PCL
// classes: the optional, header-only component `pcl`
// (find_package(ced COMPONENTS pcl), target ced::pcl, which brings PCL's
// common, search, kdtree and keypoints libraries; nothing else in ced
// includes PCL).
//
//     pcl::PointCloud<pcl::PointXYZRGB> cloud = ...;
//     ced::detection_result r = ced::detect(cloud, ced::detect_params{}, ced::preset("ced6d"));
//     pcl::PointIndices kp = ced::to_pcl_indices(r);
//     pcl::PointCloud<pcl::PointXYZRGB> keypoints = ced::keypoint_cloud(cloud, r);
//
// or, for code written against UCR-Robotics/CED_Detector, change
// `#include "ced_6d.h"` to `#include <ced/pcl.hpp>` and `pcl::CEDKeypoint6D`
// to `ced::pcl::CEDKeypoint6D`:
//
//     ced::pcl::CEDKeypoint6D<PointT, PointT> ced6d;
//     ced6d.setRadiusSearch(0.05);
//     ced6d.setNonMaxRadius(0.05);
//     ced6d.setCentroidThreshold(0.2);
//     ced6d.setCentroidThresholdRGB(0.1);
//     ced6d.setMinNeighbors(5);
//     ced6d.setInputCloud(cloud);
//     ced6d.compute(*keypoints);  // ced6d.getKeypointsIndices() gives their indices
//
// Fields (ced::from_pcl): x, y, z are the positions; a packed `rgb` (float)
// or `rgba` (uint32) becomes uint8 fields red, green, blue (and alpha for
// rgba), as PCL packs them; every other registered field (intensity,
// normal_x…, curvature, label, a custom field) keeps its name and type, an
// array field of k values becomes name_0 … name_{k−1}. Every field is copied
// out of the point structs, since ced's columns are contiguous (a strided
// view would slow the neighbour sums).
//
// Inside namespace ced, `pcl` names ced::pcl: write ::pcl there.
#pragma once

#include <pcl/PointIndices.h>
#include <pcl/common/copy_point.h>
#include <pcl/console/print.h>
#include <pcl/for_each_type.h>
#include <pcl/keypoints/keypoint.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/type_traits.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"

namespace ced {

namespace detail {
/// Adds one registered PCL field (for_each_type's functor) to a ced cloud.
template <class PointT>
struct pcl_field_adder {
  const ::pcl::PointCloud<PointT>* in;
  point_cloud* out;

  template <class Tag>
  void operator()() const {
    const std::string name = ::pcl::traits::name<PointT, Tag>::value;
    const std::size_t offset = ::pcl::traits::offset<PointT, Tag>::value;
    using datatype = ::pcl::traits::datatype<PointT, Tag>;
    using T = typename datatype::decomposed::type;
    const std::size_t count = datatype::size;
    const auto* base = reinterpret_cast<const unsigned char*>(in->points.data()) + offset;
    const std::size_t n = in->size();
    if (name == "x" || name == "y" || name == "z") return;
    if ((name == "rgb" || name == "rgba") && sizeof(T) == 4 && count == 1) {
      add_packed_colour(base, n, name == "rgba");
      return;
    }
    if constexpr (std::is_same_v<T, float> || std::is_same_v<T, double> ||
                  (std::is_integral_v<T> && !std::is_same_v<T, bool>)) {
      const scalar_type type = scalar_type_of<storage_type_t<T>>();
      for (std::size_t j = 0; j < count; ++j) {
        const std::string field = count == 1 ? name : name + "_" + std::to_string(j);
        out->add_field(field, copy_strided(type, base + j * sizeof(T), std::ptrdiff_t(sizeof(PointT)), n));
      }
    }
  }

  void add_packed_colour(const unsigned char* base, std::size_t n, bool alpha) const {
    const char* names[4] = {"red", "green", "blue", "alpha"};
    const int shifts[4] = {16, 8, 0, 24};
    for (int c = 0; c < (alpha ? 4 : 3); ++c) {
      column col(scalar_type::uint8, n);
      std::uint8_t* v = col.data<std::uint8_t>();
      for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t packed;
        std::memcpy(&packed, base + i * sizeof(PointT), 4);
        v[i] = std::uint8_t((packed >> shifts[c]) & 0xffu);
      }
      out->add_field(names[c], std::move(col));
    }
  }
};
}  // namespace detail

/// A ced cloud from a PCL cloud of any registered point type with x, y, z
/// (see the top of this header for the fields). Point i of the result is
/// point i of `in`. Throws std::invalid_argument naming the point when a
/// coordinate is NaN or infinite (remove them first with
/// pcl::removeNaNFromPointCloud; the CEDKeypoint classes skip them).
template <class PointT>
point_cloud from_pcl(const ::pcl::PointCloud<PointT>& in) {
  static_assert(::pcl::traits::has_xyz_v<PointT>, "ced::from_pcl: the point type has no x, y, z");
  point_cloud cloud;
  const auto* base = reinterpret_cast<const unsigned char*>(in.points.data());
  constexpr std::size_t x = ::pcl::traits::offset<PointT, ::pcl::fields::x>::value;
  constexpr std::size_t y = ::pcl::traits::offset<PointT, ::pcl::fields::y>::value;
  constexpr std::size_t z = ::pcl::traits::offset<PointT, ::pcl::fields::z>::value;
  set_positions(cloud, scalar_type::float32, base + x, base + y, base + z, std::ptrdiff_t(sizeof(PointT)), in.size(),
                "PCL cloud");
  ::pcl::for_each_type<typename ::pcl::traits::fieldList<PointT>::type>(detail::pcl_field_adder<PointT>{&in, &cloud});
  return cloud;
}

/// ced::detect on a PCL cloud (see from_pcl()), modalities fixed at compile time.
template <class PointT, class... M, class = std::enable_if_t<(sizeof...(M) > 0) && (is_modality_v<M> && ...)>>
detection_result detect(const ::pcl::PointCloud<PointT>& cloud, const detect_params& params, const M&... modalities) {
  return detect(from_pcl(cloud), params, modalities...);
}
/// ced::detect on a PCL cloud, modalities chosen at run time (ced::preset, ced::make_modality).
template <class PointT>
detection_result detect(const ::pcl::PointCloud<PointT>& cloud, const detect_params& params,
                        const std::vector<any_modality>& modalities) {
  return detect(from_pcl(cloud), params, modalities);
}

/// The keypoints' indices as pcl::PointIndices.
inline ::pcl::PointIndices to_pcl_indices(const detection_result& result) {
  ::pcl::PointIndices out;
  out.indices.assign(result.keypoints.begin(), result.keypoints.end());
  return out;
}

/// The keypoints' points of `cloud`, in index order, with the cloud's header.
template <class PointT>
::pcl::PointCloud<PointT> keypoint_cloud(const ::pcl::PointCloud<PointT>& cloud, const detection_result& result) {
  ::pcl::PointCloud<PointT> out;
  out.header = cloud.header;
  out.points.reserve(result.keypoints.size());
  for (std::uint32_t i : result.keypoints) out.points.push_back(cloud.points[i]);
  out.width = std::uint32_t(out.points.size());
  out.height = 1;
  out.is_dense = true;
  return out;
}

namespace pcl {

/// A PCL keypoint detector (pcl::Keypoint) running ced with any list of
/// modalities (setModalities; ced's xyz alone by default). The
/// neighbourhood radius is setRadiusSearch's, the NMS radius
/// setNonMaxRadius's. compute() fills the output with the keypoints' points
/// (every field the two point types share, pcl::copyPoint) and
/// getKeypointsIndices() with their indices in the input.
///
/// Differences from a PCL detector, and from the paper's classes:
/// - No search tree is built: setSearchMethod is accepted and ignored, and
///   so are setSearchSurface and setIndices (as the paper's classes ignore
///   them). setKSearch is refused: see setNeighborhood for k nearest.
/// - Points with a NaN or infinite coordinate are never keypoints and are
///   no one's neighbours (PCL's kd-tree skips them too).
/// - Errors are PCL's: PCL_ERROR and an empty output, as the paper's
///   classes do. getResult() keeps ced's whole result (saliencies,
///   candidates, neighbour counts), indexed like the input.
template <typename PointInT, typename PointOutT>
class CEDKeypoint : public ::pcl::Keypoint<PointInT, PointOutT> {
 public:
  using Ptr = std::shared_ptr<CEDKeypoint<PointInT, PointOutT>>;
  using ConstPtr = std::shared_ptr<const CEDKeypoint<PointInT, PointOutT>>;
  using PointCloudIn = typename ::pcl::Keypoint<PointInT, PointOutT>::PointCloudIn;
  using PointCloudOut = typename ::pcl::Keypoint<PointInT, PointOutT>::PointCloudOut;

  CEDKeypoint() { this->name_ = "CEDKeypoint"; }

  /// The modalities, in NMS order (each with its own threshold).
  void setModalities(std::vector<any_modality> modalities) { m_modalities = std::move(modalities); }
  /// The NMS radius (metres). The paper's classes require it; 0 = the search radius here.
  void setNonMaxRadius(double non_max_radius) { m_non_max_radius = non_max_radius; }
  /// Points with fewer neighbours (themselves included) get saliency 0.
  void setMinNeighbors(int min_neighbors) { m_min_neighbors = min_neighbors; }
  /// Worker threads, 0 = all cores (the paper's classes: one). The keypoints do not depend on it.
  void setNumberOfThreads(unsigned int threads) { m_params.threads = threads; }
  /// A neighbourhood spec: "radius" (default), "knn:K", "adaptive:K,..."
  /// (ced::parse_neighborhood; docs/ALGORITHM.md#neighbourhoods).
  void setNeighborhood(const std::string& spec) { m_params.neighborhood = parse_neighborhood(spec); }
  /// Every other parameter of ced (refinement, max_keypoints, ...); the
  /// radii and min_neighbors set above override its own.
  void setParams(const detect_params& params) { m_params = params; }

  /// The whole result of the last compute(), indexed like its input.
  const detection_result& getResult() const noexcept { return m_result; }

 protected:
  using ::pcl::Keypoint<PointInT, PointOutT>::name_;
  using ::pcl::Keypoint<PointInT, PointOutT>::input_;
  using ::pcl::Keypoint<PointInT, PointOutT>::search_radius_;
  using ::pcl::Keypoint<PointInT, PointOutT>::k_;
  using ::pcl::Keypoint<PointInT, PointOutT>::keypoints_indices_;

  /// The modalities compute() runs.
  virtual std::vector<any_modality> modalities() const {
    return m_modalities.empty() ? std::vector<any_modality>{ced::xyz{}} : m_modalities;
  }

  bool initCompute() override {
    if (!::pcl::PCLBase<PointInT>::initCompute()) return false;
    const double nms = non_max_radius();
    std::string problem;
    if (k_ != 0)
      problem = "k nearest neighbours are set with setNeighborhood(\"knn:K\"), not setKSearch";
    else if (!(search_radius_ > 0) || !std::isfinite(search_radius_))
      problem = "the search radius (setRadiusSearch) must be positive";
    else if (!(m_non_max_radius >= 0) || !std::isfinite(m_non_max_radius))
      problem = "the non maxima radius (setNonMaxRadius) must be positive, or 0 for the search radius";
    else if (m_min_neighbors < 0)
      problem = "the minimum number of neighbors (setMinNeighbors) must not be negative";
    else
      problem = check_thresholds(nms);
    if (!problem.empty()) {
      ::pcl::console::print(::pcl::console::L_ERROR, "[ced::pcl::%s::initCompute] %s\n", name_.c_str(),
                            problem.c_str());
      return false;
    }
    keypoints_indices_.reset(new ::pcl::PointIndices);
    return true;
  }

  void detectKeypoints(PointCloudOut& output) override {
    output.clear();
    m_result = {};
    try {
      detect_params p = m_params;
      p.radius = search_radius_;
      p.nms_radius = non_max_radius();
      p.min_neighbors = std::uint32_t(m_min_neighbors);
      m_result = run(p);
    } catch (const std::exception& e) {
      ::pcl::console::print(::pcl::console::L_ERROR, "[ced::pcl::%s::detectKeypoints] %s\n", name_.c_str(), e.what());
      m_result = {};
      return;
    }
    output.reserve(m_result.keypoints.size());
    keypoints_indices_->indices.reserve(m_result.keypoints.size());
    for (std::uint32_t i : m_result.keypoints) {
      PointOutT q;
      ::pcl::copyPoint((*input_)[i], q);
      output.push_back(q);
      keypoints_indices_->indices.push_back(int(i));
    }
    output.header = input_->header;
    output.height = 1;
    output.width = std::uint32_t(output.size());
    output.is_dense = input_->is_dense;
  }

 private:
  /// The NMS radius: setNonMaxRadius's, or the search radius when it is 0.
  double non_max_radius() const noexcept { return m_non_max_radius > 0 ? m_non_max_radius : search_radius_; }

  /// What is wrong with the modalities' thresholds at these radii (a
  /// negative or non-finite centroid threshold), or "" when nothing is:
  /// checked before the detection, so that the output is left alone.
  std::string check_thresholds(double nms) const {
    detect_params p = m_params;
    p.radius = search_radius_;
    p.nms_radius = nms;
    try {
      for (const auto& m : modalities()) {
        const double t = m.threshold(p);
        if (!std::isfinite(t) || t < 0)
          return "the threshold of modality '" + m.name() +
                 "' (setCentroidThreshold, setCentroidThresholdRGB, setModalities) must be a finite number >= 0";
      }
    } catch (const std::exception& e) {
      return e.what();
    }
    return {};
  }

  /// Detection on the finite points, mapped back to the input's indices.
  detection_result run(const detect_params& p) const {
    const PointCloudIn& in = *input_;
    if (in.is_dense) return detect(from_pcl(in), p, modalities());
    std::vector<std::uint32_t> finite;
    for (std::size_t i = 0; i < in.size(); ++i)
      if (std::isfinite(in[i].x) && std::isfinite(in[i].y) && std::isfinite(in[i].z))
        finite.push_back(std::uint32_t(i));
    if (finite.size() == in.size()) return detect(from_pcl(in), p, modalities());
    if (finite.empty()) return no_keypoints(in.size());
    PointCloudIn dense;
    dense.points.reserve(finite.size());
    for (std::uint32_t i : finite) dense.points.push_back(in[i]);
    dense.width = std::uint32_t(finite.size());
    dense.height = 1;
    detection_result r = detect(from_pcl(dense), p, modalities());
    return spread(std::move(r), finite, in.size());
  }

  /// A result on the finite points, indexed like the whole input (0 elsewhere).
  static detection_result spread(detection_result r, const std::vector<std::uint32_t>& at, std::size_t n) {
    for (auto& k : r.keypoints) k = at[k];
    const auto widen = [&](auto& v) {
      using V = std::decay_t<decltype(v)>;
      if (v.empty()) return;
      V all(n, typename V::value_type{});
      for (std::size_t q = 0; q < at.size(); ++q) all[at[q]] = v[q];
      v = std::move(all);
    };
    for (auto& s : r.saliency) widen(s);
    widen(r.candidate);
    widen(r.neighbor_count);
    widen(r.point_radius);
    return r;
  }

  /// Every point non-finite: nothing to detect.
  detection_result no_keypoints(std::size_t n) const {
    detection_result r;
    r.candidate.assign(n, 0);
    r.neighbor_count.assign(n, 0);
    return r;
  }

  std::vector<any_modality> m_modalities;
  detect_params m_params;
  double m_non_max_radius = 0.0;
  int m_min_neighbors = 5;
  detection_result m_result;
};

/// The paper's CED-3D (geometry only), as UCR-Robotics/CED_Detector's
/// pcl::CEDKeypoint3D: the same setters and defaults (centroid threshold
/// 0.2), ced's speed. setModalities is not for this class (use CEDKeypoint).
template <typename PointInT, typename PointOutT>
class CEDKeypoint3D : public CEDKeypoint<PointInT, PointOutT> {
 public:
  using Ptr = std::shared_ptr<CEDKeypoint3D<PointInT, PointOutT>>;
  using ConstPtr = std::shared_ptr<const CEDKeypoint3D<PointInT, PointOutT>>;
  CEDKeypoint3D() { this->name_ = "CEDKeypoint3D"; }
  /// Threshold on the ratio of the centroid distance to the search radius.
  void setCentroidThreshold(double centroid_threshold) { m_geometry = centroid_threshold; }

 protected:
  std::vector<any_modality> modalities() const override { return {ced::xyz{m_geometry}}; }

 private:
  double m_geometry = 0.2;
};

/// The paper's CED-6D (geometry and colour), as UCR-Robotics/CED_Detector's
/// pcl::CEDKeypoint6D: the same setters and defaults (centroid threshold
/// 0.2; colour threshold 0.05, the class's default, where the paper's
/// configuration sets 0.1). The point type must have colour.
template <typename PointInT, typename PointOutT>
class CEDKeypoint6D : public CEDKeypoint<PointInT, PointOutT> {
  static_assert(::pcl::traits::has_color_v<PointInT>, "ced::pcl::CEDKeypoint6D: the point type has no colour");

 public:
  using Ptr = std::shared_ptr<CEDKeypoint6D<PointInT, PointOutT>>;
  using ConstPtr = std::shared_ptr<const CEDKeypoint6D<PointInT, PointOutT>>;
  CEDKeypoint6D() { this->name_ = "CEDKeypoint6D"; }
  /// Threshold on the ratio of the centroid distance to the search radius.
  void setCentroidThreshold(double centroid_threshold) { m_geometry = centroid_threshold; }
  /// Threshold on the L1 colour distance, channels scaled to [0, 1].
  void setCentroidThresholdRGB(double centroid_threshold_rgb) { m_colour = centroid_threshold_rgb; }

 protected:
  std::vector<any_modality> modalities() const override { return {ced::xyz{m_geometry}, ced::rgb{m_colour}}; }

 private:
  double m_geometry = 0.2;
  double m_colour = 0.05;
};

}  // namespace pcl
}  // namespace ced
