// SPDX-License-Identifier: MIT
// Tiled runs: the plan as JSON (written, read and checked), its digest.
#include "tiled/plan_file.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>

#include "ced/channels.hpp"
#include "core/hash.hpp"
#include "core/text.hpp"
#include "io/base/scalar_io.hpp"
#include "tiled/fingerprint.hpp"
#include "tiled/modalities.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

constexpr int plan_version = 1;

scalar_type type_named(const std::string& name, const std::string& where) {
  for (int t = 0; t <= int(scalar_type::float64); ++t)
    if (name_of(scalar_type(t)) == name) return scalar_type(t);
  throw io::io_error(where, "unknown field type '" + name + "'");
}

/// A whole number of a plan, within T's range (`what` names it): nlohmann's
/// get<> would wrap -1 to 2^32-1 and truncate 2.5.
template <class T>
T whole_number(const nlohmann::json& v, const std::string& what) {
  if (!v.is_number_unsigned() || v.get<std::uint64_t>() > std::numeric_limits<T>::max())
    throw std::invalid_argument(what + " must be a whole number from 0 to " +
                                std::to_string(std::numeric_limits<T>::max()) + ", got " + v.dump());
  return static_cast<T>(v.get<std::uint64_t>());
}
template <class T>
T count_of(const nlohmann::json& j, const char* key) {
  return whole_number<T>(j.at(key), std::string("'") + key + "'");
}
/// A finite number of a plan.
double number_of(const nlohmann::json& j, const char* key) {
  const nlohmann::json& v = j.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    throw std::invalid_argument(std::string("'") + key + "' must be a finite number, got " + v.dump());
  return v.get<double>();
}
std::array<double, 3> point_of(const nlohmann::json& j, const char* key) {
  const nlohmann::json& v = j.at(key);
  if (!v.is_array() || v.size() != 3) throw std::invalid_argument(std::string("'") + key + "' must be 3 numbers");
  std::array<double, 3> out{};
  for (std::size_t k = 0; k < 3; ++k) {
    if (!v[k].is_number() || !std::isfinite(v[k].get<double>()))
      throw std::invalid_argument(std::string("'") + key + "' must be 3 finite numbers, got " + v.dump());
    out[k] = v[k].get<double>();
  }
  return out;
}

tiled_request request_from_json(const nlohmann::json& j) {
  tiled_request r;
  r.input = j.at("input").get<std::string>();
  r.read.format = io::parse_format(j.at("format").get<std::string>());
  r.read.csv.columns = j.at("csv_columns").get<std::vector<std::string>>();
  if (j.at("fields").is_string()) {
    if (j.at("fields").get<std::string>() != "all") throw std::invalid_argument("'fields' must be \"all\" or a list");
    r.read.fields = {};
  } else {
    r.read.fields = field_selection::only(j.at("fields").get<std::vector<std::string>>());
  }
  r.params.radius = number_of(j, "radius");
  r.params.nms_radius = number_of(j, "nms_radius");
  r.params.min_neighbors = count_of<std::uint32_t>(j, "min_neighbors");
  r.params.block_scale = number_of(j, "block_scale");
  if (j.contains("refine") && !j.at("refine").is_boolean())
    throw std::invalid_argument("'refine' must be true or false");
  r.params.refine = j.value("refine", false);  // plans written before refinement existed
  // Written only when set, so that plans without a limit keep their digest.
  if (j.contains("max_keypoints")) r.params.max_keypoints = count_of<std::size_t>(j, "max_keypoints");
  if (j.contains("keypoint_share")) r.params.keypoint_share = number_of(j, "keypoint_share");  // validate() checks it
  if (j.contains("neighborhood")) {
    if (!j.at("neighborhood").is_string()) throw std::invalid_argument("'neighborhood' must be a string");
    r.params.neighborhood = parse_neighborhood(j.at("neighborhood").get<std::string>());
  }
  if (j.contains("search")) {
    if (!j.at("search").is_string()) throw std::invalid_argument("'search' must be a string");
    try {
      r.params.search = parse_search_kind(j.at("search").get<std::string>());
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("'search' ") + e.what());
    }
  }
  r.modalities = j.at("modalities").get<std::vector<std::string>>();
  r.tile_size = number_of(j, "tile_size");
  r.memory_limit = count_of<std::uint64_t>(j, "memory_limit");
  r.scan = j.value("scan", false);
  r.reach_estimated = j.value("reach_estimated", false);
  validate(r.params);
  if (r.modalities.empty()) throw std::invalid_argument("'modalities' is empty");
  modalities_of(r.modalities);  // each spec parses
  if (r.tile_size < 0 || (r.tile_size == 0) == (r.memory_limit == 0))
    throw std::invalid_argument("a plan has a positive 'tile_size' or a 'memory_limit', one of them");
  return r;
}

