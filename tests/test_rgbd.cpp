// SPDX-License-Identifier: MIT
// RGB-D back-projection, Open3D intrinsics and trajectory logs.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "ced/io/rgbd.hpp"
#include "file_support.hpp"

// stb, a system header for CMake (its warnings are not ours).
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

using ced_test::read_error_of;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace {

ced::io::camera_intrinsics small_camera() {
  ced::io::camera_intrinsics k;
  k.width = 4;
  k.height = 3;
  k.fx = 2.0;
  k.fy = 4.0;
  k.cx = 1.5;
  k.cy = 1.0;
  return k;
}

// 4x3 depth in millimetres: 0 = no measurement, 5000 = beyond depth_max 3 m.
const std::vector<std::uint16_t> depth_mm = {1000, 0,    2000, 1500,  //
                                             500,  1000, 5000, 0,     //
                                             3000, 1200, 800,  2500};

std::vector<std::uint8_t> colours() {
  std::vector<std::uint8_t> rgb;
  for (int i = 0; i < 12; ++i) {
    rgb.push_back(std::uint8_t(10 * i));
    rgb.push_back(std::uint8_t(200 - 10 * i));
    rgb.push_back(std::uint8_t(7 * i));
  }
  return rgb;
}

// A minimal 16-bit greyscale PNG encoder (stb_image_write only writes 8 bits):
// stored (uncompressed) deflate blocks, CRC-32 and Adler-32.
std::uint32_t crc32(const std::string& bytes) {
  std::uint32_t c = 0xffffffffu;
  for (unsigned char b : bytes) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

std::string be32(std::uint32_t v) {
  return {char(v >> 24), char((v >> 16) & 0xff), char((v >> 8) & 0xff), char(v & 0xff)};
}

std::string chunk(const std::string& type, const std::string& data) {
  return be32(std::uint32_t(data.size())) + type + data + be32(crc32(type + data));
}

std::string png16(const std::vector<std::uint16_t>& pixels, int w, int h) {
  std::string raw;
  for (int y = 0; y < h; ++y) {
    raw += '\0';  // filter: none
    for (int x = 0; x < w; ++x) {
      const std::uint16_t v = pixels[std::size_t(y * w + x)];
      raw += char(v >> 8);
      raw += char(v & 0xff);
    }
  }
  std::uint32_t a = 1, b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  const auto n = std::uint16_t(raw.size());  // one stored block: small images only
  std::string zlib = "\x78\x01";
  zlib += '\x01';  // final stored block
  zlib += {char(n & 0xff), char(n >> 8), char(~n & 0xff), char((~n >> 8) & 0xff)};
  zlib += raw + be32((b << 16) | a);
  const std::string ihdr = be32(std::uint32_t(w)) + be32(std::uint32_t(h)) + std::string("\x10\x00\x00\x00\x00", 5);
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", zlib) + chunk("IEND", "");
}

void write_colour_png(const std::string& path, const std::vector<std::uint8_t>& rgb, int w, int h) {
  ASSERT_NE(stbi_write_png(path.c_str(), w, h, 3, rgb.data(), 3 * w), 0);
}

}  // namespace

TEST(Rgbd, BackProjectsThroughThePinholeModel) {
  const auto k = small_camera();
  const auto rgb = colours();
  const auto cloud = ced::io::back_project(depth_mm.data(), rgb.data(), 4, 3, k);
  // Valid pixels in row order, without the zeros (1, 7) and the 5 m one (6).
  const std::vector<int> kept = {0, 2, 3, 4, 5, 8, 9, 10, 11};
  ASSERT_EQ(cloud.size(), kept.size());
  ASSERT_TRUE(cloud.has_rgb());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const int pixel = kept[i], u = pixel % 4, v = pixel / 4;
    const double z = depth_mm[std::size_t(pixel)] / 1000.0;
    EXPECT_FLOAT_EQ(cloud.position(i)[0], float((u - 1.5) * z / 2.0)) << "pixel " << pixel;
    EXPECT_FLOAT_EQ(cloud.position(i)[1], float((v - 1.0) * z / 4.0)) << "pixel " << pixel;
    EXPECT_FLOAT_EQ(cloud.position(i)[2], float(z)) << "pixel " << pixel;
    EXPECT_EQ(cloud.get_field("red").values[i], rgb[std::size_t(3 * pixel)]);
    EXPECT_EQ(cloud.get_field("green").values[i], rgb[std::size_t(3 * pixel + 1)]);
    EXPECT_EQ(cloud.get_field("blue").values[i], rgb[std::size_t(3 * pixel + 2)]);
  }
  ced::io::rgbd_options all;
  all.depth_max = 0;  // keep every measurement
  EXPECT_EQ(ced::io::back_project(depth_mm.data(), nullptr, 4, 3, k, all).size(), 10u);
  EXPECT_FALSE(ced::io::back_project(depth_mm.data(), nullptr, 4, 3, k, all).has_rgb());
  EXPECT_THROW(ced::io::back_project(depth_mm.data(), rgb.data(), 3, 4, k), std::invalid_argument);
}

