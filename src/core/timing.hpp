// SPDX-License-Identifier: MIT
// Private: the clock of the per-stage times (not installed).
#pragma once

#include <chrono>

namespace ced::detail {

using clock_type = std::chrono::steady_clock;

/// Milliseconds since `t`.
inline double ms_since(clock_type::time_point t) {
  return std::chrono::duration<double, std::milli>(clock_type::now() - t).count();
}

}  // namespace ced::detail
