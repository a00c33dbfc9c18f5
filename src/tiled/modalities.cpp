// SPDX-License-Identifier: MIT
// The run's modalities (modalities.hpp): what planning, sizing, the tiles,
// the merge and the fetch all ask of them.
#include "tiled/modalities.hpp"

#include <algorithm>
#include <exception>

#include "ced/channels.hpp"
#include "ced/scaled.hpp"
#include "core/text.hpp"
#include "tiled/records.hpp"

namespace ced::tiled_detail {

std::vector<any_modality> modalities_of(const std::vector<std::string>& specs) {
  std::vector<any_modality> out;
  for (const auto& s : specs) out.push_back(make_modality(s));
  return out;
}

detect_params halo_params(const tiled_request& r) { return tile_halo_params(r.params, modalities_of(r.modalities)); }

void name_modalities(const tile_plan& plan, const std::vector<any_modality>& modalities, tile_part& part) {
  for (const auto& mod : modalities) {
    part.names.push_back(mod.name());
    part.thresholds.push_back(mod.threshold(plan.request.params));
  }
}

std::optional<std::vector<std::string>> detection_fields(const tile_plan& p) {
  std::vector<std::string> read;
  const auto modalities = modalities_of(p.request.modalities);
  for (const auto& m : modalities) {
    const auto f = m.fields();
    if (!f) return std::nullopt;  // a modality that does not say: every field
    read.insert(read.end(), f->begin(), f->end());
  }
  tile_plan slim = p;
  slim.tile_fields.emplace();
  for (const auto& f : p.fields)
    if (std::any_of(read.begin(), read.end(), [&](const std::string& n) { return field_name_matches(n, f.name); }))
      slim.tile_fields->push_back(f.name);
  if (slim.tile_fields->size() == p.fields.size()) return std::nullopt;
  // The modalities must find their fields among these (they look them up
  // by their own rules): else every field goes through the cache.
  try {
    const point_cloud one = probe_cloud(slim);
    for (const auto& m : modalities) m.bind(one, probe_params(p.request.params));
  } catch (const std::exception&) {
    return std::nullopt;
  }
  return slim.tile_fields;
}

}  // namespace ced::tiled_detail
