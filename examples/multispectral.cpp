// SPDX-License-Identifier: MIT
// Multispectral keypoints: geometry + any bands, chosen on the command line.
//
//   example_multispectral CLOUD RADIUS BAND [BAND...]
//   e.g. example_multispectral cloud_multi.ply 0.5 NIR GREEN RED REG
#include <ced/ced.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 4) return std::cerr << "usage: example_multispectral CLOUD RADIUS BAND [BAND...]\n", 2;
  try {
    const ced::point_cloud cloud = ced::io::read_cloud(argv[1]);
    ced::detect_params params;
    params.radius = params.nms_radius = ced::parse_number(argv[2], "RADIUS");
    const ced::bands bands(std::vector<std::string>(argv + 3, argv + argc), 0.1);
    const auto r = ced::detect(cloud, params, ced::xyz{0.2}, bands);
    std::cout << r.keypoints.size() << " keypoints (" << r.names[0] << " + " << r.names[1] << ")\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
