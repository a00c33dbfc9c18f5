// SPDX-License-Identifier: MIT
// PCD errors and threads: malformed files are io_errors naming the problem; ascii
// blocks read on threads give the one-thread cloud and errors.

#include "pcd_test_support.hpp"

using namespace pcd_test;

// ------------------------------------------------------------------ errors

TEST(PcdErrors, MissingFileAndNotAPcd) {
  try {
    ced::io::read_pcd(temp_file("does_not_exist.pcd"));
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "cannot open");
    EXPECT_CONTAINS(e.what(), "does_not_exist.pcd");
  }
  EXPECT_CONTAINS(read_error("ply\nformat ascii 1.0\n"), "not a PCD file");
  EXPECT_CONTAINS(read_error(""), "no DATA line");
}

TEST(PcdErrors, HeaderProblems) {
  const std::string tail = "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n0 0 0\n";
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + tail),
                  "SIZE lists 2 values but FIELDS names 3 fields");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F F\nCOUNT 1 1 1\n" + tail),
                  "TYPE lists 4 values but FIELDS names 3 fields");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1\n" + tail),
                  "COUNT lists 2 values but FIELDS names 3 fields");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 2\nTYPE F F F\n" + tail),
                  "field 'z': unsupported TYPE F with SIZE 2");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\n" + tail), "invalid TYPE 'Q'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nCOUNT 1 1 0\n" + tail), "invalid COUNT '0'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y\n" + tail), "no 'z' field");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z x\n" + tail), "field 'x' is declared twice");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nCOLOUR 1\n" + tail), "unknown header keyword 'COLOUR'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nWIDTH -1\nDATA ascii\n"), "invalid WIDTH line");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n"),
                  "POINTS (3) does not equal WIDTH × HEIGHT (2 × 2 = 4)");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nDATA ascii\n"), "neither WIDTH nor POINTS");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nPOINTS 1\nDATA binary_lzma\n"),
                  "unknown DATA format 'binary_lzma'");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nPOINTS 1\n0 0 0\n"), "the PCD header has no DATA line");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nSIZE 4 4 4\nPOINTS 1\nDATA ascii\n0 0 0\n"), "no FIELDS line");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z red rgb\nPOINTS 1\nDATA ascii\n0 0 0 1 1\n"),
                  "two fields would be named 'red'");
}

TEST(PcdErrors, AbsurdPointCountIsRejectedBeforeAllocating) {
  const std::string head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4000000000\nPOINTS 4000000000\n";
  EXPECT_CONTAINS(read_error(head + "DATA binary\n" + std::string(12, '\0')),
                  "truncated: POINTS declares 4000000000 points of 12 bytes, but only 12 bytes");
  EXPECT_CONTAINS(read_error(head + "DATA ascii\n0 0 0\n"), "truncated: POINTS declares 4000000000 points");
  EXPECT_CONTAINS(read_error(head + "DATA binary_compressed\n" + u32_bytes(4) + u32_bytes(0xffffffffu) + "\x03xyzw"),
                  "does not match POINTS × point size");
  const std::string ok = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000000\nPOINTS 1000000\n";
  EXPECT_CONTAINS(read_error(ok + "DATA binary_compressed\n" + u32_bytes(4) + u32_bytes(12000000) + "\x03xyzw"),
                  "implausible binary_compressed sizes");
  EXPECT_CONTAINS(read_error("VERSION 0.7\nFIELDS x y z\nWIDTH 18446744073709551615\nHEIGHT 2\nDATA binary\n"),
                  "overflows");
}

TEST(PcdErrors, TruncatedBinary) {
  point_cloud c;
  for (int i = 0; i < 100; ++i) c.push_back(float(i), 1, 2);
  const std::string bytes = write_string(c, pcd_format::binary);
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 5)),
                  "truncated: POINTS declares 100 points of 12 bytes, but only 1195 bytes of binary data follow");
}

TEST(PcdErrors, TruncatedCompressed) {
  const std::string bytes = write_string(big_cloud(1000), pcd_format::binary_compressed);
  const std::size_t body = bytes.find("DATA binary_compressed\n") + 23;
  EXPECT_CONTAINS(read_error(bytes.substr(0, bytes.size() - 10)), "truncated: the binary_compressed data declares");
  EXPECT_CONTAINS(read_error(bytes.substr(0, body + 5)), "has no size header");
  // Consistent sizes but the LZF stream cut short.
  std::string cut = bytes.substr(0, bytes.size() - 10);
  std::uint32_t size = 0;
  std::memcpy(&size, cut.data() + body, 4);
  size -= 10;
  std::memcpy(cut.data() + body, &size, 4);
  EXPECT_CONTAINS(read_error(cut), "corrupt LZF data");
}

