// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "test_support.hpp"

using ced_test::with_value;

using ced_test::make_room;

TEST(Detect, BadParametersAreClearErrors) {
  const auto c = make_room(100, 1);
  ced::detect_params p;
  auto expect_error = [&](const ced::detect_params& q, const std::string& what) {
    try {
      ced::detect(c, q, ced::xyz{});
      FAIL() << "no error for " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  p.radius = 0;
  expect_error(p, "radius");
  p.radius = -1;
  expect_error(p, "radius");
  p.radius = std::nan("");
  expect_error(p, "radius");
  p.radius = 0.05;
  p.nms_radius = INFINITY;
  expect_error(p, "nms_radius");
  p.nms_radius = 0.05;
  EXPECT_THROW(ced::detect(c, p, ced::xyz{-0.1}), std::invalid_argument);
  EXPECT_THROW(ced::detect(c, p, ced::xyz{std::nan("")}), std::invalid_argument);
  EXPECT_THROW(ced::detect(c, p, std::vector<ced::any_modality>{}), std::invalid_argument);
  ced::point_cloud bad = c;
  bad.positions()[7] = std::nanf("");
  try {
    ced::detect(bad, p, ced::xyz{});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("point 2"), std::string::npos) << e.what();
  }
  ced::point_cloud nan_colour = c;  // a NaN in a field a modality reads is an error, named
  for (auto& f : nan_colour.fields())
    if (f.name == "red") f.values = ced::column(ced::scalar_type::float64, with_value(f.values, 5, std::nan("")));
  try {
    ced::detect(nan_colour, p, ced::rgb{});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("field 'red' has a non-finite value (nan) at point 5"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ced::detect(nan_colour, p, {ced::make_modality("bands(red)")}), std::invalid_argument);
  EXPECT_THROW(ced::detect(nan_colour, p, ced::lab{}), std::invalid_argument);
  EXPECT_NO_THROW(ced::detect(nan_colour, p, ced::xyz{}));  // fields no modality reads may hold anything

  ced::point_cloud grey;
  grey.push_back(0, 0, 0);
  try {
    ced::detect(grey, p, ced::rgb{});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("red"), std::string::npos) << e.what();
  }
}

TEST(Detect, NonFiniteAndOutOfFloatRangeValuesAreNamedErrors) {
  // The checks test chunks of values at once: a bad value past the first
  // chunk, or the last one, is found and named.
  const auto c = ced_test::make_room(6000, 11);
  ced::detect_params p;
  p.radius = 0.05;
  for (const float bad :
       {std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(), std::nanf("")})
    for (const std::size_t i : {std::size_t(4097), c.size() - 1}) {
      ced::point_cloud cloud = c;
      cloud.positions()[3 * i + 2] = bad;
      try {
        ced::detect(cloud, p, ced::xyz{});
        ADD_FAILURE() << "no error for point " << i;
      } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("point " + std::to_string(i) + " has a non-finite coordinate"),
                  std::string::npos)
            << e.what();
      }
    }
  // Fields keep their type: non-finite values live in float fields.
  for (const auto type : {ced::scalar_type::float64, ced::scalar_type::float32})
    for (const double bad :
         {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(), std::nan("")})
      for (const std::size_t i : {std::size_t(4096), std::size_t(5000), c.size() - 1}) {
        ced::point_cloud cloud = c;
        for (auto& f : cloud.fields())
          if (f.name == "green") f.values = ced::column(type, with_value(f.values, i, bad));
        try {
          ced::detect(cloud, p, ced::rgb{});
          ADD_FAILURE() << "no error for point " << i;
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("field 'green' has a non-finite value"), std::string::npos) << e.what();
          EXPECT_NE(std::string(e.what()).find("at point " + std::to_string(i)), std::string::npos) << e.what();
        }
      }
  // Values a float holds pass; values beyond it (which would become
  // infinite in the float channels) are named errors, not NaN saliencies.
  const double flt_max = std::numeric_limits<float>::max();
  const ced::field fine{"h", ced::scalar_type::float64, {flt_max, -flt_max, 1e-320, -0.0, 1e30}};
  EXPECT_NO_THROW(ced::require_finite(fine, "bands(h)"));
  EXPECT_EQ(ced::interleave({&fine}).size(), 5u);
  for (const double beyond : {std::nextafter(flt_max, 1e300), 1e300, -std::numeric_limits<double>::max()}) {
    ced::point_cloud cloud = c;
    std::vector<double> h(c.size(), 1.0);
    h[4500] = beyond;
    cloud.add_field("h", ced::scalar_type::float64, h);
    try {
      ced::detect(cloud, p, {ced::make_modality("bands(h),range=0..1")});
      ADD_FAILURE() << "no error for " << beyond;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("field 'h' has a value beyond the float range"), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("at point 4500"), std::string::npos) << e.what();
    }
    const ced::field f{"h", ced::scalar_type::float64, h};
    EXPECT_THROW(ced::interleave({&f}), std::invalid_argument);
  }
}
