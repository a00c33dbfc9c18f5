// SPDX-License-Identifier: MIT
// Reading rigid transforms from text (4×4 matrices).
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ced/io/output_file.hpp"
#include "ced/io/transform.hpp"

namespace ced::eval {

namespace {

/// The numbers of a matrix file: '#' comments dropped, commas as blanks.
std::vector<double> read_numbers(std::istream& in, const std::string& name) {
  std::vector<double> values;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    line = line.substr(0, line.find('#'));
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream words(line);
    for (std::string word; words >> word;) {
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(word, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != word.size() || !std::isfinite(v))
        throw io::io_error(name + ": line " + std::to_string(line_no) + ": '" + word + "' is not a finite number");
      values.push_back(v);
    }
  }
  if (in.bad()) throw io::io_error(name + ": read error");
  return values;
}

void check_rigid(const rigid_transform& t, const std::array<double, 4>& last_row, const std::string& name,
                 double tolerance) {
  const std::array<double, 4> expected{0, 0, 0, 1};
  for (std::size_t c = 0; c < 4; ++c)
    if (std::abs(last_row[c] - expected[c]) > tolerance)
      throw io::io_error(name + ": the last row must be 0 0 0 1 (a rigid transform), got " +
                         std::to_string(last_row[0]) + " " + std::to_string(last_row[1]) + " " +
                         std::to_string(last_row[2]) + " " + std::to_string(last_row[3]));
  double worst = 0;  // max |RᵀR − I|
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t j = 0; j < 3; ++j) {
      double dot = 0;
      for (std::size_t k = 0; k < 3; ++k) dot += t.rotation[k][i] * t.rotation[k][j];
      worst = std::max(worst, std::abs(dot - (i == j ? 1.0 : 0.0)));
    }
  const auto& R = t.rotation;
  const double det = R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1]) -
                     R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0]) +
                     R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]);
  if (worst > tolerance || std::abs(det - 1) > tolerance)
    throw io::io_error(name +
                       ": the upper-left 3x3 block is not a rotation (max |R^T R - I| = " + std::to_string(worst) +
                       ", det = " + std::to_string(det) + "): only rigid transforms are supported");
}

}  // namespace

rigid_transform parse_transform(std::istream& in, const std::string& name, double tolerance) {
  const std::vector<double> v = read_numbers(in, name);
  if (v.size() != 16)
    throw io::io_error(name + ": expected a 4x4 matrix (16 numbers, row by row), found " + std::to_string(v.size()) +
                       " number(s)");
  rigid_transform t;
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 3; ++c) t.rotation[r][c] = v[4 * r + c];
    t.translation[r] = v[4 * r + 3];
  }
  check_rigid(t, {v[12], v[13], v[14], v[15]}, name, tolerance);
  return t;
}

rigid_transform read_transform(const std::string& path, double tolerance) {
  std::ifstream in(path);
  if (!in) throw io::io_error(path + ": cannot open the transform file");
  return parse_transform(in, path, tolerance);
}

}  // namespace ced::eval
