// SPDX-License-Identifier: MIT
// A modality with its own saliency measure (circular hue), used both at
// compile time and from a spec string after registering it.
//
//   example_custom_saliency CLOUD.ply
#include <iostream>

#include "hue_modality.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return std::cerr << "usage: example_custom_saliency CLOUD.ply\n", 2;
  try {
    const ced::point_cloud cloud = ced::io::read_ply(argv[1]);
    ced::detect_params params;

    // Compile time: geometry + circular hue, fused into one pass.
    const auto a = ced::detect(cloud, params, ced::xyz{0.2}, example::hue{0.15});
    std::cout << "xyz + hue (compile time): " << a.keypoints.size() << " keypoints\n";

    // Run time: register once, then use it by name like a built-in.
    ced::register_modality<example::hue>("hue as an angle, circular mean");
    const auto b = ced::detect(cloud, params, {ced::make_modality("xyz:0.2"), ced::make_modality("hue:0.15")});
    std::cout << "xyz + hue (run time):     " << b.keypoints.size() << " keypoints"
              << (a.keypoints == b.keypoints ? " (same)" : " (DIFFERENT)") << "\n";
    return a.keypoints == b.keypoints ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
