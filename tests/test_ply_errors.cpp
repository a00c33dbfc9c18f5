// SPDX-License-Identifier: MIT
// PLY errors and threads: malformed files are io_errors naming the problem; ascii
// blocks read on threads give the one-thread cloud and errors.

#include "ply_test_support.hpp"

using namespace ply_test;

// ----------------------------------------------------------------- errors

namespace {
const std::string xyz_header_start = "ply\nformat ascii 1.0\nelement vertex ";
const std::string xyz_props = "property float x\nproperty float y\nproperty float z\n";
}  // namespace

TEST(PlyErrors, NotAPlyFile) {
  EXPECT_CONTAINS(read_error("plx\nformat ascii 1.0\n"), "not a PLY file");
  EXPECT_CONTAINS(read_error(""), "not a PLY file");
  EXPECT_CONTAINS(read_error("OFF\n3 1 0\n"), "not a PLY file");
}

TEST(PlyErrors, MissingFile) {
  try {
    ced::io::read_ply(temp_file("does_not_exist.ply"));
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "cannot open");
    EXPECT_CONTAINS(e.what(), "does_not_exist.ply");
  }
  EXPECT_THROW(ced::io::read_ply(temp_dir().string()), io_error);
}

TEST(PlyErrors, MissingEndHeader) {
  EXPECT_CONTAINS(read_error("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz_props + "0 0 0\n"), "no end_header");
}

TEST(PlyErrors, UnknownFormatTypeAndKeyword) {
  EXPECT_CONTAINS(read_error("ply\nformat binary_middle_endian 1.0\nend_header\n"),
                  "unknown PLY format 'binary_middle_endian'");
  EXPECT_CONTAINS(read_error("ply\nformat ascii 2.0\nend_header\n"), "unsupported PLY version");
  EXPECT_CONTAINS(read_error(xyz_header_start + "1\nproperty float128 x\nend_header\n"),
                  "unknown property type 'float128'");
  EXPECT_CONTAINS(read_error(xyz_header_start + "1\n" + xyz_props + "propertee float w\nend_header\n0 0 0\n"),
                  "unknown header keyword 'propertee'");
  EXPECT_CONTAINS(read_error("ply\nelement vertex 1\n" + xyz_props + "end_header\n0 0 0\n"), "no format line");
  EXPECT_CONTAINS(read_error(xyz_header_start + "-1\n" + xyz_props + "end_header\n"), "invalid count '-1'");
}

TEST(PlyErrors, MissingVertexElementOrCoordinate) {
  EXPECT_CONTAINS(read_error("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\n"
                             "end_header\n"),
                  "no 'vertex' element");
  EXPECT_CONTAINS(read_error(xyz_header_start + "1\nproperty float x\nproperty float y\nend_header\n0 0\n"),
                  "no 'z' property");
}

TEST(PlyErrors, ImplausibleCountIsRejectedBeforeAllocating) {
  const std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n" + xyz_props +
                             "end_header\n" + std::string(12, '\0');
  EXPECT_CONTAINS(read_error(binary), "implausible element count");
  EXPECT_CONTAINS(read_error(xyz_header_start + "4000000000\n" + xyz_props + "end_header\n0 0 0\n"),
                  "implausible element count");
  // Also for a skipped element with lists.
  EXPECT_CONTAINS(read_error("ply\nformat binary_little_endian 1.0\nelement face 18446744073709551615\n"
                             "property list uchar int vertex_indices\nelement vertex 0\n" +
                             xyz_props + "end_header\n\x03"),
                  "implausible element count");
}

TEST(PlyErrors, TruncatedBinary) {
  point_cloud c;
  for (int i = 0; i < 100; ++i) c.push_back(float(i), 1, 2);
  std::stringstream s;
  ced::io::write_ply(s, c, ply_format::binary_little_endian);
  const std::string bytes = s.str();
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 5)), "file ends after 99 of 100 vertices");
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 12 * 30)), "file ends after 70 of 100 vertices");
}

TEST(PlyErrors, TruncatedBinaryWithLists) {
  bytes_builder b;
  b.data = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" + xyz_props +
           "property list uchar float extra\nend_header\n";
  b.put(0.f).put(0.f).put(0.f).put(std::uint8_t(1)).put(5.f);
  b.put(1.f).put(1.f).put(1.f).put(std::uint8_t(200));  // list claims 200 floats
  EXPECT_CONTAINS(read_error(b.data), "file ends after 1 of 3 vertices");
}

TEST(PlyErrors, TruncatedAscii) {
  std::string text = xyz_header_start + "10\n" + xyz_props + "end_header\n";
  for (int i = 0; i < 7; ++i) text += "1.25 2.5 " + std::to_string(i) + ".125\n";
  text += "4.5 ";
  EXPECT_CONTAINS(read_error(text), "file ends after 7 of 10 vertices");
}