/// The plan's "input": what was read, and its counts.
void input_from_json(const nlohmann::json& in, tile_plan& p, const std::string& name) {
  p.details = in.at("details").get<std::string>();
  p.input_bytes = count_of<std::uint64_t>(in, "bytes");
  p.fingerprint = in.at("fingerprint").get<std::string>();
  p.content = in.value("content", std::string());
  p.file_points = count_of<std::uint64_t>(in, "points");
  p.finite_points = count_of<std::uint64_t>(in, "finite_points");
  p.streamed = in.at("streamed").get<bool>();
  p.indexed = in.value("indexed", false);
  p.bytes_hash = in.value("bytes_hash", std::string());
  if (!p.bytes_hash.empty() &&
      (p.bytes_hash.size() != 16 || p.bytes_hash.find_first_not_of("0123456789abcdef") != std::string::npos))
    throw io::io_error(name, "invalid tile plan: 'bytes_hash' must be 16 hex digits");
  if (p.indexed && p.finite_points != p.file_points)
    throw io::io_error(name, "invalid tile plan: a plan from a spatial index counts every point finite");
  if (p.finite_points == 0 || p.finite_points > p.file_points ||
      p.finite_points > std::numeric_limits<std::uint32_t>::max())
    throw io::io_error(name, "invalid tile plan: its point counts are inconsistent");
}

/// The plan's "grid", its halo at least the one the request needs.
void grid_from_json(const nlohmann::json& g, tile_plan& p, const std::string& name) {
  p.grid.lo = point_of(g, "lo");
  p.grid.size = number_of(g, "size");
  const auto& dims = g.at("dims");
  if (!dims.is_array() || dims.size() != 3)
    throw io::io_error(name, "invalid tile plan: the grid's 'dims' must be 3 counts");
  for (std::size_t k = 0; k < 3; ++k) p.grid.dims[k] = whole_number<std::uint32_t>(dims.at(k), "the grid's dims");
  p.grid.halo = number_of(g, "halo");
  if (!(p.grid.size > 0) || !(p.grid.halo >= 0) ||
      p.grid.dims[0] * std::uint64_t(p.grid.dims[1]) * p.grid.dims[2] == 0 || p.grid.count() > (std::uint64_t(1) << 24))
    throw io::io_error(name, "the tile grid is invalid");
  // The halo makes the tiles exact: at least the one the request needs.
  const double needed = exact_halo(halo_params(p.request), 0);
  if (p.grid.halo < needed)
    throw io::io_error(name, "invalid tile plan: its halo " + std::to_string(p.grid.halo) + " is less than the " +
                                 std::to_string(needed) + " its radii and modalities need (tiles would not be exact)");
}

