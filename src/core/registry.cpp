// SPDX-License-Identifier: MIT
// Modality specs (the CLI grammar), the registry of modalities, presets.
#include "core/registry.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <mutex>
#include <set>
#include <stdexcept>
#include <type_traits>

#include "ced/modalities/builtin.hpp"
#include "ced/modality.hpp"
#include "ced/scaled.hpp"
#include "core/text.hpp"

namespace ced {

double parse_number(std::string_view text, const std::string& what) {
  const std::string s(detail::trim(text));
  if (s.empty()) throw std::invalid_argument(what + ": expected a number, got nothing");
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size()) throw std::invalid_argument(what + ": '" + s + "' is not a number");
  if (!std::isfinite(v)) throw std::invalid_argument(what + ": '" + s + "' is not a finite number");
  return v;
}

norm_type parse_norm(const std::string& text) {
  if (text == "l1" || text == "L1") return norm_type::l1;
  if (text == "l2" || text == "L2") return norm_type::l2;
  if (text == "linf" || text == "Linf" || text == "max") return norm_type::linf;
  throw std::invalid_argument("norm must be l1, l2 or linf, got '" + text + "'");
}

namespace {
std::string trimmed(std::string_view s) { return std::string(detail::trim(s)); }
bool valid_identifier(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}
/// A field name, a range of them (b000..b191: dots are allowed) or a glob
/// (* and ?).
bool valid_field_pattern(const std::string& s) {
  std::string plain = s;
  for (char& c : plain)
    if (c == '*' || c == '?') c = '_';
  return valid_identifier(plain);
}
}  // namespace

std::vector<std::string> split_modality_specs(std::string_view text) {
  std::vector<std::string> specs;
  std::string cur;
  int depth = 0;
  auto flush = [&] {
    const auto eq = cur.find('='), colon = cur.find_first_of(":(");
    if (!specs.empty() && eq != std::string::npos && (colon == std::string::npos || eq < colon))
      specs.back() += "," + cur;
    else if (!cur.empty())
      specs.push_back(cur);
    cur.clear();
  };
  for (char c : text) {
    depth += c == '(' ? 1 : c == ')' ? -1 : 0;
    if (c == ',' && depth == 0)
      flush();
    else
      cur += c;
  }
  flush();
  return specs;
}

modality_spec modality_spec::parse(std::string_view text) {
  modality_spec s;
  s.m_text = trimmed(text);
  const std::string& t = s.m_text;
  auto fail = [&](const std::string& why) {
    throw std::invalid_argument("bad modality spec '" + t + "': " + why +
                                " (expected name[(field,...)][:threshold][,key=value...], e.g. rgb:0.1 or "
                                "bands(nir,red):0.1,range=0..255)");
  };
  if (t.empty()) fail("it is empty");
  std::size_t pos = 0;
  while (pos < t.size() && t[pos] != '(' && t[pos] != ':' && t[pos] != ',') ++pos;
  s.m_name = trimmed(t.substr(0, pos));
  if (!valid_identifier(s.m_name)) fail("'" + s.m_name + "' is not a modality name");
  if (pos < t.size() && t[pos] == '(') {
    const std::size_t close = t.find(')', pos);
    if (close == std::string::npos) fail("missing ')'");
    std::string inner = t.substr(pos + 1, close - pos - 1);
    std::set<std::string> seen;  // in lower case: fields are found ignoring case
    std::size_t b = 0;
    for (;;) {
      const std::size_t c = inner.find(',', b);
      std::string arg = trimmed(inner.substr(b, c == std::string::npos ? std::string::npos : c - b));
      if (!valid_field_pattern(arg)) fail("'" + arg + "' is not a field name, range (b000..b191) or glob (b*)");
      if (!seen.insert(detail::to_lower(arg)).second) fail("it lists field '" + arg + "' twice");
      s.m_args.push_back(arg);
      if (c == std::string::npos) break;
      b = c + 1;
    }
    pos = close + 1;
  }
  if (pos < t.size() && t[pos] == ':') {
    const std::size_t c = t.find(',', pos + 1);
    const std::string thr = trimmed(t.substr(pos + 1, c == std::string::npos ? std::string::npos : c - pos - 1));
    const double v = parse_number(thr, "threshold of modality '" + t + "'");
    if (v < 0) fail("the threshold must not be negative");
    s.m_threshold = v;
    pos = c == std::string::npos ? t.size() : c;
  }
  while (pos < t.size()) {
    if (t[pos] != ',') fail("unexpected '" + t.substr(pos) + "'");
    const std::size_t c = t.find(',', pos + 1);
    const std::string kv = trimmed(t.substr(pos + 1, c == std::string::npos ? std::string::npos : c - pos - 1));
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos) fail("option '" + kv + "' is not key=value");
    const std::string key = trimmed(kv.substr(0, eq));
    if (!valid_identifier(key)) fail("bad option name '" + key + "'");
    if (s.m_options.count(key)) fail("option '" + key + "' given twice");
    s.m_options[key] = trimmed(kv.substr(eq + 1));
    pos = c == std::string::npos ? t.size() : c;
  }
  return s;
}

std::optional<std::string> modality_spec::take(const std::string& key) {
  auto it = m_options.find(key);
  if (it == m_options.end()) return std::nullopt;
  m_taken[key] = true;
  return it->second;
}

std::vector<std::string> modality_spec::unused_options() const {
  std::vector<std::string> out;
  for (const auto& kv : m_options)
    if (!m_taken.count(kv.first)) out.push_back(kv.first);
  return out;
}

