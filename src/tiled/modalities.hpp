// SPDX-License-Identifier: MIT
// Private to src/tiled: the run's modalities: made from their specs, the halo they need, the names and thresholds a
// part carries, the fields they read (modalities.cpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ced/modality.hpp"
#include "ced/tiled.hpp"

namespace ced::tiled_detail {

std::vector<any_modality> modalities_of(const std::vector<std::string>& specs);
/// The parameters a tile's halo follows: the radius of the largest scale
/// among the modalities (scale=).
detect_params halo_params(const tiled_request& r);
/// `params` for binding modalities to a one-point probe cloud (which only
/// checks their fields): the fixed radius, since K nearest need K points.
inline detect_params probe_params(detect_params params) {
  params.neighborhood = neighborhood_spec{};
  return params;
}
/// A part's modality names and absolute thresholds, from the plan's modalities.
void name_modalities(const tile_plan& plan, const std::vector<any_modality>& modalities, tile_part& part);

/// The tile fields of a plan whose modalities read fewer fields than it
/// has (what build_cache() sets as tile_plan::tile_fields); nullopt when
/// they read them all, or a modality does not say which it reads.
std::optional<std::vector<std::string>> detection_fields(const tile_plan& p);

}  // namespace ced::tiled_detail