/// A field's "sample": base64 of its values as little-endian doubles, as
/// many as whole_sample_count() of the plan's finite points, all finite.
std::shared_ptr<const std::vector<double>> sample_from_json(const nlohmann::json& text, const tile_plan& p,
                                                            const std::string& field, const std::string& name) {
  std::string bytes;
  const std::size_t m = whole_sample_count(p.finite_points);
  if (!text.is_string() || !detail::base64_decode(text.get<std::string>(), bytes) || bytes.size() != 8 * m)
    throw io::io_error(name, "invalid tile plan: field '" + field + "' has a sample that is not base64 of " +
                                 std::to_string(m) + " doubles");
  auto v = std::make_shared<std::vector<double>>(m);
  for (std::size_t j = 0; j < m; ++j) {
    (*v)[j] = io::detail::load_le<double>(reinterpret_cast<const unsigned char*>(bytes.data()) + 8 * j);
    if (!std::isfinite((*v)[j]))
      throw io::io_error(name, "invalid tile plan: field '" + field + "' has a sample value that is not finite");
  }
  return v;
}

void fields_from_json(const nlohmann::json& fields, tile_plan& p, const std::string& name) {
  std::set<std::string> names;
  for (const auto& f : fields) {
    plan_field pf{f.at("name").get<std::string>(),
                  type_named(f.at("type").get<std::string>(), name),
                  {number_of(f, "lo"), number_of(f, "hi")},
                  nullptr};
    if (pf.name.empty() || !names.insert(pf.name).second || !(pf.range.lo <= pf.range.hi))
      throw io::io_error(name, "invalid tile plan: field '" + pf.name + "' is unnamed, repeated or has lo > hi");
    if (f.contains("sample")) pf.sample = sample_from_json(f.at("sample"), p, pf.name, name);
    p.fields.push_back(pf);
  }
}

/// The plan's "tile_fields": some of its fields, each once, in their order.
void tile_fields_from_json(const nlohmann::json& names, tile_plan& p, const std::string& name) {
  p.tile_fields = names.get<std::vector<std::string>>();
  std::size_t at = 0;
  for (const auto& n : *p.tile_fields) {
    while (at < p.fields.size() && p.fields[at].name != n) ++at;
    if (at == p.fields.size())
      throw io::io_error(name, "invalid tile plan: tile field '" + n + "' is not one of its fields, or out of order");
    ++at;
  }
}

/// The plan's tiles: in the grid, ascending, their counts consistent, and
/// owning every finite point between them.
void tiles_from_json(const nlohmann::json& tiles, tile_plan& p, const std::string& name) {
  std::uint64_t owned = 0;
  for (const auto& t : tiles) {
    const tile_entry e{whole_number<std::uint64_t>(t.at(0), "a tile's id"),
                       whole_number<std::uint64_t>(t.at(1), "a tile's count"),
                       whole_number<std::uint64_t>(t.at(2), "a tile's count")};
    if (e.id >= p.grid.count() || (!p.tiles.empty() && e.id <= p.tiles.back().id))
      throw io::io_error(name, "tile " + std::to_string(e.id) + " is out of the grid or out of order");
    if (e.core_points == 0 || e.core_points > e.points || e.points > p.finite_points)
      throw io::io_error(name, "invalid tile plan: tile " + std::to_string(e.id) + "'s counts are inconsistent");
    owned += e.core_points;
    p.tiles.push_back(e);
  }
  if (owned != p.finite_points && !p.indexed)  // a plan from an index estimates its counts
    throw io::io_error(name, "invalid tile plan: its tiles own " + std::to_string(owned) + " points, its input has " +
                                 std::to_string(p.finite_points) + " finite points");
}

