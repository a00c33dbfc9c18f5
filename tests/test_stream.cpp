// SPDX-License-Identifier: MIT
// Clouds read in chunks (ced/io/stream.hpp): after a first pass and
// rewind(), the chunks of every format put together are bit for bit the
// cloud read_cloud() reads; truncated files are io_errors.

#include "stream_test_support.hpp"

using namespace stream_test;

TEST(Stream, Las) {
  const point_cloud cloud = georeferenced_cloud(100);
  const std::string path = temp_file("s.las");
  ced::io::write_las(path, cloud);
  expect_stream_reads_like_read_cloud(path, {}, true);
  read_options only;
  only.fields = ced::field_selection::only({"intensity", "RED"});
  expect_stream_reads_like_read_cloud(path, only, true);
  expect_truncated_fails(read_bytes(path), 5, "s_cut.las", {}, false);
}

TEST(Stream, PlyBinaryLittleAndBigEndian) {
  const point_cloud cloud = georeferenced_cloud(100);
  for (auto f : {ced::io::ply_format::binary_little_endian, ced::io::ply_format::binary_big_endian}) {
    const std::string name = f == ced::io::ply_format::binary_big_endian ? "be" : "le";
    const std::string path = temp_file("s_" + name + ".ply");
    ced::io::write_ply(path, cloud, f);
    const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true);
    EXPECT_NEAR(got.origin()[0], 500030, 2);
    read_options only;
    only.fields = ced::field_selection::only({"gps_time", "label", "Class8"});
    const point_cloud some = expect_stream_reads_like_read_cloud(path, only, true);
    EXPECT_EQ(some.fields().size(), 3u);
    expect_truncated_fails(read_bytes(path), 5, "s_cut_" + name + ".ply");
    expect_truncated_fails(read_bytes(path), 3000, "s_cut2_" + name + ".ply");
  }
}

TEST(Stream, PlyAsciiIsReadWhole) {
  const point_cloud cloud = georeferenced_cloud(100);
  const std::string path = temp_file("s_ascii.ply");
  ced::io::write_ply(path, cloud, ced::io::ply_format::ascii);
  expect_stream_reads_like_read_cloud(path, {}, false);
  expect_truncated_fails(read_bytes(path), 40, "s_cut_ascii.ply");
}

/// Vertices with a list property (records of varying size), elements before
/// and after them, a header longer than the stream's first read, and
/// non-finite coordinates (which PLY keeps).
std::string ply_with_lists(bool big) {
  std::string head = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") + " 1.0\n";
  for (int i = 0; i < 2000; ++i) head += "comment a long header, longer than one read of the stream's\n";
  head +=
      "element camera 2\nproperty list uchar float params\n"
      "element vertex 50\nproperty double x\nproperty double y\nproperty double z\n"
      "property list uchar int neighbours\nproperty ushort intensity\nproperty uint64 id\n"
      "element face 3\nproperty list uchar int vertex_indices\nend_header\n";
  bytes_builder b{head, big};
  b.put(std::uint8_t(2)).put(1.f).put(2.f);
  b.put(std::uint8_t(0));
  for (int i = 0; i < 50; ++i) {
    b.put(i == 13 ? nan_v : 612345.25 + i).put(5123456.5 - i * 0.25).put(i == 20 ? -nan_v : 12.0 + i * 1e-3);
    b.put(std::uint8_t(i % 4));
    for (int k = 0; k < i % 4; ++k) b.put(std::int32_t(i + k));
    b.put(std::uint16_t(i * 1000));
    b.put(std::uint64_t(1) << 60 | std::uint64_t(i));
  }
  for (int f = 0; f < 3; ++f) b.put(std::uint8_t(3)).put(std::int32_t(f)).put(std::int32_t(f + 1)).put(std::int32_t(0));
  return b.data;
}

TEST(Stream, PlyWithListsAndOtherElements) {
  for (bool big : {false, true}) {
    const std::string bytes = ply_with_lists(big);
    const std::string path = temp_file(big ? "lists_be.ply" : "lists_le.ply");
    write_bytes(path, bytes);
    const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true);
    ASSERT_EQ(got.size(), 50u);
    EXPECT_EQ(got.origin(), (std::array<double, 3>{612370, 5123450, 0}));
    EXPECT_TRUE(std::isnan(got.position(13)[0]));
    EXPECT_EQ(got.get_field("id").type(), scalar_type::uint64);
    expect_truncated_fails(bytes, 2, big ? "lists_cut_face_be.ply" : "lists_cut_face_le.ply");  // in the faces
    expect_truncated_fails(bytes, 100, big ? "lists_cut_be.ply" : "lists_cut_le.ply");          // in the vertices
  }
}

