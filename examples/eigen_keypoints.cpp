// SPDX-License-Identifier: MIT
// Keypoints of a cloud held as Eigen matrices: positions N×3 and colours N×3
// (any scalar, any storage order). Needs the `eigen` component
// (find_package(ced COMPONENTS eigen)). The matrices are filled from a file
// here; in a real program they come from your own code.
//
//   example_eigen_keypoints scan.ply
#include <ced/ced.hpp>
#include <ced/eigen.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: example_eigen_keypoints CLOUD.ply\n";
    return 2;
  }
  const ced::point_cloud file = ced::io::read_cloud(argv[1]);
  const auto rgb = ced::find_rgb_fields(file);
  if (!rgb[0]) {
    std::cerr << argv[1] << " has no colour\n";
    return 1;
  }
  Eigen::MatrixX3d points(Eigen::Index(file.size()), 3);
  Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> colours(Eigen::Index(file.size()), 3);
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      points(i, k) = file.origin()[std::size_t(k)] + file.position(std::size_t(i))[k];
      colours(i, k) = std::uint8_t((*rgb[std::size_t(k)]).values[std::size_t(i)]);
    }

  const ced::detect_params params;  // the paper's: radius 0.05, NMS 0.05, min_neighbors 5
  const ced::detection_result r = ced::detect(points, {{"rgb", colours}}, params, ced::xyz{0.2}, ced::rgb{0.1});

  const auto keypoints = ced::as_eigen(r.keypoints);               // no copy
  const Eigen::MatrixX3d at = ced::keypoint_positions(points, r);  // their rows of `points`
  const Eigen::MatrixXf saliency = ced::saliency_matrix(r);        // N × 2: geometry, colour
  std::cout << keypoints.size() << " keypoints of " << points.rows() << " points\n";
  for (Eigen::Index k = 0; k < std::min<Eigen::Index>(keypoints.size(), 5); ++k)
    std::cout << keypoints(k) << " at " << at.row(k) << ", saliency " << saliency.row(keypoints(k)) << "\n";
  return 0;
}