/// The plan's "runs" (tile_plan::runs): consecutive from the first point to
/// the last, each with points, a finite ordered box and a 16-digit hash.
void runs_from_json(const nlohmann::json& runs, tile_plan& p, const std::string& name) {
  if (!runs.is_array()) throw io::io_error(name, "invalid tile plan: 'runs' must be a list");
  if (p.indexed || p.finite_points != p.file_points)
    throw io::io_error(name, "invalid tile plan: runs are for a file of finite points planned by passes");
  std::uint64_t next = 0;
  for (const auto& r : runs) {
    const std::string at = "run " + std::to_string(p.runs.size());
    if (!r.is_array() || r.size() != 9 || !r[8].is_string() || r[8].get<std::string>().size() != 16 ||
        r[8].get<std::string>().find_first_not_of("0123456789abcdef") != std::string::npos)
      throw io::io_error(name, "invalid tile plan: " + at + " must be [first, count, 6 box bounds, \"hash\"]");
    plan_run e;
    e.first = whole_number<std::uint64_t>(r[0], at + "'s first point");
    e.count = whole_number<std::uint64_t>(r[1], at + "'s count");
    for (std::size_t k = 0; k < 6; ++k) {
      if (!r[2 + k].is_number() || !std::isfinite(r[2 + k].get<double>()) ||
          std::fabs(r[2 + k].get<double>()) > std::numeric_limits<float>::max())
        throw io::io_error(name, "invalid tile plan: " + at + "'s box must be 6 finite numbers");
      e.box[k] = static_cast<float>(r[2 + k].get<double>());
    }
    e.hash = std::stoull(r[8].get<std::string>(), nullptr, 16);
    if (e.first != next || e.count == 0 || e.count > p.file_points - next || !(e.box[0] <= e.box[3]) ||
        !(e.box[1] <= e.box[4]) || !(e.box[2] <= e.box[5]))
      throw io::io_error(name, "invalid tile plan: " + at + " is empty, out of order or its box is inverted");
    next += e.count;
    p.runs.push_back(e);
  }
  if (next != p.file_points)
    throw io::io_error(name, "invalid tile plan: its runs hold " + std::to_string(next) + " points, its input has " +
                                 std::to_string(p.file_points));
}

}  // namespace

namespace tiled_detail {

nlohmann::json request_json(const tiled_request& r) {
  nlohmann::json j;
  j["input"] = r.input;
  j["format"] = io::format_name(r.read.format);
  j["csv_columns"] = r.read.csv.columns;
  j["fields"] = r.read.fields.all ? nlohmann::json("all") : nlohmann::json(r.read.fields.names);
  j["radius"] = r.params.radius;
  j["nms_radius"] = r.params.nms_radius;
  j["min_neighbors"] = r.params.min_neighbors;
  j["block_scale"] = r.params.block_scale;
  j["refine"] = r.params.refine;
  if (r.params.max_keypoints) j["max_keypoints"] = r.params.max_keypoints;
  if (r.params.keypoint_share > 0) j["keypoint_share"] = r.params.keypoint_share;
  // Written only when not the default, so that other plans keep their digest.
  if (!r.params.neighborhood.fixed()) j["neighborhood"] = to_string(r.params.neighborhood);
  if (r.params.search == search_kind::cgal) j["search"] = to_string(r.params.search);
  j["modalities"] = r.modalities;
  j["tile_size"] = r.tile_size;
  j["memory_limit"] = r.memory_limit;
  if (r.scan) j["scan"] = true;
  if (r.reach_estimated) j["reach_estimated"] = true;
  return j;
}

}  // namespace tiled_detail

