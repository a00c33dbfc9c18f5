// Compiles against ced's public headers only: no CGAL include path is given.
#include <ced/ced.hpp>
#include <iostream>

#ifdef CGAL_VERSION
#error "ced's public headers must not include CGAL"
#endif

int main() {
  ced::point_cloud cloud;
  for (int i = 0; i < 50; ++i) cloud.push_back(i * 0.01f, 0.0f, 0.0f);  // a line: its two ends are keypoints
  const auto r = ced::detect(cloud, ced::detect_params{}, ced::xyz{0.2});
  const auto s = ced::detect(cloud, ced::detect_params{}, {ced::make_modality("xyz:0.2")});
  const bool ok = r.keypoints == std::vector<std::uint32_t>{0, 49} && s.keypoints == r.keypoints;
  std::cout << (ok ? "consumer: ok" : "consumer: WRONG") << "\n";
  return ok ? 0 : 1;
}
