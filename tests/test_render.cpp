// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "ced/io/output_file.hpp"
#include "ced/render.hpp"
#include "file_support.hpp"

// stb, a system header for CMake (its warnings are not ours).
#define STB_IMAGE_IMPLEMENTATION
#include <stb_image.h>

namespace fs = std::filesystem;
using ced::point_cloud;
using ced::render_options;
using ced::view_direction;

using ced_test::read_bytes;
using ced_test::temp_dir;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace {

/// A wavy 41x41 grid over [-1,1]^2; point index = row * 41 + column.
point_cloud grid(bool with_colour = false) {
  point_cloud c;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  for (int r = 0; r <= 40; ++r)
    for (int k = 0; k <= 40; ++k) {
      const float x = -1 + 0.05f * k, y = -1 + 0.05f * r;
      c.push_back(x, y, 0.2f * std::sin(3 * x) * std::cos(2 * y));
      rgb.push_back({20, static_cast<std::uint8_t>(100 + 3 * k), 220});
    }
  if (with_colour) c.add_rgb(rgb);
  return c;
}
constexpr std::uint32_t center_index = 20 * 41 + 20;
constexpr std::uint32_t corner_index = 40 * 41 + 40;  // (1, 1)

struct image {
  int w = 0, h = 0;
  std::vector<std::uint8_t> rgb;
  const std::uint8_t* at(int x, int y) const { return &rgb[3 * (static_cast<std::size_t>(y) * w + x)]; }
};

image load_png(const std::string& path) {
  image img;
  int channels = 0;
  std::uint8_t* data = stbi_load(path.c_str(), &img.w, &img.h, &channels, 3);
  if (!data) return img;
  img.rgb.assign(data, data + 3 * static_cast<std::size_t>(img.w) * img.h);
  stbi_image_free(data);
  return img;
}

bool is_keypoint_red(const std::uint8_t* p) { return p[0] > 200 && p[1] < 50 && p[2] < 50; }

std::size_t distinct_colours(const image& img) {
  std::set<std::uint32_t> colours;
  for (std::size_t i = 0; i + 2 < img.rgb.size(); i += 3)
    colours.insert(std::uint32_t(img.rgb[i]) << 16 | std::uint32_t(img.rgb[i + 1]) << 8 | img.rgb[i + 2]);
  return colours.size();
}

/// Number of keypoint-red pixels in [x0,x1) x [y0,y1).
int red_pixels(const image& img, int x0, int y0, int x1, int y1) {
  int n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) n += is_keypoint_red(img.at(x, y));
  return n;
}

image render(const point_cloud& c, const std::vector<std::uint32_t>& kp, const render_options& o) {
  image img;
  img.rgb = ced::render_rgb(c, kp, o, img.w, img.h);
  return img;
}

}  // namespace

TEST(Render, WritesADecodablePngWithKeypointsWhereTheyAre) {
  render_options o;
  o.width = 320;
  o.height = 240;
  o.view = view_direction::top;
  const fs::path dir = temp_dir() / "png";
  fs::create_directories(dir);
  const std::string path = (dir / "top.png").string();
  ced::render_png(path, grid(), {center_index, corner_index}, o);
  const image img = load_png(path);
  ASSERT_FALSE(img.rgb.empty()) << stbi_failure_reason();
  EXPECT_EQ(img.w, 320);
  EXPECT_EQ(img.h, 240);
  EXPECT_GT(distinct_colours(img), 10u);
  // Top view, square cloud centred: the centre keypoint is at the image centre,
  // the (1,1) corner in the upper-right quadrant, nothing red lower-left
  // (away from the centre disc).
  EXPECT_TRUE(is_keypoint_red(img.at(160, 120)));
  EXPECT_GT(red_pixels(img, 160, 0, 320, 120), 5);
  EXPECT_EQ(red_pixels(img, 0, 150, 130, 240), 0);
  // The background is white; the margin is left empty.
  const std::uint8_t* corner = img.at(0, 0);
  EXPECT_EQ(corner[0] + corner[1] + corner[2], 3 * 255);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);  // no temporary file left
}

TEST(Render, NoKeypointsNoRed) {
  render_options o;
  o.width = 200;
  o.height = 150;
  const image img = render(grid(), {}, o);
  EXPECT_EQ(red_pixels(img, 0, 0, img.w, img.h), 0);
  EXPECT_GT(distinct_colours(img), 10u);
}

