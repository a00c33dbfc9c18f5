// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
// The error of reading and writing files (also through ced/io/io.hpp and
// ced/io/output_file.hpp).
#pragma once

#include <stdexcept>
#include <string>

namespace ced::io {

/// Error reading or writing a file. The message names the file and the problem.
struct io_error : std::runtime_error {
  using std::runtime_error::runtime_error;
  /// The message "<file>: <problem>".
  io_error(const std::string& file, const std::string& problem) : std::runtime_error(file + ": " + problem) {}
};

}  // namespace ced::io
