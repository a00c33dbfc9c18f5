// SPDX-License-Identifier: MIT
// Private to src/tiled: the plan file (plan_file.cpp): the request as a plan
// writes it.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include "ced/tiled.hpp"

namespace ced::tiled_detail {

/// The request as a plan writes it (and as a resumed run compares it).
nlohmann::json request_json(const tiled_request& r);

}  // namespace ced::tiled_detail