TEST(Render, EveryViewIsNonTrivial) {
  for (view_direction v : {view_direction::top, view_direction::front, view_direction::iso}) {
    render_options o;
    o.width = 160;
    o.height = 120;
    o.view = v;
    const image img = render(grid(), {center_index}, o);
    ASSERT_EQ(img.rgb.size(), 160u * 120u * 3u);
    EXPECT_GT(distinct_colours(img), 3u) << int(v);
    EXPECT_GT(red_pixels(img, 0, 0, img.w, img.h), 5) << int(v);
  }
}

TEST(Render, UsesTheCloudColours) {
  render_options o;
  o.width = 200;
  o.height = 200;
  o.view = view_direction::top;
  const image img = render(grid(true), {}, o);
  const std::uint8_t* p = img.at(100, 100);
  EXPECT_GT(p[2], p[0] + 80) << int(p[0]) << "," << int(p[1]) << "," << int(p[2]);  // blue-ish, not grey

  point_cloud c = grid();
  const std::size_t n = c.size();
  c.add_field("r", ced::scalar_type::float32, std::vector<double>(n, 0.0));
  c.add_field("g", ced::scalar_type::float32, std::vector<double>(n, 0.9));
  c.add_field("b", ced::scalar_type::float32, std::vector<double>(n, 0.0));
  const image green = render(c, {}, o);
  const std::uint8_t* q = green.at(100, 100);
  EXPECT_GT(q[1], q[0] + 80);

  // 16-bit colour fields holding 8-bit values (common in LAS) are read as
  // 8-bit, as the rgb modality reads them, not as nearly black.
  point_cloud las = grid();
  las.add_field("red", ced::scalar_type::uint16, std::vector<double>(n, 230.0));
  las.add_field("green", ced::scalar_type::uint16, std::vector<double>(n, 200.0));
  las.add_field("blue", ced::scalar_type::uint16, std::vector<double>(n, 40.0));
  const image lit = render(las, {}, o);
  const std::uint8_t* l = lit.at(100, 100);
  EXPECT_GT(l[0], 150) << int(l[0]) << "," << int(l[1]) << "," << int(l[2]);
  EXPECT_GT(l[1], 120);
}

TEST(Render, CustomColoursAndSizes) {
  render_options o;
  o.width = 100;
  o.height = 100;
  o.view = view_direction::top;
  o.background = {0, 0, 0};
  o.keypoint_color = {0, 255, 0};
  o.point_size_px = 2;
  o.keypoint_size_px = 15;
  const image img = render(grid(), {center_index}, o);
  const std::uint8_t* c = img.at(50, 50);
  EXPECT_EQ(c[1], 255);
  EXPECT_EQ(c[0], 0);
  const std::uint8_t* corner = img.at(0, 0);
  EXPECT_EQ(corner[0] + corner[1] + corner[2], 0);
}

TEST(Render, KeypointMarkersShrinkWithTheirDensity) {
  // A finer grid (161 x 161 points over 2 x 2) seen from above at 800 x 800.
  point_cloud c;
  for (int r = 0; r <= 160; ++r)
    for (int k = 0; k <= 160; ++k) c.push_back(-1 + 0.0125f * k, -1 + 0.0125f * r, 0);
  render_options o;
  o.width = o.height = 800;
  o.view = view_direction::top;
  o.point_size_px = 4;
  // Red pixels a keypoint: a few keypoints get the sparse default (12 px
  // discs, about 57 red pixels inside their outline); every 4th point in
  // each direction (1681 keypoints, ~19 px apart) gets discs of about
  // 0.4 x 19 = 7-8 px that do not touch.
  std::vector<std::uint32_t> few = {0, 80 * 161 + 80, 160 * 161 + 160}, dense;
  for (int r = 0; r <= 160; r += 4)
    for (int k = 0; k <= 160; k += 4) dense.push_back(static_cast<std::uint32_t>(r * 161 + k));
  const image a = render(c, few, o), b = render(c, dense, o);
  const double per_few = red_pixels(a, 0, 0, a.w, a.h) / double(few.size());
  const double per_dense = red_pixels(b, 0, 0, b.w, b.h) / double(dense.size());
  EXPECT_GT(per_few, 40) << per_few << " " << per_dense;
  EXPECT_LT(per_dense, 0.7 * per_few) << per_few << " " << per_dense;
  EXPECT_GT(per_dense, 8);
  // Apart: the pixel between two neighbouring keypoints is not red.
  const image& img = b;
  int gaps = 0, checked = 0;
  for (int y = 100; y < 700; y += 37) {
    for (int x = 100; x < 700; ++x)
      if (is_keypoint_red(img.at(x, y))) {
        int e = x;
        while (e < img.w && is_keypoint_red(img.at(e, y))) ++e;
        const int f = std::min(img.w - 1, e + 2);
        ++checked;
        gaps += !is_keypoint_red(img.at(f, y)) || !is_keypoint_red(img.at(e, y));
        x = e;
      }
  }
  EXPECT_GT(checked, 10);
  EXPECT_EQ(gaps, checked);
  // A given size still wins.
  o.keypoint_size_px = 15;
  EXPECT_GT(red_pixels(render(c, dense, o), 0, 0, 800, 800) / double(dense.size()), 0.9 * per_few);
}

