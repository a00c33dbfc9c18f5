// SPDX-License-Identifier: MIT
// Private to src/tiled: the plan file (plan_file.cpp): the request as a plan
// writes it.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include "ced/tiled.hpp"

namespace ced::tiled_detail {

/// The request as a plan writes it (and as a resumed run compares it).
nlohmann::json request_json(const tiled_request& r);

/// tile_plan::from_json(); with `tiles` false, a plan without tiles is
/// accepted too (the plan from the headers that fill_cache_share() gets).
tile_plan plan_from_json(const std::string& text, const std::string& name, bool tiles);

}  // namespace ced::tiled_detail
