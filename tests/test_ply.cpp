// SPDX-License-Identifier: MIT
// PLY (src/io/ply/): round trips of every scalar type and encoding, hand-written
// files, meshes with lists, large and non-finite coordinates, parallel chunks.

#include "ply_test_support.hpp"

using namespace ply_test;

TEST_P(PlyRoundTrip, EveryScalarTypeThroughAFile) {
  const point_cloud c = all_types_cloud();
  const std::string path = temp_file(std::string("roundtrip_") + format_name(GetParam()) + ".ply");
  ced::io::write_ply(path, c, GetParam());
  const std::string bytes = read_bytes(path);
  EXPECT_CONTAINS(bytes, std::string("format ") + format_name(GetParam()) + " 1.0\n");
  EXPECT_CONTAINS(bytes, "property float x\n");
  EXPECT_CONTAINS(bytes, "property uchar red\n");
  expect_same_cloud(c, ced::io::read_ply(path));
}

TEST_P(PlyRoundTrip, EveryScalarTypeThroughAStream) {
  const point_cloud c = all_types_cloud();
  std::stringstream s(std::ios::in | std::ios::out | std::ios::binary);
  ced::io::write_ply(s, c, GetParam());
  expect_same_cloud(c, ced::io::read_ply(s, "stream"));
}

TEST_P(PlyRoundTrip, EmptyCloud) {
  std::stringstream s;
  ced::io::write_ply(s, point_cloud{}, GetParam());
  EXPECT_TRUE(ced::io::read_ply(s, "stream").empty());
}

TEST_P(PlyRoundTrip, GeoreferencedCoordinatesKeepTheirPrecision) {
  const double x0 = 512345.678, y0 = 4123456.789, z0 = 312.345;
  point_cloud c;
  c.set_origin({512000.0, 4123000.0, 300.0});
  std::vector<std::array<double, 3>> abs;
  for (int i = 0; i < 50; ++i) {
    const std::array<double, 3> p{x0 + 0.731 * i, y0 - 1.37 * i, z0 + 0.01 * i};
    abs.push_back(p);
    c.push_back(float(p[0] - 512000.0), float(p[1] - 4123000.0), float(p[2] - 300.0));
  }
  const std::string path = temp_file(std::string("geo_") + format_name(GetParam()) + ".ply");
  ced::io::write_ply(path, c, GetParam());
  EXPECT_CONTAINS(read_bytes(path), "property double x\n");
  const point_cloud r = ced::io::read_ply(path);
  ASSERT_EQ(r.size(), c.size());
  EXPECT_NE(r.origin()[0], 0.0);  // |mean| > 1e4: positions are relative to an origin
  for (std::size_t i = 0; i < r.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) {
      const double got = r.origin()[k] + r.position(i)[k];
      EXPECT_NEAR(got, abs[i][k], 1e-6 * std::fabs(abs[i][k])) << i << "," << k;
      EXPECT_NEAR(got, abs[i][k], 1e-3) << i << "," << k;  // millimetres survive
    }
}

INSTANTIATE_TEST_SUITE_P(AllFormats, PlyRoundTrip,
                         ::testing::Values(ply_format::ascii, ply_format::binary_little_endian,
                                           ply_format::binary_big_endian),
                         [](const auto& p) { return std::string(format_name(p.param)); });

TEST(PlyWrite, Int64FieldsAreWrittenAsDouble) {
  point_cloud c;
  c.push_back(1, 2, 3);
  c.add_field("id", scalar_type::int64, {-123456789012.0});
  c.add_field("big", scalar_type::uint64, {9007199254740992.0});
  std::stringstream s;
  ced::io::write_ply(s, c, ply_format::binary_little_endian);
  const point_cloud r = ced::io::read_ply(s, "s");
  EXPECT_EQ(r.get_field("id").type(), scalar_type::float64);
  EXPECT_EQ(r.get_field("id").values[0], -123456789012.0);
  EXPECT_EQ(r.get_field("big").values[0], 9007199254740992.0);
}

TEST(PlyWrite, IntegersAreRoundedAndClamped) {
  point_cloud c;
  for (int i = 0; i < 4; ++i) c.push_back(0, 0, 0);
  c.add_field("v", scalar_type::uint8, {-5.0, 300.0, 2.6, std::nan("")});
  for (ply_format f : {ply_format::ascii, ply_format::binary_little_endian}) {
    std::stringstream s;
    ced::io::write_ply(s, c, f);
    EXPECT_EQ(ced::io::read_ply(s, "s").get_field("v").values, (std::vector<double>{0, 255, 3, 0}));
  }
}