TEST(Stream, PcdBinary) {
  const point_cloud cloud = georeferenced_cloud(100);
  const std::string path = temp_file("s.pcd");
  ced::io::write_pcd(path, cloud, ced::io::pcd_format::binary);
  const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true);
  EXPECT_NE(got.find_field("red"), nullptr);  // unpacked from rgb
  read_options only;
  only.fields = ced::field_selection::only({"green", "curv"});
  expect_stream_reads_like_read_cloud(path, only, true);
  expect_truncated_fails(read_bytes(path), 5, "s_cut.pcd");
}

// point_stream::read_points (a tiled run's fetch of its keypoints' records):
// fixed-size binary records read at their offsets, each point as the whole
// read gives it; PLY records with lists and text files say no.
TEST(Stream, PointsReadAtTheirRecords) {
  const point_cloud cloud = georeferenced_cloud(3000);
  std::vector<std::string> paths;
  for (auto f : {ced::io::ply_format::binary_little_endian, ced::io::ply_format::binary_big_endian}) {
    paths.push_back(temp_file(f == ced::io::ply_format::binary_big_endian ? "rp_be.ply" : "rp_le.ply"));
    ced::io::write_ply(paths.back(), cloud, f);
  }
  paths.push_back(temp_file("rp.pcd"));
  ced::io::write_pcd(paths.back(), cloud, ced::io::pcd_format::binary);
  std::vector<std::uint64_t> at;  // ends, a dense run, gaps of every size (past a 1 MiB window too)
  for (std::uint64_t i = 0; i < cloud.size(); i += 1 + i / 2) at.push_back(i);
  at.push_back(cloud.size() - 1);
  for (const std::string& path : paths) {
    SCOPED_TRACE(path);
    const point_cloud all = ced::io::read_cloud(path);
    auto s = ced::io::open_point_stream(path);
    point_cloud got;
    ASSERT_TRUE(s->read_points(at, {}, all.origin(), got));
    ASSERT_EQ(got.size(), at.size());
    ASSERT_EQ(got.fields().size(), all.fields().size());
    for (std::size_t j = 0; j < at.size(); ++j) {
      ASSERT_EQ(0, std::memcmp(got.position(j), all.position(at[j]), 12)) << j;
      for (std::size_t f = 0; f < got.fields().size(); ++f) {
        ASSERT_EQ(got.fields()[f].name, all.fields()[f].name);
        ASSERT_EQ(got.fields()[f].values[j], all.fields()[f].values[at[j]]) << got.fields()[f].name << " " << j;
      }
    }
    EXPECT_THROW(ced::io::open_point_stream(path)->read_points({5, 5}, {}, all.origin(), got), std::logic_error);
    EXPECT_THROW(ced::io::open_point_stream(path)->read_points({cloud.size()}, {}, all.origin(), got),
                 std::logic_error);
  }
  const std::string lists = temp_file("rp_lists.ply"), text = temp_file("rp_ascii.ply");
  write_bytes(lists, ply_with_lists(false));
  ced::io::write_ply(text, cloud, ced::io::ply_format::ascii);
  for (const std::string& path : {lists, text}) {
    point_cloud got;
    EXPECT_FALSE(ced::io::open_point_stream(path)->read_points({0, 1}, {}, {0, 0, 0}, got)) << path;
  }
}

