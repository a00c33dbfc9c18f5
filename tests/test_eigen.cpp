// SPDX-License-Identifier: MIT
// ced/eigen.hpp: Eigen matrices in (any storage order, strides, scalar) and
// results out, against ced::detect on the same cloud read from its file.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "ced/eigen.hpp"
#include "ced/io/io.hpp"
#include "ced/plugin.hpp"
#include "file_support.hpp"
#include "ndvi_modality.hpp"  // examples/: a user's modality

namespace {

const ced::point_cloud& scan() {
  static const ced::point_cloud c = ced::io::read_ply(std::string(CED_TEST_DATA_DIR) + "/apartment_mesh_214.ply");
  return c;
}

Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> positions_of(const ced::point_cloud& c) {
  return Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(c.positions().data(),
                                                                                    Eigen::Index(c.size()), 3);
}

Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> colours_of(const ced::point_cloud& c) {
  Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3> m(Eigen::Index(c.size()), 3);
  const auto rgb = ced::find_rgb_fields(c);
  for (int k = 0; k < 3; ++k) {
    const std::uint8_t* v = rgb[std::size_t(k)]->values.data<std::uint8_t>();
    for (std::size_t i = 0; i < c.size(); ++i) m(Eigen::Index(i), k) = v[i];
  }
  return m;
}

void expect_same(const ced::detection_result& got, const ced::detection_result& want, const std::string& what) {
  EXPECT_EQ(got.keypoints, want.keypoints) << what;
  ASSERT_EQ(got.saliency.size(), want.saliency.size()) << what;
  for (std::size_t m = 0; m < want.saliency.size(); ++m) EXPECT_EQ(got.saliency[m], want.saliency[m]) << what;
  EXPECT_EQ(got.neighbor_count, want.neighbor_count) << what;
}

}  // namespace

// Every storage order and scalar of positions and colours gives the cloud's
// own result, bit for bit (CED-6D on a Redwood scan).
TEST(Eigen, AnyLayoutGivesTheCloudsResult) {
  const auto& c = scan();
  const ced::detect_params p;
  const auto want = ced::detect(c, p, ced::xyz{}, ced::rgb{});
  ASSERT_GT(want.keypoints.size(), 100u);

  const auto rows = positions_of(c);                                                // float, row-major
  const Eigen::MatrixX3f cols = rows;                                               // float, column-major
  const Eigen::MatrixX3d twice = rows.cast<double>();                               // double: float values, exact
  const auto colours = colours_of(c);                                               // uint8, column-major: in place
  const Eigen::Matrix<std::uint8_t, -1, 3, Eigen::RowMajor> colour_rows = colours;  // strided: copied
  const Eigen::Matrix<int, -1, 3> colour_ints = colours.cast<int>();                // int32, other range

  expect_same(ced::detect(rows, {{"rgb", colours}}, p, ced::xyz{}, ced::rgb{}), want, "row-major float");
  expect_same(ced::detect(cols, {{"rgb", colour_rows}}, p, ced::xyz{}, ced::rgb{}), want, "column-major float");
  expect_same(ced::detect(twice, {{"red,green,blue", colours}}, p, ced::xyz{}, ced::rgb{}), want, "double");
  // A strided Map over an N×4 buffer (x y z pad), and an Eigen::Ref.
  Eigen::Matrix<float, -1, 4, Eigen::RowMajor> padded(rows.rows(), 4);
  padded.leftCols<3>() = rows;
  padded.col(3).setConstant(std::numeric_limits<float>::quiet_NaN());
  const Eigen::Map<const Eigen::Matrix<float, -1, 3, Eigen::RowMajor>, 0, Eigen::OuterStride<4>> strided(
      padded.data(), padded.rows(), 3);
  expect_same(ced::detect(strided, {{"rgb", colours}}, p, ced::xyz{}, ced::rgb{}), want, "strided map");
  const Eigen::Ref<const Eigen::MatrixX3f> ref = cols;
  expect_same(ced::detect(ref, {{"rgb", colours}}, p, ced::preset("ced6d")), want, "Ref, runtime modalities");
  // An expression is evaluated once; integer channels of other types are
  // read as they are, with the range given: the same saliencies (x/255).
  auto rgb255 = ced::rgb{};
  rgb255.range = ced::range_policy::parse("0..255");
  expect_same(ced::detect(padded.leftCols<3>(), {{"rgb", colours.cast<std::uint16_t>() * std::uint16_t(1)}}, p,
                          ced::xyz{}, rgb255),
              want, "uint16 expression, range 0..255");
  expect_same(ced::detect(rows, {{"rgb", colour_ints}}, p, ced::xyz{}, rgb255), want, "int32 colour, range 0..255");
  // Geometry alone, without channels.
  expect_same(ced::detect(cols, p, ced::xyz{}), ced::detect(c, p, ced::xyz{}), "geometry only");
}

