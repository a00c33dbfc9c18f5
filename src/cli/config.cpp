// SPDX-License-Identifier: MIT
// --config files (TOML-like and JSON), expanded into the command line; the number options hardened.
#include "common.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <system_error>
#include <unordered_set>
#include <vector>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/io.hpp"
#include "ced/io/rgbd.hpp"
#include "ced/io/stream.hpp"
#include "ced/plugin.hpp"
#include "ced/preprocess.hpp"

namespace ced_cli {

std::vector<CLI::ConfigItem> json_config::from_config(std::istream& in) const {
  nlohmann::json j;
  std::unordered_set<std::string> keys;  // of the top object: JSON keeps the last of a duplicate
  std::string twice;
  const auto key_once = [&](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    if (event == nlohmann::json::parse_event_t::key && depth == 1 && !keys.insert(parsed.get<std::string>()).second &&
        twice.empty())
      twice = parsed.get<std::string>();
    return true;
  };
  try {
    j = nlohmann::json::parse(in, key_once);
  } catch (const nlohmann::json::exception& e) {
    throw CLI::ConversionError("--config: not valid JSON: " + std::string(e.what()));
  }
  if (!twice.empty()) throw CLI::ConversionError("'" + twice + "' is given twice");
  if (!j.is_object()) throw CLI::ConversionError("--config: the JSON file must hold one object");
  std::vector<CLI::ConfigItem> config_items;
  auto text = [](const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
  for (const auto& [key, value] : j.items()) {
    CLI::ConfigItem item;
    item.name = key;
    if (value.is_array())
      for (const auto& v : value) item.inputs.push_back(text(v));
    else
      item.inputs.push_back(text(value));
    config_items.push_back(std::move(item));
  }
  return config_items;
}

namespace {

// A config holds options with a value or an array of values: two levels of
// brackets and braces (the JSON object, an array; TOML's [[table]] headers).
// Deeper nesting is refused before a parser sees it: JSON objects nested
// 100,000 deep overflowed the stack (#25).
constexpr int max_config_depth = 4;
// Far more than any set of options takes; keeps --config /dev/zero from filling memory.
constexpr std::size_t max_config_bytes = std::size_t{1} << 20;

/// The text of the --config file at `path`.
std::string read_config_text(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw usage_error("--config: '" + path + "' is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw usage_error("--config: cannot open '" + path + "'");
  std::string text(max_config_bytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad()) throw usage_error("--config: cannot read '" + path + "'");
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > max_config_bytes)
    throw usage_error("--config " + path + ": larger than " + std::to_string(max_config_bytes >> 20) +
                      " MiB (a config file holds options)");
  return text;
}

/// 0 when brackets and braces nest at most max_config_depth deep in `text`,
/// strings (and TOML comments) aside; else the line where they go deeper.
/// TOML/INI strings end with their line, as CLI11 reads them.
std::size_t line_too_deep(const std::string& text, bool json) {
  int depth = 0;
  std::size_t line = 1;
  char quote = 0;  // the quote of the string we are in, if any
  bool comment = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      comment = false;
      if (!json) quote = 0;
    } else if (comment) {
    } else if (quote) {
      if (c == '\\' && quote != '\'' && i + 1 < text.size() && text[i + 1] != '\n')
        ++i;  // an escaped character
      else if (c == quote)
        quote = 0;
    } else if (c == '"' || (!json && (c == '\'' || c == '`'))) {
      quote = c;
    } else if (!json && c == '#') {
      comment = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_config_depth) return line;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return 0;
}

/// The items of the --config file at `path`: JSON for .json, else TOML/INI.
std::vector<CLI::ConfigItem> read_config_items(const std::string& path) {
  const std::string text = read_config_text(path);
  const bool json = path.size() > 5 && path.compare(path.size() - 5, 5, ".json") == 0;
  if (const std::size_t line = line_too_deep(text, json))
    throw usage_error("--config " + path + ": brackets or braces nested more than " + std::to_string(max_config_depth) +
                      " deep (line " + std::to_string(line) +
                      "); a config holds options with a value or an array of values");
  std::istringstream in(text);
  std::vector<CLI::ConfigItem> items;
  try {
    items = json ? json_config().from_config(in) : CLI::ConfigTOML().from_config(in);
  } catch (const std::exception& e) {
    throw usage_error("--config " + path + ": " + e.what());
  }
  // One value an option: a key given twice is a mistake, not "the last wins".
  // CLI11 merges a TOML key given on consecutive lines into one item: the lines say.
  if (!json) {
    std::unordered_set<std::string> keys;
    std::istringstream lines(text);
    std::string section, line;
    while (std::getline(lines, line)) {
      const auto b = line.find_first_not_of(" \t");
      if (b == std::string::npos) continue;
      if (line[b] == '[') section = line.substr(b, line.find(']', b) - b + 1);
      const auto eq = line.find('=', b);
      if (!(std::isalpha(static_cast<unsigned char>(line[b])) || line[b] == '_') || eq == std::string::npos) continue;
      std::string key = line.substr(b, eq - b);
      key.erase(key.find_last_not_of(" \t") + 1);
      if (!keys.insert(section + key).second) throw usage_error("--config " + path + ": '" + key + "' is given twice");
    }
  }
  std::unordered_set<std::string> seen;
  for (const auto& item : items)
    if (item.name != "++" && item.name != "--" && !seen.insert(item.fullname()).second)
      throw usage_error("--config " + path + ": '" + item.fullname() + "' is given twice");
  return items;
}

/// A flag's value in a config: true or false (also 1 or 0).
bool flag_value(const std::string& path, const CLI::ConfigItem& item) {
  const std::string v = item.inputs.size() == 1 ? item.inputs[0] : std::string();
  if (v == "true" || v == "1") return true;
  if (v == "false" || v == "0") return false;
  const std::string got = item.inputs.empty()      ? "no value"
                          : item.inputs.size() > 1 ? std::to_string(item.inputs.size()) + " values"
                                                   : "'" + v + "'";
  throw usage_error("--config " + path + ": '" + item.name + "' is a flag: its value must be true or false, got " +
                    got);
}

/// Whether `opt` is among the command-line arguments `rest`.
bool given_on_command_line(const CLI::Option* opt, const std::vector<std::string>& rest) {
  for (const auto& a : rest) {
    for (const auto& l : opt->get_lnames())
      if (a == "--" + l || a.rfind("--" + l + "=", 0) == 0) return true;
    for (const auto& sn : opt->get_snames())
      if (a == "-" + sn) return true;
  }
  return false;
}

}  // namespace

std::vector<std::string> expand_config(const std::vector<std::string>& args, CLI::App& det) {
  const auto sub = std::find(args.begin(), args.end(), "detect");
  if (sub == args.end()) return args;
  std::string path;
  bool given = false;
  std::vector<std::string> rest;
  for (auto it = sub + 1; it != args.end(); ++it) {
    const bool config = (*it == "--config" && it + 1 != args.end()) || it->rfind("--config=", 0) == 0;
    if (config && given) throw usage_error("--config given twice");
    if (*it == "--config" && it + 1 != args.end()) {
      path = *++it;
    } else if (it->rfind("--config=", 0) == 0) {
      path = it->substr(9);
    } else {
      rest.push_back(*it);
    }
    given = given || config;
  }
  if (!given) return args;
  if (path.empty()) throw usage_error("--config: no file given");
  const std::vector<CLI::ConfigItem> items = read_config_items(path);
  std::vector<std::string> out(args.begin(), sub + 1);
  std::map<std::string, std::string> where;  // option -> the key that gave it (a section's keys count too)
  for (const auto& item : items) {
    if (item.name == "++" || item.name == "--") continue;  // TOML section markers
    const auto [at, added] = where.emplace(item.name, item.fullname());
    if (!added)
      throw usage_error("--config " + path + ": '" + item.name + "' is given twice ('" + at->second + "' and '" +
                        item.fullname() + "')");
    const CLI::Option* opt = det.get_option_no_throw("--" + item.name);
    if (!opt || item.name == "config") throw usage_error("--config " + path + ": unknown key '" + item.name + "'");
    if (opt->get_expected_max() == 0) {  // a flag (CLI11 gives flags a type size of 1)
      if (flag_value(path, item) && !given_on_command_line(opt, rest)) out.push_back("--" + item.name);
      continue;
    }
    if (item.inputs.empty() ||
        std::any_of(item.inputs.begin(), item.inputs.end(), [](const std::string& v) { return v.empty(); }))
      throw usage_error("--config " + path + ": '" + item.name + "' has no value");
    if (given_on_command_line(opt, rest)) continue;
    for (const auto& v : item.inputs) {
      out.push_back("--" + item.name);
      out.push_back(v);
    }
  }
  out.insert(out.end(), rest.begin(), rest.end());
  return out;
}

namespace {

/// Every output path option of `app` and its subcommands refuses an empty
/// path (an unset $OUT in a script would otherwise pass as "not given"),
/// and every count option reads its digits as decimal: CLI11 takes a
/// leading 0 as octal (--tile 010 was tile 8, --max-keypoints 08 an error).
void harden_options(CLI::App* app) {
  static const char* const outputs[] = {"output", "indices", "indices-original", "viewer",
                                        "png",    "html",    "summary",          "csv"};
  static const char* const counts[] = {"tile", "min-neighbors", "max-keypoints", "threads", "html-max-points",
                                       "seed", "trials",        "random-draws",  "knn"};
  const CLI::Validator non_empty(
      [](std::string& v) { return v.empty() ? std::string("an empty path: give a file name") : std::string(); },
      "PATH");
  // Digits only (after a sign, where one is allowed), leading zeros dropped.
  const auto decimal_digits = [](std::string& v, bool sign) {
    std::size_t digits = v.size() > 1 && (v[0] == '+' || (sign && v[0] == '-')) ? 1 : 0;
    if (v.size() == digits || v.find_first_not_of("0123456789", digits) != std::string::npos)
      return v.empty()              ? std::string("an empty value: give a whole number")
             : !sign && v[0] == '-' ? "'" + v + "' is negative: give a whole number from 0"
                                    : "'" + v + "' is not a whole decimal number";
    std::size_t zeros = digits;
    while (zeros + 1 < v.size() && v[zeros] == '0') ++zeros;
    v.erase(digits, zeros - digits);
    return std::string();
  };
  // (An unsigned option read "-1" as 2^64 - 1.)
  const CLI::Validator unsigned_decimal([=](std::string& v) { return decimal_digits(v, false); }, "");
  const CLI::Validator decimal([=](std::string& v) { return decimal_digits(v, true); }, "");
  // Numbers: never empty, never hexadecimal. CLI11 reads "" as 0 and takes
  // hexadecimal ("0x10", "0x1p4"), "nan" and "inf" as C's strtod does.
  const auto not_decimal = [](const std::string& v) {
    if (v.empty()) return std::string("an empty value: give a number");
    if (v.find_first_of("xX") != std::string::npos) return "'" + v + "' is not a decimal number";
    return std::string();
  };
  // ... and finite.
  const CLI::Validator finite(
      [=](std::string& v) {
        if (std::string bad = not_decimal(v); !bad.empty()) return bad;
        const char* b = v.c_str();
        char* e = nullptr;
        const double d = std::strtod(b, &e);
        if (e != b && *e == '\0' && !std::isfinite(d)) return "'" + v + "' is not a finite number";
        return std::string();
      },
      "");
  // Options kept as text that take a number or a list of them (or "auto",
  // "4G"), and numbers with a check of their own (which reads C's way):
  // never empty, never hexadecimal.
  static const char* const numbers_as_text[] = {"radius",     "keypoint-share", "tile-size", "memory-limit",
                                                "nms-radius", "noise",          "counts"};
  const CLI::Validator number_text([=](std::string& v) { return not_decimal(v); }, "");
  // (Names compared as they are: check_lname() folds case for every call, which cost ~1 M instructions a start.)
  const auto is_in = [](const std::string& name, const auto& list) {
    for (const char* n : list)
      if (name == n) return true;
    return false;
  };
  for (CLI::Option* opt : app->get_options([](const CLI::Option*) { return true; })) {
    bool count = false;
    for (const std::string& l : opt->get_lnames()) {
      if (is_in(l, outputs)) opt->check(non_empty);
      if (is_in(l, counts)) count = true;
      if (is_in(l, numbers_as_text)) opt->check(number_text);
    }
    if (opt->get_expected_max() == 0) continue;  // a flag
    const std::string type = opt->get_type_name();
    if (type == "UINT")
      opt->transform(unsigned_decimal);
    else if (count || type == "INT")
      opt->transform(decimal);
    else if (type == "FLOAT")
      opt->check(finite);
  }
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) harden_options(sub);
}

}  // namespace

std::optional<int> parse_command_line(CLI::App& app, CLI::App& detect, int argc, char** argv, const std::string& name,
                                      bool report) {
  harden_options(&app);
  std::vector<std::string> args(argv + 1, argv + argc);
  try {
    args = expand_config(args, detect);
    std::reverse(args.begin(), args.end());  // CLI11 takes a reversed vector
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    if (!report) return exit_usage;
    return app.exit(e) == 0 ? exit_ok : exit_usage;
  } catch (const std::exception& e) {
    if (report) std::cerr << name << ": error: " << e.what() << "\n";
    return exit_usage;
  }
  return std::nullopt;
}

}  // namespace ced_cli