TEST(Stream, PcdBinaryOrganizedKeepsNaNPoints) {
  // 10 x 10 image, double coordinates, packed rgb, padding, a COUNT 2 field;
  // every 7th pixel invalid (NaN, or one coordinate infinite).
  std::string head =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb _ normal intensity\nSIZE 8 8 8 4 1 4 2\n"
      "TYPE F F F F U F U\nCOUNT 1 1 1 1 3 2 1\nWIDTH 10\nHEIGHT 10\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 100\n";
  for (int i = 0; i < 1500; ++i) head += "# padding the header past the stream's first read of the file\n";
  head += "DATA binary\n";
  bytes_builder b{head};
  const double inf = std::numeric_limits<double>::infinity();
  std::size_t invalid = 0;
  for (int i = 0; i < 100; ++i) {
    const bool bad = i % 7 == 3;
    invalid += bad;
    b.put(bad && i % 2 ? nan_v : 431000.5 + (i % 10) * 0.1)
        .put(5.4e6 + (i / 10) * 0.1)
        .put(bad && !(i % 2) ? inf : 50.0);
    b.put(std::uint32_t(0x00102030u + std::uint32_t(i)));
    b.put(std::uint8_t(1)).put(std::uint8_t(2)).put(std::uint8_t(3));
    b.put(float(i) * 0.5f).put(-float(i));
    b.put(std::uint16_t(i * 600));
  }
  const std::string path = temp_file("organized.pcd");
  write_bytes(path, b.data);
  ced::io::read_report report;
  const point_cloud want = ced::io::read_cloud(path, {}, &report);
  EXPECT_EQ(report.nonfinite_removed, invalid);
  EXPECT_EQ(report.details, "PCD binary, organized 10x10");
  const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true, true);
  EXPECT_EQ(got.size(), 100u);  // every record
  EXPECT_EQ(want.size(), 100u - invalid);
  EXPECT_NE(got.find_field("normal_1"), nullptr);
  expect_truncated_fails(b.data, 1, "organized_cut.pcd");
}

TEST(Stream, PcdAsciiIsReadWhole) {
  const point_cloud cloud = georeferenced_cloud(100);
  const std::string path = temp_file("s_ascii.pcd");
  ced::io::write_pcd(path, cloud, ced::io::pcd_format::ascii);
  expect_stream_reads_like_read_cloud(path, {}, false);
  const std::string compressed = temp_file("s_compressed.pcd");
  ced::io::write_pcd(compressed, cloud, ced::io::pcd_format::binary_compressed);
  expect_stream_reads_like_read_cloud(compressed, {}, false);
  expect_truncated_fails(read_bytes(path), 60, "s_cut_ascii.pcd");
}

TEST(Stream, CsvWithHeader) {
  const point_cloud cloud = georeferenced_cloud(100);
  const std::string path = temp_file("s.csv");
  ced::io::write_csv(path, cloud);
  const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true);
  EXPECT_EQ(got.get_field("red").type(), scalar_type::uint8);
  EXPECT_EQ(got.get_field("label").type(), scalar_type::int32);
  EXPECT_EQ(got.get_field("curv").type(), scalar_type::float64);
  read_options only;
  only.fields = ced::field_selection::only({"intensity", "blue"});
  expect_stream_reads_like_read_cloud(path, only, true);
  const std::string bytes = read_bytes(path);
  expect_truncated_fails(bytes, 30, "s_cut.csv");  // the last line loses values
}

TEST(Stream, CsvTypesDependOnEveryValue) {
  // A byte order mark, CRLF, comments and blank lines; the last lines make
  // `red` int32 (300) and `label` float64 (2.5): a stream learns that in its
  // first pass.
  std::string text = "\xEF\xBB\xBF# exported\r\n\r\nX;Y;Z;r;g;b;label\r\n";
  for (int i = 0; i < 40; ++i)
    text += std::to_string(700000 + i) + ".125;" + std::to_string(3000000 - i) + ".5;" + std::to_string(i % 9) + ";" +
            std::to_string(i * 6) + ";" + std::to_string(i) + ";7;" + std::to_string(i - 20) + "\r\n" +
            (i % 10 == 0 ? "// a comment\r\n\r\n" : "");
  text += "700050;2999950;1;300;1;2;2.5\r\nnan;1;2;3;4;5;6\r\n";
  const std::string path = temp_file("types.txt");
  write_bytes(path, text);
  const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true);
  EXPECT_EQ(got.get_field("red").type(), scalar_type::int32);
  EXPECT_EQ(got.get_field("green").type(), scalar_type::uint8);
  EXPECT_EQ(got.get_field("label").type(), scalar_type::float64);
  EXPECT_EQ(got.origin(), (std::array<double, 3>{700025, 2999975, 0}));
}

