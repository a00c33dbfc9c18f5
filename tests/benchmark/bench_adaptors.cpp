// SPDX-License-Identifier: MIT
// What the adaptors (ced/eigen.hpp, ced/pcl.hpp, ced/open3d.hpp) cost beyond
// the detection: loft_mesh_240 (105,179 points, tests/data) as each library
// holds it, converted alone (`from_*`) and detected with CED-6D on one
// thread, beside the detection on ced's own cloud. Each adaptor is built in
// when its library is found (CED_BENCH_EIGEN, CED_BENCH_PCL, CED_BENCH_OPEN3D).
//
//   build/bin/bench_adaptors --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>

#include "ced/ced.hpp"
#ifdef CED_BENCH_EIGEN
#include "ced/eigen.hpp"
#endif
#ifdef CED_BENCH_PCL
#include "ced/pcl.hpp"
#endif
#ifdef CED_BENCH_OPEN3D
#include "ced/open3d.hpp"
#endif

namespace {

const ced::point_cloud& loft() {
  static const ced::point_cloud c = ced::io::read_ply(std::string(CED_TEST_DATA_DIR) + "/loft_mesh_240.ply");
  return c;
}

ced::detect_params one_thread() {
  ced::detect_params p;
  p.threads = 1;
  return p;
}

void cloud_detect(benchmark::State& state) {
  const auto& c = loft();
  for (auto _ : state) benchmark::DoNotOptimize(ced::detect(c, one_thread(), ced::xyz{}, ced::rgb{}));
}
BENCHMARK(cloud_detect)->Name("detect/ced_cloud/loft")->Unit(benchmark::kMillisecond);

#ifdef CED_BENCH_EIGEN
struct eigen_loft {
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> points;
  Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> colours;
  eigen_loft() {
    const auto& c = loft();
    points = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(c.positions().data(),
                                                                                        Eigen::Index(c.size()), 3);
    colours.resize(Eigen::Index(c.size()), 3);
    const auto rgb = ced::find_rgb_fields(c);
    for (int k = 0; k < 3; ++k)
      for (std::size_t i = 0; i < c.size(); ++i)
        colours(Eigen::Index(i), k) = std::uint8_t(rgb[std::size_t(k)]->values[i]);
  }
};
const eigen_loft& eigen_data() {
  static const eigen_loft e;
  return e;
}
void eigen_from(benchmark::State& state) {
  const auto& e = eigen_data();
  for (auto _ : state) benchmark::DoNotOptimize(ced::from_eigen(e.points, {{"rgb", e.colours}}));
}
BENCHMARK(eigen_from)->Name("convert/eigen/loft")->Unit(benchmark::kMillisecond);
void eigen_detect(benchmark::State& state) {
  const auto& e = eigen_data();
  for (auto _ : state)
    benchmark::DoNotOptimize(ced::detect(e.points, {{"rgb", e.colours}}, one_thread(), ced::xyz{}, ced::rgb{}));
}
BENCHMARK(eigen_detect)->Name("detect/eigen/loft")->Unit(benchmark::kMillisecond);
#endif

#ifdef CED_BENCH_PCL
const pcl::PointCloud<pcl::PointXYZRGB>::Ptr& pcl_loft() {
  static const pcl::PointCloud<pcl::PointXYZRGB>::Ptr p = [] {
    const auto& c = loft();
    const auto rgb = ced::find_rgb_fields(c);
    pcl::PointCloud<pcl::PointXYZRGB>::Ptr out(new pcl::PointCloud<pcl::PointXYZRGB>);
    for (std::size_t i = 0; i < c.size(); ++i) {
      pcl::PointXYZRGB q(std::uint8_t(rgb[0]->values[i]), std::uint8_t(rgb[1]->values[i]),
                         std::uint8_t(rgb[2]->values[i]));
      q.x = c.position(i)[0], q.y = c.position(i)[1], q.z = c.position(i)[2];
      out->push_back(q);
    }
    return out;
  }();
  return p;
}
void pcl_from(benchmark::State& state) {
  const auto& p = pcl_loft();
  for (auto _ : state) benchmark::DoNotOptimize(ced::from_pcl(*p));
}
BENCHMARK(pcl_from)->Name("convert/pcl/loft")->Unit(benchmark::kMillisecond);
void pcl_dropin(benchmark::State& state) {
  const auto& p = pcl_loft();
  ced::pcl::CEDKeypoint6D<pcl::PointXYZRGB, pcl::PointXYZRGB> ced6d;
  ced6d.setRadiusSearch(0.05);
  ced6d.setNonMaxRadius(0.05);
  ced6d.setCentroidThresholdRGB(0.1);
  ced6d.setNumberOfThreads(1);
  ced6d.setInputCloud(p);
  pcl::PointCloud<pcl::PointXYZRGB> out;
  for (auto _ : state) {
    ced6d.compute(out);
    benchmark::DoNotOptimize(out.size());
  }
}
BENCHMARK(pcl_dropin)->Name("detect/pcl_CEDKeypoint6D/loft")->Unit(benchmark::kMillisecond);
#endif

#ifdef CED_BENCH_OPEN3D
const open3d::geometry::PointCloud& open3d_loft() {
  static const open3d::geometry::PointCloud p = [] {
    const auto& c = loft();
    const auto rgb = ced::find_rgb_fields(c);
    open3d::geometry::PointCloud out;
    for (std::size_t i = 0; i < c.size(); ++i) {
      out.points_.emplace_back(c.position(i)[0], c.position(i)[1], c.position(i)[2]);
      out.colors_.emplace_back(rgb[0]->values[i] / 255.0, rgb[1]->values[i] / 255.0, rgb[2]->values[i] / 255.0);
    }
    return out;
  }();
  return p;
}
void open3d_from(benchmark::State& state) {
  const auto& p = open3d_loft();
  for (auto _ : state) benchmark::DoNotOptimize(ced::from_open3d(p));
}
BENCHMARK(open3d_from)->Name("convert/open3d/loft")->Unit(benchmark::kMillisecond);
void open3d_detect(benchmark::State& state) {
  const auto& p = open3d_loft();
  for (auto _ : state) benchmark::DoNotOptimize(ced::detect(p, one_thread(), ced::xyz{}, ced::rgb{}));
}
BENCHMARK(open3d_detect)->Name("detect/open3d/loft")->Unit(benchmark::kMillisecond);
#endif

}  // namespace

BENCHMARK_MAIN();