// Results come out as Eigen without copies; the copies say what they hold.
TEST(Eigen, ResultsAsEigen) {
  const auto& c = scan();
  const auto pts = positions_of(c);
  const auto r = ced::detect(pts, {{"rgb", colours_of(c)}}, ced::detect_params{}, ced::preset("ced6d"));
  const auto kp = ced::as_eigen(r.keypoints);
  EXPECT_EQ(kp.data(), r.keypoints.data());  // a view
  ASSERT_EQ(std::size_t(kp.size()), r.keypoints.size());
  const Eigen::MatrixXf s = ced::saliency_matrix(r);
  ASSERT_EQ(s.rows(), Eigen::Index(c.size()));
  ASSERT_EQ(s.cols(), 2);
  for (Eigen::Index i = 0; i < s.rows(); i += 97) {
    EXPECT_EQ(s(i, 0), r.saliency[0][std::size_t(i)]);
    EXPECT_EQ(s(i, 1), r.saliency[1][std::size_t(i)]);
  }
  const auto at = ced::keypoint_positions(pts, r);
  ASSERT_EQ(at.rows(), kp.size());
  for (Eigen::Index k = 0; k < at.rows(); ++k) EXPECT_EQ(at.row(k), pts.row(kp(k)));
}

// from_eigen copies everything; in-place channels read contiguous columns.
TEST(Eigen, CopiesAndViews) {
  Eigen::MatrixX3d p(4, 3);
  p << 500000.25, 4000000.5, 10, 500001, 4000001, 11, 500002, 4000000, 12, 500003, 4000002, 13;
  Eigen::VectorXf intensity(4);
  intensity << 1, 2, 3, 4;
  Eigen::Matrix<std::uint16_t, 4, 2, Eigen::RowMajor> bands;
  bands << 1, 2, 3, 4, 5, 6, 7, 8;
  auto cloud = ced::from_eigen(p, {{"intensity", intensity}, {"band", bands}, {"flag", Eigen::Vector4i(1, 0, 1, 0)}});
  EXPECT_EQ(cloud.origin()[0], 500002.0);  // georeferenced: float offsets from a whole origin
  EXPECT_EQ(double(cloud.position(0)[0]) + cloud.origin()[0], 500000.25);
  EXPECT_EQ(double(cloud.position(3)[1]) + cloud.origin()[1], 4000002.0);
  for (const auto& f : cloud.fields()) EXPECT_FALSE(f.values.is_view()) << f.name;
  intensity(0) = 100;
  EXPECT_EQ(cloud.get_field("intensity").values[0], 1.0);
  EXPECT_EQ(cloud.get_field("band_0").values[3], 7.0);
  EXPECT_EQ(cloud.get_field("band_1").type(), ced::scalar_type::uint16);
  EXPECT_EQ(cloud.get_field("flag").type(), ced::scalar_type::int32);

  ced::point_cloud in_place = ced::from_eigen(p);
  ced::eigen_channel{"intensity", intensity}.add_to(in_place, true);
  ced::eigen_channel{"band", bands}.add_to(in_place, true);
  EXPECT_TRUE(in_place.get_field("intensity").values.is_view());  // contiguous: read in place
  EXPECT_FALSE(in_place.get_field("band_0").values.is_view());    // row-major: strided, copied
  EXPECT_EQ(in_place.get_field("intensity").values[0], 100.0);
  ced::eigen_channel{"twice", intensity * 2.0f}.add_to(in_place, false);  // evaluated once, then shared
  EXPECT_TRUE(in_place.get_field("twice").values.is_view());
  EXPECT_EQ(in_place.get_field("twice").values[1], 4.0);
  Eigen::Matrix<bool, 4, 1> mask(true, false, true, true);
  ced::eigen_channel{"mask", mask}.add_to(in_place, true);
  EXPECT_EQ(in_place.get_field("mask").type(), ced::scalar_type::uint8);
}

