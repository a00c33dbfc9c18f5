// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "ced/io/csv.hpp"
#include "core/parallel.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;
using ced::point_cloud;
using ced::scalar_type;
using ced::io::csv_options;
using ced::io::io_error;

using ced_test::read_bytes;
using ced_test::temp_dir;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace {

point_cloud read_text(const std::string& text, const csv_options& opt = {}) {
  return ced::io::read_csv_buffer(text, "test.csv", opt);
}

/// The io_error message from reading `text` (through a file named `name`).
std::string read_error(const std::string& text, const csv_options& opt = {}, const std::string& name = "bad.csv") {
  return ced_test::read_error_of([&opt](const std::string& path) { ced::io::read_csv(path, opt); }, text, name);
}

std::vector<std::string> field_names(const point_cloud& c) {
  std::vector<std::string> names;
  for (const auto& f : c.fields()) names.push_back(f.name);
  return names;
}

/// Checks a 2-point cloud (1,2,3) (4,5,6) with red=10,20.
void expect_two_points_with_red(const point_cloud& c) {
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.position(0)[0], 1.f);
  EXPECT_EQ(c.position(0)[2], 3.f);
  EXPECT_EQ(c.position(1)[1], 5.f);
  EXPECT_EQ(c.get_field("red").values, (std::vector<double>{10, 20}));
  EXPECT_EQ(c.get_field("red").type(), scalar_type::uint8);
}

}  // namespace

// ------------------------------------------------------------- round trip

TEST(CsvRoundTrip, FieldsAndPositions) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-100.f, 100.f);
  point_cloud c;
  const std::size_t n = 2000;
  std::vector<double> red(n), label(n), value(n), intensity(n), wide(n);
  for (std::size_t i = 0; i < n; ++i) {
    c.push_back(u(rng), u(rng), i == 0 ? -0.f : u(rng));
    red[i] = double(i % 256);
    label[i] = double(int(i) - 1000);
    value[i] = std::ldexp(double(rng()), -20) / 3.0;
    intensity[i] = double(u(rng));
    wide[i] = double(i * 7 % 65536);
  }
  c.add_field("red", scalar_type::uint8, red);
  c.add_field("label", scalar_type::int32, label);
  c.add_field("value", scalar_type::float64, value);
  c.add_field("intensity", scalar_type::float32, intensity);
  c.add_field("wide", scalar_type::uint16, wide);
  const std::string path = temp_file("roundtrip.csv");
  ced::io::write_csv(path, c);
  EXPECT_EQ(read_bytes(path).substr(0, 37), "x,y,z,red,label,value,intensity,wide\n");

  const point_cloud r = ced::io::read_csv(path);
  ASSERT_EQ(r.size(), n);
  EXPECT_EQ(r.origin(), c.origin());
  EXPECT_EQ(r.positions(), c.positions());  // shortest float text reads back exactly
  EXPECT_TRUE(std::signbit(r.position(0)[2]));
  ASSERT_EQ(field_names(r), field_names(c));
  EXPECT_EQ(r.get_field("red").type(), scalar_type::uint8);
  EXPECT_EQ(r.get_field("label").type(), scalar_type::int32);
  EXPECT_EQ(r.get_field("value").type(), scalar_type::float64);
  EXPECT_EQ(r.get_field("intensity").type(), scalar_type::float64);  // CSV keeps no types
  EXPECT_EQ(r.get_field("wide").type(), scalar_type::int32);
  EXPECT_EQ(r.get_field("red").values, red);
  EXPECT_EQ(r.get_field("label").values, label);
  EXPECT_EQ(r.get_field("value").values, value);  // shortest double text reads back exactly
  EXPECT_EQ(r.get_field("wide").values, wide);
  for (std::size_t i = 0; i < n; ++i)
    EXPECT_EQ(static_cast<float>(r.get_field("intensity").values[i]), static_cast<float>(intensity[i]));
}