TEST(Rgbd, ReadsDepthAndColourFiles) {
  const auto k = small_camera();
  const std::string depth = temp_file("depth16.png"), colour = temp_file("colour.png");
  write_bytes(depth, png16(depth_mm, 4, 3));
  write_colour_png(colour, colours(), 4, 3);
  const auto cloud = ced::io::read_rgbd(depth, colour, k);
  const auto expected = ced::io::back_project(depth_mm.data(), colours().data(), 4, 3, k);
  EXPECT_EQ(cloud.positions(), expected.positions());
  EXPECT_EQ(cloud.get_field("green").values, expected.get_field("green").values);
}

TEST(Rgbd, RejectsBadImages) {
  const auto k = small_camera();
  const std::string depth = temp_file("d.png"), colour = temp_file("c.png");
  write_bytes(depth, png16(depth_mm, 4, 3));
  write_colour_png(colour, colours(), 4, 3);
  auto message = [&](const std::string& d, const std::string& c, const ced::io::camera_intrinsics& cam) {
    try {
      ced::io::read_rgbd(d, c, cam);
    } catch (const ced::io::io_error& e) {
      return std::string(e.what());
    }
    return std::string("<no io_error>");
  };
  // Colour of another size.
  const std::string wide = temp_file("wide.png");
  std::vector<std::uint8_t> wide_rgb(5 * 3 * 3, 90);
  write_colour_png(wide, wide_rgb, 5, 3);
  EXPECT_NE(message(depth, wide, k).find("colour image is 5x3 but the intrinsics say 4x3"), std::string::npos);
  // Intrinsics of another size.
  auto other = k;
  other.width = 640;
  EXPECT_NE(message(depth, colour, other).find("intrinsics say 640x3"), std::string::npos);
  // An 8-bit "depth" image.
  EXPECT_NE(message(colour, colour, k).find("16-bit greyscale"), std::string::npos);
  // Missing and corrupt files.
  EXPECT_NE(message(temp_file("none.png"), colour, k).find("cannot open"), std::string::npos);
  EXPECT_NE(message(depth, temp_file("none.jpg"), k).find("none.jpg"), std::string::npos);
  const std::string junk = temp_file("junk.png");
  write_bytes(junk, "not an image at all");
  EXPECT_NE(message(depth, junk, k).find("junk.png"), std::string::npos);
}

TEST(Rgbd, RejectsImpossibleImageSizesInIntrinsics) {
  const auto read = [](const std::string& p) { ced::io::read_intrinsics(p); };
  for (const char* side : {"1e20", "0", "-4", "640.5", "70000"}) {
    const std::string json = std::string(R"({"width": )") + side +
                             R"(, "height": 480, "intrinsic_matrix": [525.0, 0, 0, 0, 525.0, 0, 319.5, 239.5, 1]})";
    EXPECT_CONTAINS(read_error_of(read, json, "bad_camera.json"), "width") << side;
  }
}

TEST(Rgbd, ReadsOpen3DIntrinsics) {
  const std::string path = temp_file("camera.json");
  write_bytes(path, R"({"width": 640, "height": 480,
      "intrinsic_matrix": [525.0, 0, 0, 0, 525.0, 0, 319.5, 239.5, 1]})");
  const auto k = ced::io::read_intrinsics(path);
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_EQ(k.fx, 525.0);
  EXPECT_EQ(k.fy, 525.0);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);
  auto read = [](const std::string& p) { ced::io::read_intrinsics(p); };
  EXPECT_NE(
      read_error_of(read, R"({"width": 640, "height": 480, "intrinsic_matrix": [1, 2]})", "k2.json").find("9 numbers"),
      std::string::npos);
  EXPECT_NE(read_error_of(read, R"({"width": 640})", "k3.json").find("intrinsic_matrix"), std::string::npos);
  EXPECT_NE(read_error_of(read, "{ not json", "k4.json").find("not valid JSON"), std::string::npos);
  EXPECT_NE(read_error_of(read, R"({"width": 640, "height": 480, "intrinsic_matrix": [0, 0, 0, 0, 5, 0, 1, 1, 1]})",
                          "k5.json")
                .find("fx"),
            std::string::npos);
}