namespace {

struct registry {
  using table = std::map<std::string, std::pair<modality_factory, std::string>>;
  std::mutex mutex;
  table factories;
  // While a plugin registers: the table before it, and the names it registers.
  std::optional<table> saved;
  std::vector<std::string> log;

  registry() {
    builtin_modalities::for_each([this](auto* type) {
      using M = std::remove_pointer_t<decltype(type)>;
      factories[M::spec_name] = {factory_of<M>(), M::spec_help};
    });
  }
  static registry& instance() {
    static registry r;
    return r;
  }
};
}  // namespace

void register_modality(const std::string& name, modality_factory factory, std::string help) {
  if (!valid_identifier(name)) throw std::invalid_argument("register_modality: bad name '" + name + "'");
  auto& r = registry::instance();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.factories[name] = {std::move(factory), std::move(help)};
  if (r.saved) r.log.push_back(name);
}

namespace detail {
void begin_registration_log() {
  auto& r = registry::instance();
  std::lock_guard<std::mutex> lock(r.mutex);
  r.saved = r.factories;
  r.log.clear();
}

std::vector<std::string> end_registration_log(bool roll_back) {
  auto& r = registry::instance();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (roll_back && r.saved) r.factories = std::move(*r.saved);
  r.saved.reset();
  std::vector<std::string> names = std::move(r.log);
  r.log.clear();
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  return names;
}
}  // namespace detail

std::vector<std::pair<std::string, std::string>> registered_modalities() {
  auto& r = registry::instance();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& kv : r.factories) out.emplace_back(kv.first, kv.second.second);
  return out;
}

any_modality make_modality(std::string_view text) {
  modality_spec spec = modality_spec::parse(text);
  modality_factory factory;
  {
    auto& r = registry::instance();
    std::lock_guard<std::mutex> lock(r.mutex);
    auto it = r.factories.find(spec.name());
    if (it == r.factories.end()) {
      std::string known;
      for (const auto& kv : r.factories) known += (known.empty() ? "" : ", ") + kv.first;
      throw std::invalid_argument("unknown modality '" + spec.name() + "' in '" + spec.text() + "' (known: " + known +
                                  ")");
    }
    factory = it->second.first;
  }
  any_modality m = factory(spec);
  // Any modality may be measured at another scale; positions also as the
  // shift between two scales' centroids (inner=).
  if (auto scale = spec.take("scale")) {
    double inner = 0;
    if (auto in = spec.take("inner")) inner = parse_number(*in, "inner= in '" + spec.text() + "'");
    m = scaled_modality(std::move(m), parse_number(*scale, "scale= in '" + spec.text() + "'"), inner);
  }
  if (spec.args_unused())
    throw std::invalid_argument("modality '" + spec.name() + "' takes no field list (in '" + spec.text() + "')");
  const auto unused = spec.unused_options();
  if (!unused.empty())
    throw std::invalid_argument("modality '" + spec.name() + "' has no option '" + unused.front() + "' (in '" +
                                spec.text() + "')");
  return m;
}

namespace {

/// The presets, one row each: a new preset is a row here (its figures go to
/// docs/RESULTS.md and its line to "Which preset for which data").
struct preset_row {
  const char* name;
  std::vector<const char*> specs;
  double keypoint_share;  ///< detect_params::keypoint_share
  bool refine;            ///< detect_params::refine
};

const std::vector<preset_row>& preset_table() {
  // ced3d and ced6d are the paper's. docs/journal/presets.md: robust3d's centroid distance at 2 × the
  // radius (apartment_mesh_214, small_gicp's LiDAR pair), robust6d's centroid shift (inner=1; also the
  // Open3D RGB-D frames and PCL's PrimeSense pair) with colour at 0.5, both keeping 1 % of their
  // candidates and refining. corner3d: the corner modality at r and at 1.5 r (a corner at both
  // scales), refined, chosen on the tuning pairs of docs/threedmatch_pairs.py
  // (docs/journal/real-pairs.md).
  static const std::vector<preset_row> rows = {
      {"ced3d", {"xyz:0.2"}, 0, false},
      {"ced6d", {"xyz:0.2", "rgb:0.1"}, 0, false},
      {"robust3d", {"xyz:0.2,scale=2"}, 0.01, true},
      {"robust6d", {"xyz:0.2,scale=2.25,inner=1", "rgb:0.5"}, 0.01, true},
      {"corner3d", {"corner:0.05", "corner:0.05,scale=1.5"}, 0, true},
  };
  return rows;
}

const preset_row& preset_of(std::string_view name) {
  for (const auto& row : preset_table())
    if (name == row.name) return row;
  std::string known;
  for (const auto& row : preset_table()) known += (known.empty() ? "" : ", ") + std::string(row.name);
  throw std::invalid_argument("unknown preset '" + std::string(name) + "' (known: " + known + ")");
}

}  // namespace

std::vector<any_modality> preset(std::string_view name) {
  std::vector<any_modality> out;
  for (const char* spec : preset_of(name).specs) out.push_back(make_modality(spec));
  return out;
}

std::vector<std::string> preset_specs(std::string_view name) {
  const auto& specs = preset_of(name).specs;
  return {specs.begin(), specs.end()};
}

std::vector<std::string> preset_names() {
  std::vector<std::string> out;
  for (const auto& row : preset_table()) out.emplace_back(row.name);
  return out;
}

double preset_keypoint_share(std::string_view name) { return preset_of(name).keypoint_share; }

bool preset_refines(std::string_view name) { return preset_of(name).refine; }

}  // namespace ced
