// Compiles against ced::core alone: detection without IO, no CGAL, TBB,
// Eigen, PCL or Open3D include path (the adaptors are separate headers).
#include <ced/core.hpp>
#include <iostream>

#if defined(CGAL_VERSION) || defined(TBB_VERSION_MAJOR) || defined(EIGEN_WORLD_VERSION) || \
    defined(PCL_MAJOR_VERSION) || defined(OPEN3D_VERSION)
#error "ced's core headers must not include CGAL, TBB, Eigen, PCL or Open3D"
#endif

int main() {
  ced::point_cloud cloud;
  for (int i = 0; i < 50; ++i) cloud.push_back(i * 0.01f, 0.0f, 0.0f);  // a line: its two ends are keypoints
  std::vector<double> v(50, 100.0);
  v[20] = 250;  // one bright point: an intensity keypoint in the middle
  cloud.add_field("intensity", ced::scalar_type::uint8, v);
  const auto r = ced::detect(cloud, ced::detect_params{}, ced::xyz{0.2});
  const auto s = ced::detect(cloud, ced::detect_params{}, {ced::make_modality("xyz:0.2")});
  const auto t = ced::detect(cloud, ced::detect_params{}, ced::intensity{0.1});
  const bool ok = r.keypoints == std::vector<std::uint32_t>{0, 49} && s.keypoints == r.keypoints &&
                  t.keypoints == std::vector<std::uint32_t>{20} &&
                  cloud.get_field("intensity").values.data<std::uint8_t>()[20] == 250;
  std::cout << (ok ? "consumer_core: ok" : "consumer_core: WRONG") << "\n";
  return ok ? 0 : 1;
}