TEST(Rgbd, ReadsTrajectoryLogs) {
  const std::string path = temp_file("odometry.log");
  write_bytes(path,
              "0 0 1\n1 0 0 2\n0 1 0 2\n0 0 1 -0.3\n0 0 0 1\n"
              "1 1 2\n0 -1 0 1\n1 0 0 0\n0 0 1 0\n0 0 0 1\n");
  const auto poses = ced::io::read_trajectory_log(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].translation[2], -0.3);
  EXPECT_EQ(poses[1].rotation[0][1], -1.0);
  // Ground truth between frames: camera 0 -> world -> camera 1.
  const auto rel = ced::eval::compose(ced::eval::inverse(poses[1]), poses[0]);
  const auto x = rel.apply({0, 0, 0});  // camera 0's centre (2, 2, -0.3): R1ᵀ((2, 2, -0.3) - (1, 0, 0))
  EXPECT_NEAR(x[0], 2.0, 1e-12);
  EXPECT_NEAR(x[1], -1.0, 1e-12);
  EXPECT_NEAR(x[2], -0.3, 1e-12);
  auto read = [](const std::string& p) { ced::io::read_trajectory_log(p); };
  EXPECT_NE(read_error_of(read, "0 0 1\n1 0 0 2\n0 1 0 2\n", "short.log").find("fewer than 4"), std::string::npos);
  EXPECT_NE(read_error_of(read, "0 0 1\n1 0 0 2\n0 1 0 2\n0 0 1 x\n0 0 0 1\n", "bad.log").find("'x'"),
            std::string::npos);
  EXPECT_NE(read_error_of(read, "", "empty.log").find("no poses"), std::string::npos);
}

TEST(Rgbd, RejectsJpegHuffmanTablesThatWouldOverrunStb) {
  // Found by fuzz_rgbd: a DHT segment whose code counts sum past 256 makes
  // Debian's stb_image write past its Huffman tables. It is refused first.
  const std::string bad =
      ced_test::read_bytes(std::string(CED_TEST_DATA_DIR) + "/../fuzz/regressions/rgbd/jpeg_dht_codes_over_256.jpg");
  ASSERT_FALSE(bad.empty());
  for (int call = 0; call < 2; ++call) {
    try {
      if (call == 0)
        (void)ced::io::image_size(bad, "bad.jpg");  // stb reads the tables for the header too
      else
        (void)ced::io::decode_colour_image(bad, "bad.jpg", 8, 6);
      ADD_FAILURE() << "no error, call " << call;
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("Huffman table"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.jpg"), std::string::npos) << e.what();
    }
  }
  // A PNG chunk that claims more bytes than the file has (stb would first
  // allocate what it claims: 2 GB for this 400-byte file).
  const std::string greedy =
      ced_test::read_bytes(std::string(CED_TEST_DATA_DIR) + "/../fuzz/regressions/rgbd/png_idat_claims_2gb.png");
  try {
    (void)ced::io::decode_colour_image(greedy, "greedy.png", 8, 6);
    ADD_FAILURE() << "no error";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt PNG: chunk"), std::string::npos) << e.what();
  }
  // A good JPEG still decodes (the seed of the fuzz corpus, 8 x 6).
  const std::string good = ced_test::read_bytes(std::string(CED_TEST_DATA_DIR) + "/../fuzz/corpus/rgbd/colour.jpg");
  EXPECT_EQ(ced::io::decode_colour_image(good, "good.jpg", 8, 6).size(), 8u * 6 * 3);
  // Sizes other than the frame's are refused before decoding.
  EXPECT_THROW(ced::io::decode_colour_image(good, "good.jpg", 16, 6), ced::io::io_error);
  EXPECT_THROW(ced::io::decode_depth_image(good, "good.jpg", 8, 6), ced::io::io_error);  // not 16-bit
}