TEST(Eigen, BadInputIsAClearError) {
  const auto expect_error = [](auto&& f, const std::string& part) {
    try {
      f();
      ADD_FAILURE() << "no error, expected one mentioning " << part;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  const ced::detect_params p;
  Eigen::MatrixXf four = Eigen::MatrixXf::Random(10, 4);
  expect_error([&] { ced::detect(four, p, ced::xyz{}); }, "expected an N×3 matrix, got 10×4");
  Eigen::MatrixX3f pts = Eigen::MatrixX3f::Random(10, 3);
  pts(7, 1) = std::numeric_limits<float>::quiet_NaN();
  expect_error([&] { ced::detect(pts, p, ced::xyz{}); }, "point 7 has a NaN coordinate");
  pts(7, 1) = std::numeric_limits<float>::infinity();
  expect_error([&] { ced::from_eigen(pts); }, "point 7 has a infinite coordinate");
  pts(7, 1) = 0;
  Eigen::VectorXf short_channel(9);
  expect_error(
      [&] {
        ced::detect(pts, {{"intensity", short_channel}}, p, ced::xyz{});
      },
      "channels['intensity']: 9 values, but there are 10 points");
  Eigen::MatrixXf two(10, 2);
  expect_error([&] { ced::from_eigen(pts, {{"a,b,c", two}}); }, "names 3 columns but the array has 2");
  // A field given twice was kept once without a word (#57).
  Eigen::VectorXf intensity = Eigen::VectorXf::Random(10);
  expect_error(
      [&] {
        ced::from_eigen(pts, {{"intensity", intensity}, {"intensity", intensity}});
      },
      "channels['intensity']: the field 'intensity' is given twice");
  Eigen::MatrixXf rgb = Eigen::MatrixXf::Random(10, 3);
  expect_error([&] { ced::from_eigen(pts, {{"rgb", rgb}, {"red", intensity}}); }, "the field 'red' is given twice");
  expect_error([&] { ced::from_eigen(pts, {{"a,a", two}}); }, "the field 'a' is named twice");
  expect_error([&] { ced::detect(pts, p, ced::rgb{}); }, "red");  // the modality names the missing field
}

// A cloud with intensity and normals, and a modality written against
// ced::core alone (examples/ndvi_modality.hpp): from matrices, the keypoints
// of the same cloud written to a file and read back.
TEST(Eigen, IntensityNormalsAndAUserModalityAsTheFile) {
  const Eigen::Index n = 6000;
  Eigen::MatrixX3f pts(n, 3), normal(n, 3);
  Eigen::Matrix<std::uint16_t, -1, 1> intensity(n);
  Eigen::Matrix<std::uint8_t, -1, 2> nir_red(n, 2);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0, 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const float x = u(rng), y = u(rng), z = y > 0.5f ? 0.1f * std::sin(8 * x) : 0.0f;
    pts.row(i) << x, y, z;
    normal.row(i) = Eigen::RowVector3f(y > 0.5f ? -0.8f * std::cos(8 * x) : 0.0f, 0, 1).normalized();
    intensity(i) = std::uint16_t(x < 0.3f ? 20000 : 3000 + (rng() % 500));
    nir_red(i, 0) = std::uint8_t(y < 0.25f ? 200 : 60);
    nir_red(i, 1) = std::uint8_t(40 + rng() % 20);
  }
  ced::detect_params p;
  p.radius = p.nms_radius = 0.08;
  example::ndvi ndvi;
  ndvi.threshold_value = 0.05;
  const auto mine = ced::detect(pts, {{"intensity", intensity}, {"nx,ny,nz", normal}, {"nir,red", nir_red}}, p,
                                ced::xyz{}, ced::intensity{}, ced::normals{0.1, ced::normals::source::fields}, ndvi);
  const std::string path = ced_test::temp_file("eigen_adaptor.ply");
  ced::io::write_cloud(path,
                       ced::from_eigen(pts, {{"intensity", intensity}, {"nx,ny,nz", normal}, {"nir,red", nir_red}}));
  const auto file = ced::io::read_cloud(path);
  EXPECT_EQ(file.get_field("intensity").type(), ced::scalar_type::uint16);
  expect_same(mine,
              ced::detect(file, p, ced::xyz{}, ced::intensity{}, ced::normals{0.1, ced::normals::source::fields}, ndvi),
              "file");
  EXPECT_GT(mine.keypoints.size(), 20u);
  // The same modality from a plugin (examples/plugin/ndvi_plugin.cpp), chosen at run time.
  ced::load_plugin(CED_NDVI_PLUGIN);
  const auto plugged = ced::detect(pts, {{"nir,red", nir_red}}, p, {ced::make_modality("ndvi:0.05")});
  EXPECT_EQ(plugged.saliency[0], mine.saliency[3]);
  for (std::size_t m = 1; m < 4; ++m)  // every modality sees something
    EXPECT_GT(*std::max_element(mine.saliency[m].begin(), mine.saliency[m].end()), 0.0f) << mine.names[m];
}

// The paper's three Redwood scans as matrices give their files' keypoints
// (CED-6D and CED-3D).
TEST(Eigen, RedwoodScansAsTheirFiles) {
  for (const std::string scan : {"apartment_mesh_213", "apartment_mesh_214", "loft_mesh_240"}) {
    const auto c = ced::io::read_ply(std::string(CED_TEST_DATA_DIR) + "/" + scan + ".ply");
    const Eigen::MatrixX3d points = positions_of(c).cast<double>();
    const auto colours = colours_of(c);
    for (const std::string preset : {"ced6d", "ced3d"})
      expect_same(ced::detect(points, {{"rgb", colours}}, ced::detect_params{}, ced::preset(preset)),
                  ced::detect(c, ced::detect_params{}, ced::preset(preset)), scan + " " + preset);
  }
}