TEST(Render, PointColoursAndTwoViews) {
  const point_cloud c = grid(true);
  render_options o;
  o.width = o.height = 120;
  o.view = view_direction::top;
  std::vector<float> x;
  for (std::size_t i = 0; i < c.size(); ++i) x.push_back(c.position(i)[0]);
  o.point_colors = ced::colour_map(x, -1, 1);
  ASSERT_EQ(o.point_colors.size(), 3 * c.size());
  // viridis: purple at the low end (left), yellow at the high end (right).
  const image img = render(c, {}, o);
  const std::uint8_t* left = img.at(12, 60);
  const std::uint8_t* right = img.at(107, 60);
  EXPECT_GT(left[2], left[1]) << int(left[0]) << "," << int(left[1]) << "," << int(left[2]);
  EXPECT_GT(right[0], 150);
  EXPECT_GT(right[1], 150);
  EXPECT_LT(right[2], 120);
  const auto ends = ced::colour_map({-5.f, 0.f, 7.f, std::nanf("")}, 0, 1);
  EXPECT_EQ(std::vector<std::uint8_t>(ends.begin(), ends.begin() + 3), std::vector<std::uint8_t>({68, 1, 84}));
  EXPECT_EQ(std::vector<std::uint8_t>(ends.begin() + 3, ends.begin() + 6), std::vector<std::uint8_t>({68, 1, 84}));
  EXPECT_EQ(std::vector<std::uint8_t>(ends.begin() + 6, ends.begin() + 9), std::vector<std::uint8_t>({253, 231, 37}));
  o.point_colors.pop_back();
  int w = 0, h = 0;
  EXPECT_THROW(ced::render_rgb(c, {}, o, w, h), std::invalid_argument);
  // Side by side: rows of a then b.
  const std::vector<std::uint8_t> a(3 * 2 * 2, 10), b(3 * 3 * 2, 20);
  const auto ab = ced::side_by_side(a, 2, b, 3, 2);
  ASSERT_EQ(ab.size(), 3u * 5 * 2);
  EXPECT_EQ(ab[0], 10);
  EXPECT_EQ(ab[3 * 2], 20);
  EXPECT_EQ(ab[3 * 5], 10);
  EXPECT_THROW(ced::side_by_side(a, 3, b, 3, 2), std::invalid_argument);
}

TEST(Render, NonFinitePointsAreIgnored) {
  point_cloud c = grid();
  c.push_back(std::nanf(""), 0, 0);
  c.push_back(1e30f * 1e30f, 0, 0);  // inf
  render_options o;
  o.width = 120;
  o.height = 120;
  o.view = view_direction::top;
  const auto n = static_cast<std::uint32_t>(c.size());
  const image img = render(c, {center_index, n - 1}, o);  // a non-finite keypoint is not drawn
  EXPECT_TRUE(is_keypoint_red(img.at(60, 60)));
  EXPECT_GT(distinct_colours(img), 3u);
}

TEST(Render, DegenerateClouds) {
  point_cloud one;
  one.push_back(5, 5, 5);
  render_options o;
  o.width = 64;
  o.height = 48;
  const image img = render(one, {0}, o);
  EXPECT_TRUE(is_keypoint_red(img.at(32, 24)));
  point_cloud line;
  for (int i = 0; i < 10; ++i) line.push_back(float(i), 0, 0);
  o.view = view_direction::front;
  EXPECT_GT(distinct_colours(render(line, {}, o)), 1u);
}

TEST(Render, Errors) {
  int w = 0, h = 0;
  EXPECT_THROW(ced::render_rgb(point_cloud{}, {}, {}, w, h), std::invalid_argument);
  EXPECT_THROW(ced::render_png((temp_dir() / "empty.png").string(), point_cloud{}, {}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(temp_dir() / "empty.png"));
  const point_cloud c = grid();
  EXPECT_THROW(ced::render_rgb(c, {static_cast<std::uint32_t>(c.size())}, {}, w, h), std::invalid_argument);
  render_options bad;
  bad.width = 0;
  EXPECT_THROW(ced::render_rgb(c, {}, bad, w, h), std::invalid_argument);
  EXPECT_THROW(ced::render_png((temp_dir() / "missing" / "x.png").string(), c, {}), ced::io::io_error);
}