std::string tile_plan::to_json() const {
  nlohmann::json j;
  j["ced_tile_plan"] = plan_version;
  j["request"] = request_json(request);
  j["input"] = {{"details", details},    {"bytes", input_bytes},           {"fingerprint", fingerprint},
                {"points", file_points}, {"finite_points", finite_points}, {"streamed", streamed}};
  if (!content.empty()) j["input"]["content"] = content;
  if (indexed) j["input"]["indexed"] = true;
  if (!bytes_hash.empty()) j["input"]["bytes_hash"] = bytes_hash;
  j["origin"] = origin;
  j["grid"] = {{"lo", grid.lo}, {"size", grid.size}, {"dims", grid.dims}, {"halo", grid.halo}};
  auto& fl = j["fields"] = nlohmann::json::array();
  for (const auto& f : fields) {
    fl.push_back({{"name", f.name}, {"type", std::string(name_of(f.type))}, {"lo", f.range.lo}, {"hi", f.range.hi}});
    if (f.sample) {
      std::string bytes(8 * f.sample->size(), '\0');
      for (std::size_t i = 0; i < f.sample->size(); ++i)
        io::detail::store_le(reinterpret_cast<unsigned char*>(bytes.data()) + 8 * i, (*f.sample)[i]);
      std::string text;
      detail::base64_append(bytes.data(), bytes.size(), text);
      fl.back()["sample"] = std::move(text);
    }
  }
  if (tile_fields) j["tile_fields"] = *tile_fields;
  auto& tl = j["tiles"] = nlohmann::json::array();
  for (const auto& t : tiles) tl.push_back({t.id, t.core_points, t.points});
  if (cache_shares > 1) j["cache_shares"] = cache_shares;
  if (!runs.empty()) {
    auto& rl = j["runs"] = nlohmann::json::array();
    for (const auto& r : runs) {
      auto& e = rl.emplace_back(nlohmann::json::array({r.first, r.count}));
      for (float b : r.box) e.push_back(double(b));
      e.push_back(hex(r.hash));
    }
  }
  return j.dump(1) + "\n";
}

tile_plan tile_plan::from_json(const std::string& text, const std::string& name) {
  return tiled_detail::plan_from_json(text, name, true);
}

tile_plan tiled_detail::plan_from_json(const std::string& text, const std::string& name, bool tiles) {
  tile_plan p;
  try {
    const auto j = nlohmann::json::parse(text);
    if (!j.is_object() || !j.contains("ced_tile_plan"))
      throw io::io_error(name, "not a ced tile plan (no 'ced_tile_plan' key)");
    if (j.at("ced_tile_plan").get<int>() != plan_version)
      throw io::io_error(name, "tile plan version " + j.at("ced_tile_plan").dump() + ", this ced reads version " +
                                   std::to_string(plan_version));
    p.request = request_from_json(j.at("request"));
    input_from_json(j.at("input"), p, name);
    p.origin = point_of(j, "origin");
    grid_from_json(j.at("grid"), p, name);
    fields_from_json(j.at("fields"), p, name);
    if (j.contains("tile_fields")) tile_fields_from_json(j.at("tile_fields"), p, name);
    if (tiles || !j.at("tiles").empty()) tiles_from_json(j.at("tiles"), p, name);
    if (j.contains("runs")) runs_from_json(j.at("runs"), p, name);
    p.cache_shares = whole_number<unsigned>(j.value("cache_shares", nlohmann::json(1u)), "'cache_shares'");
    if (p.cache_shares == 0 || p.cache_shares > (1u << 16))
      throw io::io_error(name, "invalid tile plan: 'cache_shares' must be 1 to 65536");
  } catch (const nlohmann::json::exception& e) {
    throw io::io_error(name, std::string("malformed tile plan: ") + e.what());
  } catch (const std::invalid_argument& e) {
    throw io::io_error(name, std::string("invalid tile plan: ") + e.what());
  }
  return p;
}

tile_plan tile_plan::load(const std::string& path) { return from_json(io::detail::read_whole_file(path), path); }

std::string tile_plan::digest() const { return hex(detail::fnv1a(to_json())); }

const tile_entry& tile_plan::tile(std::uint64_t id) const {
  const auto it =
      std::lower_bound(tiles.begin(), tiles.end(), id, [](const tile_entry& e, std::uint64_t v) { return e.id < v; });
  if (it == tiles.end() || it->id != id)
    throw std::invalid_argument("tile " + std::to_string(id) +
                                " owns no points in this plan (its tiles: " + std::to_string(tiles.size()) + ", ids " +
                                (tiles.empty()
                                     ? std::string("none")
                                     : std::to_string(tiles.front().id) + ".." + std::to_string(tiles.back().id)) +
                                ")");
  return *it;
}

}  // namespace ced
