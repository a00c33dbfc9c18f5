// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include "ced/cloud.hpp"

namespace ced {

/// Removes points with a NaN or infinite coordinate (fields follow). Returns
/// the original index of every kept point.
std::vector<std::uint32_t> remove_nonfinite(point_cloud& cloud);

/// The result of voxel down-sampling.
struct voxel_result {
  point_cloud cloud;                          ///< one point per occupied voxel
  std::vector<std::uint32_t> representative;  ///< per output point: the input point nearest its centroid
  std::vector<std::uint32_t> counts;          ///< per output point: input points averaged
};

/// Voxel-grid down-sampling as PCL's VoxelGrid: cells at floor(p · (1/size))
/// computed in float, one output point per occupied cell, ordered by cell
/// index (x fastest, then y, then z). Positions are the mean of the cell's
/// points; every field is averaged too (integer fields truncated toward zero,
/// as PCL does for colour). Throws std::invalid_argument for a size ≤ 0 or
/// not finite, non-finite coordinates, or a grid too fine for the extent.
voxel_result voxel_downsample(const point_cloud& cloud, double size);

/// The cloud's resolution: the median distance from a point to its nearest
/// other point, over up to `max_samples` points spread evenly through the
/// cloud (deterministic). Samples with a coincident twin are left out; when
/// every sample has one (each point stored several times), the distance to
/// the nearest point at another position counts instead. 0 for clouds of
/// fewer than two distinct points.
double estimate_resolution(const point_cloud& cloud, std::size_t max_samples = 20000);

/// How many points share their position with another point (coincident
/// points: invalid returns stored at one place, a scan merged with itself).
/// Positions compare as floats (-0 equals +0); 0 when every point is alone.
std::size_t coincident_points(const point_cloud& cloud);

/// Quantiles `q` (each in [0, 1]) of the distance from a point to its k-th
/// nearest point, the point itself counted first (knn:k's own radius, see
/// neighborhood_spec), over up to `max_samples` points spread evenly
/// through the cloud (deterministic): to choose K for --neighborhood.
/// Throws std::invalid_argument for k < 1, k larger than the cloud, or a
/// quantile outside [0, 1].
std::vector<double> k_distance_quantiles(const point_cloud& cloud, std::size_t k, const std::vector<double>& q,
                                         std::size_t max_samples = 20000);

}  // namespace ced