TEST(PlyWrite, BadFieldNamesAreRejected) {
  point_cloud c;
  c.push_back(0, 0, 0);
  c.add_field("two words", scalar_type::uint8, {1});
  std::stringstream s;
  EXPECT_THROW(ced::io::write_ply(s, c, ply_format::ascii), std::invalid_argument);
  point_cloud d;
  d.push_back(0, 0, 0);
  d.add_field("x", scalar_type::float32, {1});
  EXPECT_THROW(ced::io::write_ply(s, d, ply_format::ascii), std::invalid_argument);
}

TEST(PlyWrite, MissingDirectoryIsAnIoError) {
  point_cloud c;
  c.push_back(0, 0, 0);
  EXPECT_THROW(ced::io::write_ply(temp_file("no/such/dir.ply"), c), io_error);
}

TEST(PlyRead, HandWrittenBigEndian) {
  bytes_builder b;
  b.big_endian = true;
  b.data =
      "ply\nformat binary_big_endian 1.0\ncomment hand made\nobj_info nothing\nelement vertex 2\n"
      "property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty short temp\n"
      "property double d\nproperty uint32 id\nend_header\n";
  b.put(1.0f).put(2.0f).put(-0.5f).put(std::uint8_t(200)).put(std::int16_t(-2)).put(0.25).put(std::uint32_t(70000));
  b.put(3.0f).put(0.0f).put(1.5f).put(std::uint8_t(7)).put(std::int16_t(258)).put(-2.0).put(std::uint32_t(1));
  // Spot-check the encoding itself: 1.0f big-endian is 3F 80 00 00.
  const std::size_t body = b.data.find("end_header\n") + 11;
  EXPECT_EQ(b.data.substr(body, 4), std::string("\x3f\x80\x00\x00", 4));

  const point_cloud c = read_string(b.data);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(std::vector<float>(c.positions().begin(), c.positions().end()),
            (std::vector<float>{1, 2, -0.5f, 3, 0, 1.5f}));
  ASSERT_EQ(c.fields().size(), 4u);
  EXPECT_EQ(c.fields()[0].name, "red");
  EXPECT_EQ(c.fields()[0].type(), scalar_type::uint8);
  EXPECT_EQ(c.fields()[0].values, (std::vector<double>{200, 7}));
  EXPECT_EQ(c.fields()[1].type(), scalar_type::int16);
  EXPECT_EQ(c.fields()[1].values, (std::vector<double>{-2, 258}));
  EXPECT_EQ(c.fields()[2].type(), scalar_type::float64);
  EXPECT_EQ(c.fields()[2].values, (std::vector<double>{0.25, -2.0}));
  EXPECT_EQ(c.fields()[3].type(), scalar_type::uint32);
  EXPECT_EQ(c.fields()[3].values, (std::vector<double>{70000, 1}));
  EXPECT_EQ(c.origin(), (std::array<double, 3>{0, 0, 0}));
}

namespace {

// A mesh with an element before the vertices, a list inside the vertex
// element, faces after, and x/y/z in unusual order and types.
const char* mesh_header(const char* format) {
  static std::string h;
  h = std::string("ply\r\nformat ") + format +
      " 1.0\r\n"
      "comment CRLF header\r\n"
      "element material 2\r\nproperty uchar kind\r\nproperty list uchar float params\r\n"
      "element vertex 3\r\n"
      "property double z\r\nproperty list uint8 int32 neighbours\r\nproperty float x\r\nproperty int16 y\r\n"
      "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\n"
      "element face 2\r\nproperty list uchar int vertex_indices\r\n"
      "end_header\r\n";
  return h.c_str();
}

void expect_mesh_vertices(const point_cloud& c) {
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(std::vector<float>(c.positions().begin(), c.positions().end()),
            (std::vector<float>{0.5f, -1, 10, 1.5f, 2, 20, -2.5f, 300, 30}));
  ASSERT_EQ(c.fields().size(), 3u);
  EXPECT_EQ(c.fields()[0].name, "red");
  EXPECT_TRUE(c.has_rgb());
  EXPECT_EQ(c.get_field("red").values, (std::vector<double>{255, 0, 9}));
  EXPECT_EQ(c.get_field("green").values, (std::vector<double>{0, 255, 8}));
  EXPECT_EQ(c.get_field("blue").values, (std::vector<double>{1, 2, 7}));
}

}  // namespace

TEST(PlyRead, MeshWithListsAndOtherElementsAscii) {
  const std::string text = std::string(mesh_header("ascii")) +
                           "1 3 0.1 0.2 0.3\r\n2 0\r\n"
                           "10 2 1 2 0.5 -1 255 0 1\r\n"
                           "20 0 1.5 2 0 255 2\r\n"
                           "30 3 0 1 2 -2.5 300 9 8 7\r\n"
                           "3 0 1 2\r\n4 0 1 2 0\r\n";
  expect_mesh_vertices(read_string(text));
}

