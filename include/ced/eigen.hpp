// SPDX-License-Identifier: MIT
// Eigen matrices in and out of ced's detector: the optional, header-only
// component `eigen` (find_package(ced COMPONENTS eigen), target ced::eigen,
// which brings Eigen; nothing else in ced includes Eigen).
//
//     Eigen::MatrixX3d points = ...;         // N×3, any storage order
//     Eigen::Matrix<std::uint8_t, -1, 3> colours = ...;
//     auto r = ced::detect(points, {{"rgb", colours}}, ced::detect_params{}, ced::xyz{0.2}, ced::rgb{0.1});
//     Eigen::Map<const Eigen::Matrix<std::uint32_t, -1, 1>> kp = ced::as_eigen(r.keypoints);  // no copy
//
// Where a copy happens:
// - Positions are always copied, into the float rows ced detects on (12 bytes
//   a point). Double input becomes float offsets from an origin, as the file
//   readers do (georeferenced coordinates keep their precision).
// - A channel column is read in place when its values are contiguous (a
//   column of a column-major matrix, a vector, a Map with inner stride 1) and
//   of a storage type (8- to 64-bit integers, float, double); otherwise it is
//   copied, once, into that type (bool to uint8, long double to double). An
//   expression without storage (`m.col(0) * 2`) is evaluated once, when the
//   channel is made.
// - ced::from_eigen() returns a cloud that owns all its values (it copies).
// - Results: as_eigen() maps a result's vectors without copying;
//   saliency_matrix() and keypoint_positions() copy.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "ced/core.hpp"

namespace ced {

namespace detail {
/// The storage type a channel of Eigen scalar T is kept in (storage_type_t).
template <class T>
struct eigen_storage {
  static_assert(std::is_arithmetic_v<T>, "ced: a channel's scalar must be an integer, bool or floating type");
  using type = storage_type_t<T>;
};

template <class Derived>
constexpr bool eigen_direct_v = (int(Eigen::DenseBase<Derived>::Flags) & Eigen::DirectAccessBit) != 0;

/// A matrix's values as bytes with strides, in storage type S: the matrix's
/// own memory when it has direct access and its scalar is S, else an owned
/// column-major copy (`owner`).
struct eigen_block {
  const unsigned char* data = nullptr;
  std::ptrdiff_t row_stride = 0, col_stride = 0;  // in bytes
  std::size_t rows = 0, cols = 0;
  std::shared_ptr<const void> owner;

  template <class S, class Derived>
  static eigen_block of(const Eigen::DenseBase<Derived>& m) {
    eigen_block b;
    b.rows = std::size_t(m.rows());
    b.cols = std::size_t(m.cols());
    if constexpr (eigen_direct_v<Derived> && std::is_same_v<typename Derived::Scalar, S>) {
      b.data = reinterpret_cast<const unsigned char*>(m.derived().data());
      b.row_stride = std::ptrdiff_t(m.derived().rowStride()) * std::ptrdiff_t(sizeof(S));
      b.col_stride = std::ptrdiff_t(m.derived().colStride()) * std::ptrdiff_t(sizeof(S));
    } else {
      auto copy = std::make_shared<Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>>(m.derived().template cast<S>());
      b.data = reinterpret_cast<const unsigned char*>(copy->data());
      b.row_stride = std::ptrdiff_t(sizeof(S));
      b.col_stride = std::ptrdiff_t(sizeof(S)) * std::ptrdiff_t(b.rows);
      b.owner = std::move(copy);
    }
    return b;
  }
};
}  // namespace detail

/// One named channel from an N×k Eigen block of any integer, bool or
/// floating scalar: its k columns become fields named as
/// channel_field_names() says ("rgb" with 3 columns: red, green, blue; "a,b"
/// names each column; else name, or name_0 … name_{k−1}). The channel reads
/// the block's memory in place where it can (see the top of this header), so
/// the block must outlive the detection it is given to.
class eigen_channel {
 public:
  template <class Derived>
  eigen_channel(std::string name, const Eigen::DenseBase<Derived>& values)
      : m_name(std::move(name)),
        m_type(scalar_type_of<typename detail::eigen_storage<typename Derived::Scalar>::type>()),
        m_block(detail::eigen_block::of<typename detail::eigen_storage<typename Derived::Scalar>::type>(values)) {}

  const std::string& name() const noexcept { return m_name; }
  scalar_type type() const noexcept { return m_type; }
  std::size_t rows() const noexcept { return m_block.rows; }
  std::size_t cols() const noexcept { return m_block.cols; }

