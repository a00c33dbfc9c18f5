// SPDX-License-Identifier: MIT
// The NDVI modality (the fast path) at compile time and from a spec string.
//
//   example_ndvi CLOUD   (a cloud with nir and red fields: LAS 1.4 formats 8
//                         and 10, PLY or CSV with such columns)
#include <ced/ced.hpp>
#include <iostream>

#include "ndvi_modality.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return std::cerr << "usage: example_ndvi CLOUD\n", 2;
  try {
    const ced::point_cloud cloud = ced::io::read_cloud(argv[1]);
    ced::detect_params params;
    params.radius = params.nms_radius = 0.5;

    const auto a = ced::detect(cloud, params, ced::xyz{0.2}, example::ndvi{0.1});
    ced::register_modality<example::ndvi>("NDVI from fields nir and red");
    const auto b = ced::detect(cloud, params, {ced::make_modality("xyz:0.2"), ced::make_modality("ndvi:0.1")});
    std::cout << "xyz + ndvi: " << a.keypoints.size() << " keypoints"
              << (a.keypoints == b.keypoints ? " (the same from strings)" : " (DIFFERENT from strings)") << "\n";
    return a.keypoints == b.keypoints ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