TEST(PlyRead, MeshWithListsAndOtherElementsBinary) {
  for (bool big : {false, true}) {
    bytes_builder b;
    b.big_endian = big;
    b.data = mesh_header(big ? "binary_big_endian" : "binary_little_endian");
    b.put(std::uint8_t(1)).put(std::uint8_t(3)).put(0.1f).put(0.2f).put(0.3f);
    b.put(std::uint8_t(2)).put(std::uint8_t(0));
    const double z[3] = {10, 20, 30};
    const float x[3] = {0.5f, 1.5f, -2.5f};
    const std::int16_t y[3] = {-1, 2, 300};
    const std::uint8_t rgb[3][3] = {{255, 0, 1}, {0, 255, 2}, {9, 8, 7}};
    const std::uint8_t nlist[3] = {2, 0, 3};
    for (int i = 0; i < 3; ++i) {
      b.put(z[i]).put(nlist[i]);
      for (int k = 0; k < nlist[i]; ++k) b.put(std::int32_t(k));
      b.put(x[i]).put(y[i]).put(rgb[i][0]).put(rgb[i][1]).put(rgb[i][2]);
    }
    b.put(std::uint8_t(3)).put(0).put(1).put(2);
    b.put(std::uint8_t(4)).put(0).put(1).put(2).put(0);
    SCOPED_TRACE(big ? "big endian" : "little endian");
    expect_mesh_vertices(read_string(b.data));
  }
}

TEST(PlyRead, LargeCoordinatesGetAnOrigin) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
      "end_header\nnan 0 0\n600000.25 5000000.25 100.125\n600001.5 5000002.75 101\n";
  const point_cloud c = read_string(text);
  // Per axis: the bounding-box centre, rounded, where it lies far from 0.
  EXPECT_EQ(c.origin(), (std::array<double, 3>{600001, 5000002, 0}));
  EXPECT_EQ(c.position(1)[0], -0.75f);  // 600000.25 - 600001
  EXPECT_EQ(c.position(2)[1], 0.75f);   // 5000002.75 - 5000002
  EXPECT_EQ(c.position(2)[2], 101.0f);
  EXPECT_TRUE(std::isnan(c.position(0)[0]));
}

TEST(PlyRead, NonFiniteCoordinatesAreKept) {
  const point_cloud c = read_string(
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "end_header\nnan inf -inf\n+1 2e0 -3.5\n");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(std::isnan(c.position(0)[0]));
  EXPECT_EQ(c.position(0)[1], std::numeric_limits<float>::infinity());
  EXPECT_EQ(c.position(0)[2], -std::numeric_limits<float>::infinity());
  EXPECT_EQ(c.position(1)[0], 1.0f);
  EXPECT_EQ(c.position(1)[1], 2.0f);
}