TEST(CsvRoundTrip, ThroughAStreamWithNaNAndGeoreference) {
  point_cloud c;
  c.set_origin({512000, 4123000, 300});
  c.push_back(345.678f, 456.789f, 12.345f);
  c.push_back(346.5f, 455.25f, 13.f);
  c.add_field("v", scalar_type::float32, {std::numeric_limits<double>::quiet_NaN(), 2.5});
  std::stringstream s;
  ced::io::write_csv(s, c);
  const point_cloud r = read_text(s.str());
  ASSERT_EQ(r.size(), 2u);
  EXPECT_NE(r.origin()[0], 0.0);
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t k = 0; k < 3; ++k)
      EXPECT_NEAR(r.origin()[k] + r.position(i)[k], c.origin()[k] + c.position(i)[k], 1e-3);
  EXPECT_TRUE(std::isnan(r.get_field("v").values[0]));
  EXPECT_EQ(r.get_field("v").values[1], 2.5);
}

TEST(CsvRoundTrip, EmptyCloudWritesAHeaderAndReadsBack) {
  point_cloud c;
  c.add_field("intensity", scalar_type::float32, {});
  std::stringstream s;
  ced::io::write_csv(s, c);
  EXPECT_EQ(s.str(), "x,y,z,intensity\n");
  const point_cloud r = read_text(s.str());
  EXPECT_TRUE(r.empty());
  EXPECT_EQ(field_names(r), std::vector<std::string>{"intensity"});
}

// ----------------------------------------------------------------- headers

TEST(CsvRead, HeaderVariants) {
  expect_two_points_with_red(read_text("x,y,z,red\n1,2,3,10\n4,5,6,20\n"));
  expect_two_points_with_red(read_text("x;y;z;red\n1;2;3;10\n4;5;6;20\n"));
  expect_two_points_with_red(read_text("x\ty\tz\tred\n1\t2\t3\t10\n4\t5\t6\t20\n"));
  expect_two_points_with_red(read_text("  x   y z  red\n 1 2   3 10\n4 5 6 20   \n"));
  expect_two_points_with_red(read_text("X, Y, Z, red\n1, 2, 3, 10\n4 , 5 , 6 , 20\n"));
  expect_two_points_with_red(read_text("\"x\",\"y\",\"z\",\"red\"\n\"1\",2,3,10\n4,5,6,\"20\"\n"));
  expect_two_points_with_red(read_text("\xEF\xBB\xBFx,y,z,red\n1,2,3,10\n4,5,6,20\n"));  // UTF-8 BOM
  expect_two_points_with_red(read_text("# x y z red\n1 2 3 10\n4 5 6 20\n"));
  expect_two_points_with_red(read_text("#x,y,z,red\n1,2,3,10\n4,5,6,20\n"));
  // CloudCompare: //X Y Z R G B, space separated.
  const point_cloud cc = read_text("//X Y Z R G B\n1 2 3 10 0 255\n4 5 6 20 1 254\n");
  expect_two_points_with_red(cc);
  EXPECT_EQ(field_names(cc), (std::vector<std::string>{"red", "green", "blue"}));
  EXPECT_TRUE(cc.has_rgb());
  // A comment line before the header line, other names kept as written.
  const point_cloud k = read_text("# exported by a scanner\nX,Y,Z,Intensity,Scalar_field\n1,2,3,0.5,7\n");
  EXPECT_EQ(field_names(k), (std::vector<std::string>{"Intensity", "Scalar_field"}));
  // The column order is free.
  const point_cloud o = read_text("i,z,y,x\n7,3,2,1\n");
  EXPECT_EQ(o.position(0)[0], 1.f);
  EXPECT_EQ(o.position(0)[2], 3.f);
  EXPECT_EQ(o.get_field("i").values[0], 7);
}

TEST(CsvRead, NoHeaderDefaultColumns) {
  const point_cloud c3 = read_text("1 2 3\n4 5 6\n");
  EXPECT_EQ(c3.size(), 2u);
  EXPECT_TRUE(c3.fields().empty());
  const point_cloud c4 = read_text("1,2,3,0.5\n4,5,6,1\n");
  EXPECT_EQ(field_names(c4), std::vector<std::string>{"intensity"});
  EXPECT_EQ(c4.get_field("intensity").type(), scalar_type::float64);
  const point_cloud c6 = read_text("1 2 3 10 20 30\n4 5 6 20 30 40\n");
  EXPECT_EQ(field_names(c6), (std::vector<std::string>{"red", "green", "blue"}));
  expect_two_points_with_red(c6);
  const point_cloud c7 = read_text("1 2 3 100 10 20 30\n4 5 6 -5 20 30 40\n");
  EXPECT_EQ(field_names(c7), (std::vector<std::string>{"intensity", "red", "green", "blue"}));
  EXPECT_EQ(c7.get_field("intensity").type(), scalar_type::int32);
  expect_two_points_with_red(c7);
}