TEST(PcdErrors, BadLzfInAFile) {
  const std::string head = header(1, "binary_compressed");
  // Back-reference before the start.
  EXPECT_CONTAINS(read_error(head + u32_bytes(2) + u32_bytes(12) + std::string("\x20\x02", 2)),
                  "corrupt LZF data (a back-reference at input offset 0 points before the start");
  // Output overflow: 13 literal bytes for 12.
  EXPECT_CONTAINS(read_error(head + u32_bytes(14) + u32_bytes(12) + "\x0c" + std::string(13, 'a')),
                  "corrupt LZF data (the output would exceed the declared 12 bytes)");
  // Flipped control byte of a real stream.
  std::string bytes = write_string(big_cloud(1000), pcd_format::binary_compressed);
  const std::size_t body = bytes.find("DATA binary_compressed\n") + 23;
  bytes[body + 8] = static_cast<char>(0xff);
  EXPECT_CONTAINS(read_error(bytes), "corrupt LZF data");
}

TEST(PcdErrors, BadAscii) {
  const std::string head = header(3, "ascii", "x y z red", "4 4 4 1", "F F F U", "1 1 1 1");
  const std::size_t first_data_line = 12;  // header() writes 11 lines
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 2\n1 abc 3 4\n"),
                  "line " + std::to_string(first_data_line + 2) + ", field 'y': 'abc' is not a number");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 300\n1 1 1 1\n"),
                  "line " + std::to_string(first_data_line + 1) + ", field 'red': '300' is out of range for uint8");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1.5\n0 0 0 1\n0 0 0 1\n"), "'1.5' is not an integer");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n0.0 0.0 0.0\n0 0 0 1\n"),
                  "line " + std::to_string(first_data_line + 1) + ": expected 4 values, found 3");
  EXPECT_CONTAINS(read_error(head + "0 0 0 1\n1 1 1 1\n" + std::string(20, '\n')),
                  "truncated: the file ends after 2 of 3 points");
  const std::string normal = header(1, "ascii", "x y z n", "4 4 4 4", "F F F F", "1 1 1 2");
  EXPECT_CONTAINS(read_error(normal + "0 0 0 1 x\n"), "field 'n_1': 'x' is not a number");
}

TEST(PcdErrors, StreamNameIsUsedInMessages) {
  try {
    ced::io::read_pcd_buffer("nope", "my_buffer");
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "my_buffer");
  }
}

// ------------------------------------------------------------- threads

namespace {
/// An ascii PCD of about 5 MB, blank lines here and there, `points` points
/// declared; `bad`: points whose intensity is not a number; `lines` lines
/// of points written (fewer than declared: truncated).
std::string big_ascii_pcd(std::size_t points, std::size_t lines, const std::vector<std::size_t>& bad = {}) {
  std::mt19937 rng(9);
  std::ostringstream s;
  s << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity n\nSIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 2\n"
    << "WIDTH " << points << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << points << "\nDATA ascii\n";
  for (std::size_t i = 0; i < lines; ++i) {
    if (i % 7001 == 0) s << "\n  \n";
    s << (rng() % 100000) * 0.001 << " " << (rng() % 100000) * 0.001 << " " << -(double(rng() % 5000) * 0.01) << " ";
    if (std::find(bad.begin(), bad.end(), i) != bad.end())
      s << "x";
    else
      s << rng() % 4096;
    s << " " << (rng() % 100) * 0.01 << " " << (rng() % 100) * 0.01 << "\n";
  }
  if (lines == points) s << "trailing text after the last point is not read\n";
  return s.str();
}

point_cloud read_pcd_on(unsigned threads, const std::string& text) {
  point_cloud c;
  ced::detail::with_thread_limit(threads, [&] { c = ced::io::read_pcd_buffer(text, "big.pcd"); });
  return c;
}

std::string pcd_error_on(unsigned threads, const std::string& text) {
  return ced_test::io_error_of([&] { read_pcd_on(threads, text); });
}
}  // namespace

TEST(PcdThreads, AsciiBlocksOfLinesOnThreadsGiveTheCloudOfOneThread) {
  const std::string text = big_ascii_pcd(150000, 150000);
  ASSERT_GT(text.size(), std::size_t(4) << 20);  // several blocks of 1 MiB
  const point_cloud want = read_pcd_on(1, text);
  ASSERT_EQ(want.size(), 150000u);
  for (unsigned threads : {2u, 3u}) {
    SCOPED_TRACE(threads);
    ced_test::expect_same_cloud(read_pcd_on(threads, text), want);
  }
}

TEST(PcdThreads, AsciiErrorsAreTheOnesOfOneThread) {
  // The first bad value in the file, with its line number, and a truncated
  // file (fewer lines than points), the same on 1, 2 and 3 threads.
  for (const std::string& text : {big_ascii_pcd(150000, 150000, {120000, 70000}), big_ascii_pcd(150000, 140000)}) {
    const std::string want = pcd_error_on(1, text);
    for (unsigned threads : {2u, 3u}) EXPECT_EQ(pcd_error_on(threads, text), want) << threads << " threads";
  }
  // Line 11 is DATA; point i is on line 12 + i plus two blank lines per 7001 points before it.
  EXPECT_NE(pcd_error_on(2, big_ascii_pcd(150000, 150000, {120000, 70000}))
                .find("line " + std::to_string(12 + 70000 + 2 * (70000 / 7001 + 1)) + ", field 'intensity'"),
            std::string::npos);
  EXPECT_NE(pcd_error_on(2, big_ascii_pcd(150000, 140000)).find("the file ends after 140000 of 150000 points"),
            std::string::npos);
}
