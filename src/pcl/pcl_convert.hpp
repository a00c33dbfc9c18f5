// SPDX-License-Identifier: MIT
// ced::point_cloud → pcl::PointCloud<pcl::PointXYZRGB> (private to ced_pcl).
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "ced/cloud.hpp"

namespace ced::pcl_bridge {

using pcl_cloud = pcl::PointCloud<pcl::PointXYZRGB>;

/// Positions as stored (relative to the cloud's origin); red/green/blue
/// scaled to 0..255 as the rgb modality reads them, 0 without colour.
pcl_cloud::Ptr to_pcl(const point_cloud& cloud);

}  // namespace ced::pcl_bridge