TEST(CsvRead, LeicaPtsPointCount) {
  const point_cloud c = read_text("2\n1 2 3 -120 10 0 0\n4 5 6 300 20 0 0\n");
  expect_two_points_with_red(c);
  EXPECT_EQ(c.get_field("intensity").values, (std::vector<double>{-120, 300}));
  EXPECT_TRUE(read_text("0\n").empty());
  EXPECT_CONTAINS(read_error("2\n1 2 3\n7\n"), "line 3: expected 3 values (x, y, z), found 1");
}

TEST(CsvRead, ExplicitColumnsAndSkipHeader) {
  csv_options opt;
  opt.columns = {"red", "X", "y", "z"};
  const point_cloud c = read_text("10 1 2 3\n20 4 5 6\n", opt);
  expect_two_points_with_red(c);
  opt.skip_header = true;
  expect_two_points_with_red(read_text("a b c d\n10 1 2 3\n20 4 5 6\n", opt));
  csv_options skip;
  skip.skip_header = true;  // ignore the header, use the default names for 6 columns
  expect_two_points_with_red(read_text("u v w a b c\n1 2 3 10 0 0\n4 5 6 20 0 0\n", skip));
  csv_options semi;
  semi.delimiter = ';';
  EXPECT_EQ(read_text("x;y;z;v\n1;2;3;1.5\n", semi).get_field("v").values[0], 1.5);
  EXPECT_CONTAINS(read_error("x;y;z;v\n1;2;3;1,5\n", semi), "'1,5' is not a number");
}

TEST(CsvRead, CrlfCommentsAndBlankLines) {
  expect_two_points_with_red(read_text("x,y,z,red\r\n1,2,3,10\r\n\r\n# a comment\r\n// another\r\n4,5,6,20\r\n"));
  expect_two_points_with_red(read_text("x,y,z,red\n1,2,3,10\n4,5,6,20"));  // no final newline
}

TEST(CsvRead, FieldTypes) {
  const point_cloud c = read_text(
      "x,y,z,red,green,blue,count,big,frac,intlike\n"
      "0,0,0,0,0,0.5,-7,3000000000,0.25,1.0\n"
      "1,1,1,255,256,1,2147483647,1,1,2\n");
  EXPECT_EQ(c.get_field("red").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("green").type(), scalar_type::int32);   // 256 is not a byte
  EXPECT_EQ(c.get_field("blue").type(), scalar_type::float64);  // 0.5: already normalised colour
  EXPECT_EQ(c.get_field("count").type(), scalar_type::int32);
  EXPECT_EQ(c.get_field("big").type(), scalar_type::float64);  // beyond int32
  EXPECT_EQ(c.get_field("frac").type(), scalar_type::float64);
  EXPECT_EQ(c.get_field("intlike").type(), scalar_type::float64);  // written as a float
  EXPECT_EQ(c.get_field("big").values[0], 3000000000.0);
}

TEST(CsvRead, LargeCoordinatesGetAnOrigin) {
  const point_cloud c = read_text("x,y,z\nnan,0,0\n600000.25,5000000.25,100.125\n600001.5,5000002.75,101\n");
  EXPECT_EQ(c.origin(), (std::array<double, 3>{600001, 5000002, 0}));  // as every reader: ced::choose_origin
  EXPECT_EQ(c.position(1)[0], -0.75f);
  EXPECT_EQ(c.position(2)[1], 0.75f);
  EXPECT_TRUE(std::isnan(c.position(0)[0]));  // kept: the caller decides
}

TEST(CsvRead, HeaderOnlyIsAnEmptyCloud) {
  const point_cloud c = read_text("x,y,z,intensity\n");
  EXPECT_TRUE(c.empty());
  EXPECT_EQ(field_names(c), std::vector<std::string>{"intensity"});
  EXPECT_TRUE(read_text("//X Y Z\n").empty());
}

