// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
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

/// Multispectral LiDAR delivers each wavelength as its own point set (three
/// LAS files for an Optech Titan). merge_channels() gives every point of a
/// `reference` channel the fields of its nearest point in each other
/// channel, as OPALS' preMergeChannels does before any per-point analysis.
struct channel_merge_options {
  /// A partner lies strictly within this distance (metres; > 0).
  double radius = 0;
  /// Taken from each other channel, named `FIELD_CHANNEL` in the result.
  std::vector<std::string> fields = {"intensity"};
  /// A reference point with no partner in some channel: dropped from the
  /// result (the merged fields keep their files' types), or kept with NaN
  /// in that channel's fields (then float32; `bands` refuses NaN, so filter
  /// them before detecting).
  enum class missing { drop, nan } when_missing = missing::drop;
  unsigned threads = 0;  ///< 0 = all cores; the result does not depend on it
};
/// One other channel: its name (in the merged fields' names) and its points.
struct named_channel {
  std::string name;
  const point_cloud* cloud = nullptr;
};
/// What merge_channels() did, to be said to the user.
struct channel_merge_report {
  std::vector<std::size_t> partnered;  ///< per other channel: reference points with a partner
  std::size_t dropped = 0;             ///< reference points dropped (missing::drop)
};
/// The reference cloud with, for each other channel and each of
/// options.fields, a field `FIELD_NAME`: the value at the channel's point
/// nearest to the reference point (in absolute coordinates: the clouds'
/// origins may differ), within options.radius; ties to the smaller index.
/// Reference points with a non-finite coordinate have no partner. Throws
/// std::invalid_argument for a radius ≤ 0 or not finite, a channel without
/// a field, an empty or repeated channel name, or a merged name the
/// reference already has.
point_cloud merge_channels(const point_cloud& reference, const std::vector<named_channel>& others,
                           const channel_merge_options& options, channel_merge_report* report = nullptr);

}  // namespace ced
