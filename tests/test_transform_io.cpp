// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "ced/io/output_file.hpp"
#include "ced/io/transform.hpp"

namespace {
std::string transform_error_of(const std::string& text) {
  std::istringstream in(text);
  try {
    ced::eval::parse_transform(in, "T.txt");
  } catch (const ced::io::io_error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Eval, ParsesATransformFile) {
  std::istringstream in(
      "# P -> Q\n"
      "0 -1 0 10\n"
      "1, 0, 0, 20   # commas are fine\n"
      "0 0 1 30\n"
      "0 0 0 1\n");
  const auto t = ced::eval::parse_transform(in, "T.txt");
  EXPECT_EQ(t.rotation[0][1], -1.0);
  EXPECT_EQ(t.rotation[1][0], 1.0);
  EXPECT_EQ(t.translation[0], 10.0);
  EXPECT_EQ(t.translation[1], 20.0);
  EXPECT_EQ(t.translation[2], 30.0);
  std::istringstream one_line("1 0 0 0.5 0 1 0 0 0 0 1 0 0 0 0 1");
  EXPECT_EQ(ced::eval::parse_transform(one_line, "x").translation[0], 0.5);
}

TEST(Eval, RejectsBadTransformFiles) {
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n").find("found 12"), std::string::npos);
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1 7\n").find("found 17"), std::string::npos);
  EXPECT_NE(transform_error_of("").find("found 0"), std::string::npos);
  const auto bad_word = transform_error_of("1 0 0 0\n0 one 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_NE(bad_word.find("line 2"), std::string::npos) << bad_word;
  EXPECT_NE(bad_word.find("'one'"), std::string::npos) << bad_word;
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 nan\n0 0 0 1\n").find("not a finite number"),
            std::string::npos);
  EXPECT_NE(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n").find("last row"), std::string::npos);
  EXPECT_NE(transform_error_of("2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n").find("not a rotation"), std::string::npos);
  EXPECT_NE(transform_error_of("-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n").find("not a rotation"),  // a reflection
            std::string::npos);
  EXPECT_EQ(transform_error_of("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"), "");
  try {
    ced::eval::read_transform("/nonexistent/dir/T.txt");
    FAIL() << "expected an io_error";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/T.txt"), std::string::npos);
  }
}