TEST(Stream, CsvWithColumnsOption) {
  // No header: the columns are named by the options; space-separated, with
  // a line to skip.
  std::string text = "this line is skipped\n";
  for (int i = 0; i < 60; ++i)
    text += std::to_string(523000.0 + i * 0.37) + "  " + std::to_string(4100000.0 + i * 0.11) + "\t" +
            std::to_string(88.0 + i * 0.01) + " " + std::to_string(i * 100) + " " + std::to_string(i % 256) + " " +
            std::to_string((i * 7) % 256) + " " + std::to_string(255 - i) + "\n";
  const std::string path = temp_file("columns.xyz");
  write_bytes(path, text);
  read_options options;
  options.csv.columns = {"x", "y", "z", "intensity", "R", "G", "B"};
  options.csv.skip_header = true;
  options.csv.delimiter = ' ';
  const point_cloud got = expect_stream_reads_like_read_cloud(path, options, true);
  EXPECT_EQ(got.get_field("red").type(), scalar_type::uint8);
  options.fields = ced::field_selection::only({"intensity"});
  expect_stream_reads_like_read_cloud(path, options, true);
  options.fields = {};
  expect_truncated_fails(text, 12, "columns_cut.xyz", options);
}

TEST(Stream, CsvPtsPointCount) {
  // A Leica .pts file: its point count, then 7 values a line.
  std::string text = "25\n";
  for (int i = 0; i < 25; ++i)
    text += std::to_string(1e5 + i) + " " + std::to_string(2e5 - i) + " 3.5 -1200 " + std::to_string(i) + " 2 3\n";
  const std::string path = temp_file("scan.pts");
  write_bytes(path, text);
  const point_cloud got = expect_stream_reads_like_read_cloud(path, {}, true);
  EXPECT_EQ(got.size(), 25u);
  EXPECT_EQ(got.get_field("intensity").type(), scalar_type::int32);
}

TEST(Stream, EmptyAndHeaderOnlyFiles) {
  const std::string ply = temp_file("empty.ply");
  ced::io::write_ply(ply, point_cloud{}, ced::io::ply_format::binary_little_endian);
  expect_stream_reads_like_read_cloud(ply, {}, true);
  const std::string pcd = temp_file("empty.pcd");
  ced::io::write_pcd(pcd, point_cloud{}, ced::io::pcd_format::binary);
  expect_stream_reads_like_read_cloud(pcd, {}, true);
  const std::string csv = temp_file("header_only.csv");
  write_bytes(csv, "x,y,z,intensity\n");
  const auto s = ced::io::open_point_stream(csv);
  point_cloud c;
  EXPECT_EQ(s->read(7, {0, 0, 0}, c), 0u);
  EXPECT_EQ(ced::io::read_cloud(csv).size(), 0u);
}

TEST(Stream, HeaderErrorsAreReadCloudsErrors) {
  const std::vector<std::pair<std::string, std::string>> files = {
      {"bad1.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"},
      {"bad2.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n"},
      {"bad3.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n0123456789"},
      {"bad4.ply", "not a ply"},
      {"bad1.pcd", "VERSION 0.7\nFIELDS x y z\nBOGUS 1\nWIDTH 1\nDATA binary\n"},
      {"bad2.pcd", "VERSION 0.7\nFIELDS x y z\nBOGUS 1\n"},
      {"bad3.pcd", "VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nDATA binary\n12345678"},
      {"bad4.pcd", "VERSION 0.7\nFIELDS x y z\nWIDTH 100\nDATA binary\n12345678"},
      {"bad1.csv", ""},
      {"bad2.csv", "x,y,q\n1,2,3\n"},
      {"bad3.csv", "1 2 3 4 5\n"},
      {"bad4.csv", "x,y,z\n1,2,3\n1,2,3\n1,2\n"},
      {"bad5.csv", "x,y,z\n1,2,3\n1,2,abc\n"},
  };
  for (const auto& [name, bytes] : files) {
    const std::string path = temp_file(name);
    write_bytes(path, bytes);
    const std::string want = read_cloud_error(path);
    EXPECT_NE(want, "<no io_error thrown>") << name;
    EXPECT_EQ(stream_error(path), want) << name;
  }
  EXPECT_EQ(stream_error(temp_file("missing.ply")), read_cloud_error(temp_file("missing.ply")));
}