TEST(CsvRead, ManyLines) {
  std::string text = "x,y,z,intensity\n";
  const std::size_t n = 200000;
  for (std::size_t i = 0; i < n; ++i)
    text += std::to_string(i % 1000) + "." + std::to_string(i % 7) + "," + std::to_string(i % 13) + ",-" +
            std::to_string(i % 17) + ".5," + std::to_string(i % 100) + "\n";
  const point_cloud c = read_text(text);
  ASSERT_EQ(c.size(), n);
  EXPECT_EQ(c.position(123456)[0], 456.4f);
  EXPECT_EQ(c.position(123456)[2], -2.5f);
  EXPECT_EQ(c.get_field("intensity").values[123456], 56.0);
}

// ------------------------------------------------------------------ errors

TEST(CsvErrors, WrongNumberOfValues) {
  EXPECT_CONTAINS(read_error("x,y,z\n1,2,3\n# c\n4,5\n"), "line 4: expected 3 values (x, y, z), found 2");
  EXPECT_CONTAINS(read_error("1 2 3\n1 2 3 4\n"), "line 2: expected 3 values");
  EXPECT_CONTAINS(read_error("x,y,z\n1,2,3,\n"), "line 2: expected 3 values (x, y, z), found 4");
}

TEST(CsvErrors, NonNumericValues) {
  EXPECT_CONTAINS(read_error("x,y,z,red\n1,2,3,4\n5,abc,6,7\n"), "line 3, column 2 ('y'): 'abc' is not a number");
  EXPECT_CONTAINS(read_error("x,y,z\n1,2,3\nx,y,z\n"), "line 3, column 1 ('x'): 'x' is not a number");
  EXPECT_CONTAINS(read_error("x,y,z\n1,,3\n"), "line 2, column 2 ('y'): '' is not a number");
  csv_options opt;
  opt.columns = {"x", "y", "z"};
  EXPECT_CONTAINS(read_error("x y z\n1 2 3\n", opt), "line 1, column 1 ('x'): 'x' is not a number (a header line?");
}

TEST(CsvErrors, EmptyFile) {
  EXPECT_CONTAINS(read_error(""), "the file is empty");
  EXPECT_CONTAINS(read_error("\n  \n\r\n"), "the file is empty");
  EXPECT_CONTAINS(read_error("# just a comment\n"), "the file is empty");
}

TEST(CsvErrors, MissingCoordinateColumnsAndBadNames) {
  EXPECT_CONTAINS(read_error("x,y,intensity\n1,2,3\n"),
                  "the header (line 1) has no 'z' column (columns: x, y, intensity)");
  csv_options opt;
  opt.columns = {"x", "z", "w"};
  EXPECT_CONTAINS(read_error("1 2 3\n", opt), "the columns option has no 'y' column");
  EXPECT_CONTAINS(read_error("x,y,z,a,A,a\n1,2,3,4,5,6\n"), "the header (line 1) names column 'a' twice");
  EXPECT_CONTAINS(read_error("x,y,z,X\n1,2,3,4\n"), "names column 'x' twice");
  EXPECT_CONTAINS(read_error("1 2 3 4 5\n"), "line 1: 5 values and no header: name the columns (--columns");
  EXPECT_CONTAINS(read_error("# comment\n\n1 2\n"), "line 3: 2 values and no header");
}

TEST(CsvErrors, MissingFile) {
  try {
    ced::io::read_csv(temp_file("does_not_exist.csv"));
    FAIL() << "no exception";
  } catch (const io_error& e) {
    EXPECT_CONTAINS(e.what(), "cannot open");
    EXPECT_CONTAINS(e.what(), "does_not_exist.csv");
  }
}