TEST(PlyRead, IntegralFloatsInIntegerPropertiesAreAccepted) {
  const point_cloud c = read_string(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nend_header\n0 0 0 255.0\n");
  EXPECT_EQ(c.get_field("red").values[0], 255.0);
}

TEST(PlyRead, LargeBinaryFile) {
  point_cloud c;
  const std::size_t n = 100000;
  std::vector<double> intensity(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.push_back(float(i % 317), float(i % 101) * 0.5f, float(i) * 1e-3f);
    intensity[i] = double(i % 65536);
  }
  c.add_field("intensity", scalar_type::uint16, intensity);
  const std::string path = temp_file("large.ply");
  ced::io::write_ply(path, c);
  expect_same_cloud(c, ced::io::read_ply(path));
}

TEST(PlyRead, ChunksDecodedInParallelEqualTheSerialReaders) {
  // 60 000 vertices of 43 bytes: several chunks of records, decoded in
  // parallel from a file, from a stream and in either byte order; the ascii
  // reader and the reader of records with lists read them one by one.
  point_cloud c;
  c.set_origin({2e5, -3e6, 0});
  const std::size_t n = 60000;
  std::vector<double> red(n), s16(n), u32(n), f32(n), f64(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.push_back(float(i % 317) * 0.25f, float(i % 101) * 0.5f, float(i) * 1e-3f);
    red[i] = double(i % 256);
    s16[i] = double(i % 65536) - 32768;
    u32[i] = double(i) * 60000;
    f32[i] = i % 1000 == 5 ? std::numeric_limits<double>::quiet_NaN() : double(i) * 0.125 - 99;
    f64[i] = double(i) / 3;
  }
  c.positions()[3 * 777] = std::numeric_limits<float>::infinity();  // kept, outside the box
  c.add_field("red", scalar_type::uint8, red);
  c.add_field("s16", scalar_type::int16, s16);
  c.add_field("u32", scalar_type::uint32, u32);
  c.add_field("f32", scalar_type::float32, f32);
  c.add_field("f64", scalar_type::float64, f64);
  const std::string dir = temp_dir().string();
  ced::io::write_ply(dir + "/le.ply", c, ply_format::binary_little_endian);
  ced::io::write_ply(dir + "/be.ply", c, ply_format::binary_big_endian);
  ced::io::write_ply(dir + "/ascii.ply", c, ply_format::ascii);
  const point_cloud le = ced::io::read_ply(dir + "/le.ply");
  ASSERT_EQ(le.size(), n);
  EXPECT_EQ(le.get_field("u32").values, c.get_field("u32").values);
  expect_same_cloud(le, ced::io::read_ply(dir + "/be.ply"));
  expect_same_cloud(le, ced::io::read_ply(dir + "/ascii.ply"));
  std::ifstream in(dir + "/le.ply", std::ios::binary);
  expect_same_cloud(le, ced::io::read_ply(in, "le.ply"));
  // With a list property after the vertex's scalars, records are read one by one.
  std::string bytes = read_bytes(dir + "/le.ply");
  const std::string end = "end_header\n";
  const std::size_t body = bytes.find(end) + end.size();
  std::string listed = bytes.substr(0, body - end.size()) + "property list uchar int none\n" + end;
  for (std::size_t i = 0, record = 12 * 2 + 1 + 2 + 4 + 4 + 8; i < n; ++i)
    listed += bytes.substr(body + i * record, record) + std::string(1, '\0');
  expect_same_cloud(le, read_string(listed));

  // Only the selected fields; the same values.
  ced::io::read_options o;
  o.fields = ced::field_selection::only({"f32", "RED"});
  const point_cloud some = ced::io::read_cloud(dir + "/le.ply", o);
  ASSERT_EQ(some.fields().size(), 2u);
  EXPECT_EQ(some.fields()[0].name, "red");
  EXPECT_EQ(some.fields()[1].name, "f32");
  EXPECT_EQ(some.positions(), le.positions());
  EXPECT_EQ(some.fields()[0].values, le.get_field("red").values);

  // The stream's chunks, after a first pass, are the same points.
  auto s = ced::io::open_point_stream(dir + "/be.ply");
  point_cloud chunk;
  while (s->read(25000, {0, 0, 0}, chunk) > 0) {
  }
  EXPECT_EQ(s->origin(), le.origin());
  s->rewind();
  std::size_t at = 0;
  while (s->read(7777, s->origin(), chunk) > 0) {
    for (std::size_t i = 0; i < 3 * chunk.size(); ++i)
      ASSERT_TRUE(chunk.positions()[i] == le.positions()[3 * at + i] ||
                  (std::isnan(chunk.positions()[i]) && std::isnan(le.positions()[3 * at + i])));
    ASSERT_EQ(chunk.fields().size(), le.fields().size());
    for (std::size_t f = 0; f < le.fields().size(); ++f)
      ASSERT_EQ(std::memcmp(chunk.fields()[f].values.bytes(),
                            le.fields()[f].values.bytes() + at * ced::size_of(le.fields()[f].type()),
                            chunk.size() * ced::size_of(le.fields()[f].type())),
                0);
    at += chunk.size();
  }
  EXPECT_EQ(at, n);
}

TEST(PlyErrors, TruncatedLargeBinaryFileNamesTheFile) {
  point_cloud c;
  for (int i = 0; i < 50000; ++i) c.push_back(float(i), 1, 2);
  std::stringstream s;
  ced::io::write_ply(s, c, ply_format::binary_little_endian);
  const std::string bytes = s.str();
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 12 * 20000 - 3)),
                  "file ends after 29999 of 50000 vertices");
}

TEST(PlyRead, SignallingNaNsAreQuietedAsAlways) {
  // Values have always gone through double on their way in and out (a
  // signalling NaN comes out quiet); the typed readers and writers keep that.
  point_cloud c;
  for (int i = 0; i < 3; ++i) c.push_back(float(i), 0, 0);
  c.add_field("f", scalar_type::float32, std::vector<double>(3, 0.0));
  const std::uint32_t signalling = 0x7fa00001u, quiet = 0x7fe00001u;
  std::memcpy(c.fields()[0].values.bytes() + 4, &signalling, 4);
  std::stringstream s;
  ced::io::write_ply(s, c, ply_format::binary_little_endian);
  std::string bytes = s.str();
  std::uint32_t written = 0;
  std::memcpy(&written, bytes.data() + bytes.size() - 16 - 4, 4);  // point 1's f
  EXPECT_EQ(written, quiet);
  std::memcpy(bytes.data() + bytes.size() - 16 - 4, &signalling, 4);
  const std::string path = temp_file("snan.ply");
  write_bytes(path, bytes);
  std::uint32_t read = 0;
  std::memcpy(&read, ced::io::read_ply(path).get_field("f").values.bytes() + 4, 4);
  EXPECT_EQ(read, quiet);
}