namespace {
/// Drops the points whose (float) position is not finite.
void drop_nonfinite_points(point_cloud& c) {
  std::vector<std::uint8_t> keep(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) keep[i] = finite3(c.position(i));
  c.filter(keep);
}

/// What reading `path` gives: the cloud (a stream's put together, after a
/// first pass, non-finite points dropped when `drop_nonfinite`), or the
/// io_error's message.
struct outcome {
  std::string error;
  point_cloud cloud;
};

outcome stream_outcome(const std::string& path, bool drop_nonfinite) {
  outcome o;
  try {
    const auto s = ced::io::open_point_stream(path);
    point_cloud c;
    while (s->read(7, {0, 0, 0}, c) > 0) {
    }
    s->rewind();
    std::vector<point_cloud> chunks;
    while (s->read(7, s->origin(), c) > 0) chunks.push_back(c);
    o.cloud = concatenate(chunks, s->origin());
    if (drop_nonfinite) drop_nonfinite_points(o.cloud);
  } catch (const io_error& e) {
    o.error = e.what();
  }
  return o;
}

/// The same from read_cloud(). PCD drops the points whose coordinates are not
/// finite, as doubles: a finite one may still overflow the float relative
/// position (a damaged file's 1e300), which the stream's caller would drop too.
outcome read_cloud_outcome(const std::string& path, bool drop_nonfinite_floats) {
  outcome o;
  try {
    o.cloud = ced::io::read_cloud(path);
    if (drop_nonfinite_floats) drop_nonfinite_points(o.cloud);
  } catch (const io_error& e) {
    o.error = e.what();
  }
  return o;
}
}  // namespace

TEST(Stream, DamagedFilesBehaveAsReadCloud) {
  // Bytes changed or cut at random: the stream fails with read_cloud()'s
  // message, or reads its cloud.
  std::string csv = "x,y,z,intensity,red\n";
  for (int i = 0; i < 30; ++i)
    csv += std::to_string(200000 + i * 3) + ".5," + std::to_string(-7e5 - i) + ",1e1," + std::to_string(i) + "," +
           std::to_string(i * 9) + "\n";
  point_cloud small = georeferenced_cloud(30);
  std::ostringstream le(std::ios::binary), pcd(std::ios::binary);
  ced::io::write_ply(le, small, ced::io::ply_format::binary_little_endian);
  ced::io::write_pcd(pcd, small, ced::io::pcd_format::binary);
  const std::vector<std::pair<std::string, std::string>> seeds = {
      {"fuzz.ply", le.str()}, {"fuzz_lists.ply", ply_with_lists(true)}, {"fuzz.pcd", pcd.str()}, {"fuzz.csv", csv}};
  std::mt19937 rng(2024);
  for (const auto& [name, bytes] : seeds) {
    // The damage falls on the header (and the first points) more often: that is where decisions are taken.
    const std::size_t hot = std::min<std::size_t>(bytes.size(), bytes.find_last_of('\n', bytes.size() / 2) + 200);
    for (int round = 0; round < 150; ++round) {
      std::string b = bytes;
      const int kind = round % 3;
      if (kind == 0) {
        b.resize(std::uniform_int_distribution<std::size_t>(0, b.size() - 1)(rng));
      } else {
        const std::size_t range = kind == 1 ? std::min(hot, b.size()) : b.size();
        for (int k = 0; k < 3; ++k) {
          const std::size_t at = std::uniform_int_distribution<std::size_t>(0, range - 1)(rng);
          const char pool[] = "0123456789 \n,.-eEnx\xff\x00";
          b[at] = round % 2 ? pool[std::uniform_int_distribution<std::size_t>(0, sizeof(pool) - 2)(rng)]
                            : static_cast<char>(rng());
        }
      }
      const std::string path = temp_file(std::to_string(round) + name);
      write_bytes(path, b);
      const bool is_pcd = name.find(".pcd") != std::string::npos;
      const outcome want = read_cloud_outcome(path, is_pcd);
      const outcome got = stream_outcome(path, is_pcd);
      SCOPED_TRACE(name + " round " + std::to_string(round));
      EXPECT_EQ(got.error, want.error);
      if (want.error.empty() && got.error.empty()) {
        if (want.cloud.empty())  // no chunks: no fields to compare
          EXPECT_EQ(got.cloud.size(), 0u);
        else
          expect_bitwise_equal(got.cloud, want.cloud);
      }
      std::filesystem::remove(path);
    }
  }
}