TEST(PlyErrors, BadAsciiTokens) {
  const std::string head = xyz_header_start + "3\n" + xyz_props + "property uchar red\nend_header\n";
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 2\n1 abc 3 4\n"), "vertex 2, property 'y': 'abc' is not a number");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 300\n1 1 1 1\n"),
                  "vertex 1, property 'red': '300' is out of range for uint8");
  EXPECT_CONTAINS(read_error(head + "0 0 0 -1\n"), "vertex 0, property 'red': '-1' is out of range");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1.5\n"), "'1.5' is not an integer");
  EXPECT_CONTAINS(read_error(head + "0 0 1e39 1\n"), "'1e39' is out of range for float32");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n0,5 0 0 1\n"), "vertex 1, property 'x': '0,5' is not a number");
}

TEST(PlyErrors, StreamNameIsUsedInMessages) {
  try {
    read_string("nope", "my_stream");
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "my_stream");
  }
}

// ------------------------------------------------------------- threads

namespace {
/// An ascii PLY of about 4.5 MB: 150 000 vertices (x y z intensity red),
/// one a line, blank lines here and there, then faces; `bad`: vertices whose
/// red is not a number; `joined`: vertices written on the line of the one
/// before, `split`: vertices written on two lines (records not one a line);
/// `written`: vertices written (fewer than declared: truncated, no faces).
std::string big_ascii_ply(std::size_t written = 150000, const std::vector<std::size_t>& bad = {},
                          const std::vector<std::size_t>& joined = {}, const std::vector<std::size_t>& split = {}) {
  std::mt19937 rng(3);
  std::ostringstream s;
  s << "ply\nformat ascii 1.0\nelement vertex 150000\nproperty float x\nproperty float y\nproperty float z\n"
    << "property ushort intensity\nproperty uchar red\nelement face 3\nproperty list uchar int vertex_indices\n"
    << "end_header\n";
  for (std::size_t i = 0; i < written; ++i) {
    if (i % 6007 == 0) s << "\n \n";
    if (i > 0) s << (std::find(joined.begin(), joined.end(), i) == joined.end() ? "\n" : " ");
    s << (rng() % 100000) * 0.001 << " " << (rng() % 100000) * 0.001 << " " << -(double(rng() % 5000) * 0.01)
      << (std::find(split.begin(), split.end(), i) == split.end() ? " " : "\n") << rng() % 60000 << " ";
    if (std::find(bad.begin(), bad.end(), i) != bad.end())
      s << "red";
    else
      s << rng() % 256;
  }
  if (written == 150000) s << "\n3 0 1 2\n3 1 2 3\n3 2 3 4";
  s << "\n";
  return s.str();
}

point_cloud read_ply_on(unsigned threads, const std::string& text) {
  point_cloud c;
  ced::detail::with_thread_limit(threads, [&] {
    std::istringstream in(text);
    c = ced::io::read_ply(in, "big.ply");
  });
  return c;
}

std::string ply_error_on(unsigned threads, const std::string& text) {
  return ced_test::io_error_of([&] { read_ply_on(threads, text); });
}
}  // namespace

TEST(PlyThreads, AsciiBlocksOfLinesOnThreadsGiveTheCloudOfOneThread) {
  // Records one a line (read in blocks on the threads), and records not one
  // a line (read word by word): the cloud of one thread.
  for (const std::string& text :
       {big_ascii_ply(), big_ascii_ply(150000, {}, {100, 99000}), big_ascii_ply(150000, {}, {}, {130000})}) {
    ASSERT_GT(text.size(), std::size_t(4) << 20);
    const point_cloud want = read_ply_on(1, text);
    ASSERT_EQ(want.size(), 150000u);
    ASSERT_EQ(want.fields().size(), 2u);
    for (unsigned threads : {2u, 3u}) {
      SCOPED_TRACE(threads);
      expect_same_cloud(read_ply_on(threads, text), want);
    }
  }
}

TEST(PlyThreads, AsciiErrorsAreTheOnesOfOneThread) {
  // The first bad value (after an irregular line or not) and a truncated
  // file give the message of one thread on 2 and 3 threads.
  const std::vector<std::string> texts = {big_ascii_ply(150000, {120000, 70000}),
                                          big_ascii_ply(150000, {120000, 70000}, {50000}),
                                          big_ascii_ply(150000, {120000, 70000}, {90000}),
                                          big_ascii_ply(150000, {120000, 70000}, {}, {60000}), big_ascii_ply(140000)};
  for (const std::string& text : texts) {
    const std::string want = ply_error_on(1, text);
    EXPECT_NE(want, "<no io_error thrown>");
    for (unsigned threads : {2u, 3u}) EXPECT_EQ(ply_error_on(threads, text), want) << threads << " threads";
  }
  EXPECT_NE(ply_error_on(2, texts[0]).find("vertex 70000, property 'red': 'red'"), std::string::npos);
  EXPECT_NE(ply_error_on(2, texts[4]).find("the file ends after 140000 of 150000 vertices"), std::string::npos);
}