TEST(CsvWrite, BadFieldsAreRejectedAndLeaveNoFile) {
  point_cloud c;
  c.push_back(0, 0, 0);
  c.add_field("a,b", scalar_type::float32, {1});
  const std::string path = temp_file("bad_field.csv");
  EXPECT_THROW(ced::io::write_csv(path, c), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
  point_cloud d;
  d.push_back(0, 0, 0);
  d.add_field("X", scalar_type::float32, {1});
  std::stringstream s;
  EXPECT_THROW(ced::io::write_csv(s, d), std::invalid_argument);
  EXPECT_THROW(ced::io::write_csv(temp_file("no/such/dir/a.csv"), point_cloud{}), io_error);
}

TEST(CsvWrite, IntegersAreRoundedAndClamped) {
  point_cloud c;
  c.push_back(1.5f, 0.1f, -2.f);
  c.add_field("red", scalar_type::uint8, {300.7});
  c.add_field("n", scalar_type::int16, {-2.5});
  std::stringstream s;
  ced::io::write_csv(s, c);
  EXPECT_EQ(s.str(), "x,y,z,red,n\n1.5,0.1,-2,255,-3\n");
}

// ------------------------------------------------------------- threads

namespace {
/// A CSV text of about 5 MB: comments and blank lines here and there, a
/// column that turns non-integer and a colour that leaves 0..255 only near
/// the end (so the types depend on the last blocks), and `bad` lines whose
/// first value is not a number.
std::string big_csv(const std::vector<std::size_t>& bad = {}) {
  std::mt19937 rng(5);
  std::ostringstream s;
  s << "x,y,z,intensity,red,w\n";
  for (std::size_t i = 0; i < 150000; ++i) {
    if (i % 9973 == 0) s << "# a comment at point " << i << "\n";
    if (i % 7919 == 0) s << "\n";
    if (std::find(bad.begin(), bad.end(), i) != bad.end())
      s << "oops,";
    else
      s << (rng() % 100000) * 0.001 << ",";
    s << (rng() % 100000) * 0.001 << "," << -(double(rng() % 5000) * 0.01) << "," << rng() % 60000 << ","
      << (i == 149000 ? 300 : rng() % 256) << "," << (i == 148000 ? std::string("1.5") : std::to_string(rng() % 9))
      << "\n";
  }
  return s.str();
}

point_cloud read_text_on(unsigned threads, const std::string& text) {
  point_cloud c;
  ced::detail::with_thread_limit(threads, [&] { c = read_text(text); });
  return c;
}
}  // namespace

TEST(CsvThreads, BlocksOfLinesOnThreadsGiveTheCloudOfOneThread) {
  const std::string text = big_csv();
  ASSERT_GT(text.size(), std::size_t(4) << 20);  // several blocks of 1 MiB
  const point_cloud want = read_text_on(1, text);
  ASSERT_EQ(want.size(), 150000u);
  EXPECT_EQ(want.get_field("intensity").type(), scalar_type::int32);
  EXPECT_EQ(want.get_field("red").type(), scalar_type::int32);  // the 300 near the end
  EXPECT_EQ(want.get_field("w").type(), scalar_type::float64);  // the 1.5 near the end
  for (unsigned threads : {2u, 3u}) {
    SCOPED_TRACE(threads);
    ced_test::expect_same_cloud(read_text_on(threads, text), want);
  }
}

TEST(CsvThreads, TheFirstBadLineInTheFileIsReported) {
  // Two bad lines in later blocks: every thread count names the first one,
  // with its line number in the file (comments and blank lines counted).
  const std::string text = big_csv({120000, 70000});
  std::string want;
  for (unsigned threads : {1u, 2u, 3u}) {
    try {
      read_text_on(threads, text);
      ADD_FAILURE() << "no error on " << threads << " threads";
    } catch (const io_error& e) {
      if (want.empty()) want = e.what();
      EXPECT_EQ(std::string(e.what()), want) << threads << " threads";
    }
  }
  // Line 1 is the header; point i is on line 2 + i plus the comments and blank lines before it.
  const std::size_t extra = 70000 / 9973 + 1 + 70000 / 7919 + 1;
  EXPECT_NE(want.find("line " + std::to_string(2 + 70000 + extra) + ", column 1 ('x')"), std::string::npos) << want;
}

TEST(CsvThreads, ManyColumnsAndShortLinesAreAnErrorNotAHugeAllocation) {
  // 4,000 columns named, then 1.5 M lines of one value: the columns are sized
  // by what the bytes can hold (about 400 rows), not 1.5 M × 4,000 doubles,
  // and the first line is the one named, on any number of threads.
  std::string text = "c0";
  for (int j = 1; j < 4000; ++j) text += ",c" + std::to_string(j);
  text.replace(0, 2, "x,y,z");  // x, y and z among them
  text += "\n";
  for (int i = 0; i < 1500000; ++i) text += "1\n";
  for (unsigned threads : {1u, 2u}) {
    const std::string msg = ced_test::io_error_of([&] { read_text_on(threads, text); });
    EXPECT_NE(msg.find("line 2: expected 4002 values"), std::string::npos) << threads << " threads: " << msg;
  }
}
