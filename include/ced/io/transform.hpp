// SPDX-License-Identifier: MIT
// Reading rigid transforms: 4×4 matrix files (ground truths of evaluations).
#pragma once

#include <istream>
#include <string>

#include "ced/transform.hpp"

namespace ced::eval {

/// Reads a 4×4 row-major matrix of a rigid transform: 16 numbers separated by
/// white space or commas; '#' starts a comment. The last row must be 0 0 0 1
/// and the upper-left 3×3 block a rotation (orthonormal, determinant +1, to
/// within `tolerance`). Throws ced::io::io_error naming `name` and the
/// problem (wrong count, a bad number, not rigid) otherwise.
rigid_transform parse_transform(std::istream& in, const std::string& name, double tolerance = 1e-3);

/// parse_transform on the file `path` (io_error when it cannot be opened).
rigid_transform read_transform(const std::string& path, double tolerance = 1e-3);

}  // namespace ced::eval