  /// Adds the channel's fields to `cloud` (of as many points as the block
  /// has rows, else std::invalid_argument naming the channel). With
  /// `in_place`, contiguous aligned columns are views of the block (the
  /// caller keeps it alive as long as the cloud); a copy the channel made
  /// itself is always shared, never copied again.
  void add_to(point_cloud& cloud, bool in_place) const {
    const std::string what = "channels['" + m_name + "']";
    if (m_block.rows != cloud.size())
      throw std::invalid_argument(what + ": " + std::to_string(m_block.rows) + " values, but there are " +
                                  std::to_string(cloud.size()) + " points");
    const auto names = channel_field_names(cloud, m_name, m_block.cols, what);
    const std::size_t size = size_of(m_type);
    for (std::size_t j = 0; j < m_block.cols; ++j) {
      const unsigned char* base = m_block.data + std::ptrdiff_t(j) * m_block.col_stride;
      const bool contiguous = m_block.row_stride == std::ptrdiff_t(size) || m_block.rows <= 1;
      const bool aligned = reinterpret_cast<std::uintptr_t>(base) % size == 0;
      if (contiguous && aligned && (in_place || m_block.owner))
        cloud.add_field(names[j], column::view(m_type, base, m_block.rows, m_block.owner));
      else
        cloud.add_field(names[j], copy_strided(m_type, base, m_block.row_stride, m_block.rows));
    }
  }

 private:
  std::string m_name;
  scalar_type m_type;
  detail::eigen_block m_block;
};

/// Channels by name: `{{"rgb", colours}, {"intensity", intensity}}`.
using eigen_channels = std::vector<eigen_channel>;

namespace detail {
template <class Derived>
point_cloud eigen_cloud(const Eigen::MatrixBase<Derived>& points, const eigen_channels& channels, bool in_place) {
  if (points.cols() != 3)
    throw std::invalid_argument("points: expected an N×3 matrix, got " + std::to_string(points.rows()) + "×" +
                                std::to_string(points.cols()));
  using S = std::conditional_t<std::is_same_v<typename Derived::Scalar, float>, float, double>;
  const eigen_block b = eigen_block::of<S>(points);
  point_cloud cloud;
  set_positions(cloud, scalar_type_of<S>(), b.data, b.data + b.col_stride, b.data + 2 * b.col_stride, b.row_stride,
                b.rows, "points");
  for (const auto& c : channels) c.add_to(cloud, in_place);
  return cloud;
}
}  // namespace detail

/// A cloud from an N×3 matrix of positions (float, double or integers; any
/// storage order and strides) and channels. The cloud owns its values: every
/// column is copied. Throws std::invalid_argument for a matrix that is not
/// N×3, a NaN or infinite coordinate (naming the point), or a channel of
/// another number of rows.
template <class Derived>
point_cloud from_eigen(const Eigen::MatrixBase<Derived>& points, const eigen_channels& channels = {}) {
  return detail::eigen_cloud(points, channels, false);
}

/// ced::detect on an N×3 matrix of positions, with modalities fixed at
/// compile time (same result as on the cloud from_eigen() would give).
template <class Derived, class... M, class = std::enable_if_t<(sizeof...(M) > 0) && (is_modality_v<M> && ...)>>
detection_result detect(const Eigen::MatrixBase<Derived>& points, const detect_params& params, const M&... modalities) {
  return detect(detail::eigen_cloud(points, {}, true), params, modalities...);
}
/// The same with channels: `ced::detect(points, {{"rgb", colours}}, params, ced::xyz{}, ced::rgb{})`.
template <class Derived, class... M, class = std::enable_if_t<(sizeof...(M) > 0) && (is_modality_v<M> && ...)>>
detection_result detect(const Eigen::MatrixBase<Derived>& points, const eigen_channels& channels,
                        const detect_params& params, const M&... modalities) {
  return detect(detail::eigen_cloud(points, channels, true), params, modalities...);
}
/// The same with modalities chosen at run time (ced::preset, ced::make_modality).
template <class Derived>
detection_result detect(const Eigen::MatrixBase<Derived>& points, const detect_params& params,
                        const std::vector<any_modality>& modalities) {
  return detect(detail::eigen_cloud(points, {}, true), params, modalities);
}
template <class Derived>
detection_result detect(const Eigen::MatrixBase<Derived>& points, const eigen_channels& channels,
                        const detect_params& params, const std::vector<any_modality>& modalities) {
  return detect(detail::eigen_cloud(points, channels, true), params, modalities);
}

/// A result's vector as an Eigen column vector, without a copy: keypoints,
/// saliency[m], candidate, neighbor_count, point_radius. Valid while the
/// vector lives and keeps its size.
template <class T>
Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>> as_eigen(const std::vector<T>& v) {
  return Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>>(v.data(), Eigen::Index(v.size()));
}

/// All saliencies as an N×M matrix (column m is modality m), copied.
inline Eigen::MatrixXf saliency_matrix(const detection_result& result) {
  const Eigen::Index n = result.saliency.empty() ? 0 : Eigen::Index(result.saliency[0].size());
  Eigen::MatrixXf s(n, Eigen::Index(result.saliency.size()));
  for (std::size_t m = 0; m < result.saliency.size(); ++m) s.col(Eigen::Index(m)) = as_eigen(result.saliency[m]);
  return s;
}

/// The keypoints' rows of `points` (K×3, in the points' scalar), copied.
template <class Derived>
Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, 3> keypoint_positions(const Eigen::MatrixBase<Derived>& points,
                                                                              const detection_result& result) {
  Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, 3> out(Eigen::Index(result.keypoints.size()), 3);
  for (std::size_t k = 0; k < result.keypoints.size(); ++k)
    out.row(Eigen::Index(k)) = points.row(Eigen::Index(result.keypoints[k]));
  return out;
}

}  // namespace ced
