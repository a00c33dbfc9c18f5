// SPDX-License-Identifier: MIT
// Private to src/tiled: the plan file (plan_file.cpp): the request as a plan
// writes it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ced/io/error.hpp"
#include "ced/io/stream.hpp"
#include "ced/modality.hpp"
#include "ced/tiled.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::tiled_detail {

/// The request as a plan writes it (and as a resumed run compares it).
nlohmann::json request_json(const tiled_request& r);

}  // namespace ced::tiled_detail
