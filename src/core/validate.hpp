// SPDX-License-Identifier: MIT
// Private: stage 0 of detection, the checks of its inputs.
#pragma once

#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/params.hpp"

namespace ced::detail {

/// Throws std::invalid_argument for bad parameters (validate()), no
/// modality, a threshold that is negative or not finite, a non-finite
/// coordinate (naming the point) or too many points.
void check_inputs(const point_cloud& cloud, const detect_params& params, const std::vector<std::string>& names,
                  const std::vector<double>& thresholds);

}  // namespace ced::detail
