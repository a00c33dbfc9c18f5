// Compiles against ced's public headers only: no CGAL include path is given.
// ced/ced.hpp is the whole library: detection and IO.
#include <ced/ced.hpp>
#include <cstdio>
#include <iostream>

#if defined(CGAL_VERSION) || defined(TBB_VERSION_MAJOR)
#error "ced's public headers must not include CGAL or TBB"
#endif

int main() {
  ced::point_cloud cloud;
  for (int i = 0; i < 50; ++i) cloud.push_back(i * 0.01f, 0.0f, 0.0f);  // a line: its two ends are keypoints
  std::vector<std::array<std::uint8_t, 3>> rgb(50, {10, 20, 30});
  cloud.add_rgb(rgb);
  const std::string path = "consumer_line.ply";
  ced::io::write_cloud(path, cloud);  // IO from the umbrella header alone
  const ced::point_cloud back = ced::io::read_cloud(path);
  std::remove(path.c_str());
  const auto r = ced::detect(back, ced::detect_params{}, ced::xyz{0.2});
  const auto s = ced::detect(back, ced::detect_params{}, {ced::make_modality("xyz:0.2")});
  const bool ok = back.size() == 50 && back.has_rgb() && r.keypoints == std::vector<std::uint32_t>{0, 49} &&
                  s.keypoints == r.keypoints;
  std::cout << (ok ? "consumer: ok" : "consumer: WRONG") << "\n";
  return ok ? 0 : 1;
}
