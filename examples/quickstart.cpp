// The README's 10-line example: CED-6D on any supported file, modalities fixed at compile time.
#include <ced/ced.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 2) return std::cerr << "usage: example_quickstart CLOUD\n", 2;
  const ced::point_cloud cloud = ced::io::read_cloud(argv[1]);  // PLY, PCD, LAS, CSV
  ced::detect_params params;                                    // radius 0.05, NMS radius 0.05, min_neighbors 5
  const auto result = ced::detect(cloud, params, ced::xyz{0.2}, ced::rgb{0.1});
  std::cout << result.keypoints.size() << " keypoints in " << result.times.total_ms() << " ms\n";
  for (auto i : result.keypoints)
    std::cout << i << ' ' << result.saliency[0][i] << ' ' << result.saliency[1][i] << '\n';
}
