// SPDX-License-Identifier: MIT
// The same cloud in every format and encoding gives the same keypoints,
// including georeferenced coordinates with large offsets.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "test_support.hpp"

namespace {
/// A coloured room on a millimetre grid (so LAS holds it exactly), placed at
/// (500000, 4000000) like projected map coordinates.
ced::point_cloud georeferenced_room() {
  ced::point_cloud c = ced_test::make_room(6000, 17);
  for (float& v : c.positions()) v = static_cast<float>(std::round(double(v) * 1000.0) * 0.001);
  for (std::size_t i = 0; i < c.size(); ++i) c.positions()[3 * i + 2] += 100.0f;
  c.set_origin({500000.0, 4000000.0, 0.0});
  return c;
}
}  // namespace

TEST(Formats, EveryFormatGivesTheSameKeypoints) {
  const ced::point_cloud cloud = georeferenced_room();
  const std::vector<ced::any_modality> mods = {ced::make_modality("xyz"), ced::make_modality("rgb"),
                                               ced::make_modality("intensity:0.3,range=0..65535")};
  const ced::detect_params p;
  const auto want = ced::detect(cloud, p, mods).keypoints;
  ASSERT_GT(want.size(), 20u);

  const auto dir = std::filesystem::path(::testing::TempDir()) / "ced_formats";
  std::filesystem::create_directories(dir);
  struct variant {
    std::string name;
    std::function<void(const std::string&)> write;
  };
  const std::vector<variant> variants = {
      {"a.ply", [&](const std::string& f) { ced::io::write_ply(f, cloud, ced::io::ply_format::binary_little_endian); }},
      {"b.ply", [&](const std::string& f) { ced::io::write_ply(f, cloud, ced::io::ply_format::binary_big_endian); }},
      {"c.ply", [&](const std::string& f) { ced::io::write_ply(f, cloud, ced::io::ply_format::ascii); }},
      {"a.pcd", [&](const std::string& f) { ced::io::write_pcd(f, cloud, ced::io::pcd_format::ascii); }},
      {"b.pcd", [&](const std::string& f) { ced::io::write_pcd(f, cloud, ced::io::pcd_format::binary); }},
      {"c.pcd", [&](const std::string& f) { ced::io::write_pcd(f, cloud, ced::io::pcd_format::binary_compressed); }},
      {"a.las", [&](const std::string& f) { ced::io::write_las(f, cloud); }},
      {"a.csv", [&](const std::string& f) { ced::io::write_csv(f, cloud); }},
  };
  for (const auto& v : variants) {
    const std::string path = (dir / v.name).string();
    v.write(path);
    const ced::point_cloud back = ced::io::read_cloud(path);
    ASSERT_EQ(back.size(), cloud.size()) << v.name;
    EXPECT_EQ(back.origin(), cloud.origin()) << v.name;
    float worst = 0;  // positions agree to far below a micrometre (float rounding of the offsets)
    for (std::size_t i = 0; i < cloud.positions().size(); ++i)
      worst = std::max(worst, std::abs(back.positions()[i] - cloud.positions()[i]));
    EXPECT_LT(worst, 1e-6f) << v.name;
    EXPECT_EQ(ced::detect(back, p, mods).keypoints, want) << v.name;
  }
  std::filesystem::remove_all(dir);
}

TEST(Formats, ExtensionsAndRefusals) {
  EXPECT_EQ(ced::io::format_of("a/b.PLY"), ced::io::file_format::ply);
  EXPECT_EQ(ced::io::format_of("x.xyz"), ced::io::file_format::csv);
  EXPECT_EQ(ced::io::format_of("x.las"), ced::io::file_format::las);
  auto message = [](const std::string& path) {
    try {
      ced::io::format_of(path);
    } catch (const ced::io::io_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("scan.laz").find("laszip"), std::string::npos);
  EXPECT_NE(message("scan.e57").find("convert"), std::string::npos);
  EXPECT_NE(message("scan.obj").find("unsupported"), std::string::npos);
  EXPECT_NE(message("dir.d/scan").find("--format"), std::string::npos);
  EXPECT_THROW(ced::io::parse_format("obj"), std::invalid_argument);
}
