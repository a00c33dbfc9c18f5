// SPDX-License-Identifier: MIT
// Docs drift (#26 item 7): the numbers the docs quote from code constants are
// the constants, and docs/ARCHITECTURE.md's parts name every source file.
// Each check builds the sentence the doc should hold from the code and looks
// for it; a failure shows what the doc says instead.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "core/nms.hpp"
#include "file_support.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path root = fs::path(CED_TEST_DATA_DIR).parent_path().parent_path();

/// A doc with its whitespace runs collapsed to one space: Markdown wraps
/// sentences anywhere.
std::string read_doc(const std::string& name) {
  const std::string text = ced_test::read_bytes((root / "docs" / name).string());
  EXPECT_FALSE(text.empty()) << "docs/" << name << " is missing or empty";
  return std::regex_replace(text, std::regex("[ \t\r\n]+"), " ");
}

/// A number as the docs write it: 0.05, 5, 0.2.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// `doc` (docs/`name`, collapsed) holds `expected`, which starts with
/// `anchor`; otherwise the failure shows what follows the anchor in the doc.
void expect_quoted(const std::string& doc, const std::string& name, const std::string& anchor,
                   const std::string& expected, const std::string& source) {
  ASSERT_EQ(expected.compare(0, anchor.size(), anchor), 0) << "test bug: " << expected;
  if (doc.find(expected) != std::string::npos) return;
  const auto at = doc.find(anchor);
  if (at == std::string::npos) {
    ADD_FAILURE() << "docs/" << name << " no longer has \"" << anchor << "\", where it quoted " << source
                  << ".\n  The code says: \"" << expected << "\"";
    return;
  }
  ADD_FAILURE() << "docs/" << name << " quotes " << source << " differently from the code:\n  docs/" << name
                << " says: \"" << doc.substr(at, expected.size() + 20) << "...\"\n  the code says:  \"" << expected
                << "\"\n  Fix the doc (or the constant, if the doc is right).";
}

}  // namespace

TEST(Docs, KeptSweepBudget) {
  using namespace ced::detail;
  ASSERT_EQ(kept_sweeps_min_bytes % (std::size_t(1) << 20), 0u);
  const std::string mib = std::to_string(kept_sweeps_min_bytes >> 20);
  const std::string per_point = std::to_string(kept_sweeps_bytes_per_point);
  const std::string source =
      "the kept sweeps' budget (kept_sweeps_min_bytes, kept_sweeps_bytes_per_point in "
      "src/core/nms.hpp)";
  expect_quoted(read_doc("ALGORITHM.md"), "ALGORITHM.md", "within a budget of",
                "within a budget of " + mib + " MiB or " + per_point + " bytes a point, whichever is more", source);
  expect_quoted(read_doc("ARCHITECTURE.md"), "ARCHITECTURE.md", "The sweeps have a budget of",
                "The sweeps have a budget of " + mib + " MiB or " + per_point + " bytes a point, whichever is more",
                source);
  EXPECT_EQ(kept_sweeps_budget(0), kept_sweeps_min_bytes);
  EXPECT_EQ(kept_sweeps_budget(100'000'000), kept_sweeps_bytes_per_point * 100'000'000);
}

TEST(Docs, PaperDefaults) {
  const ced::detect_params p;
  const auto ced6d = ced::preset("ced6d");
  ASSERT_EQ(ced6d.size(), 2u);
  ASSERT_EQ(p.nms_radius, p.radius) << "ALGORITHM.md says r = r_nms";
  const std::string ratio = num(ced6d[0].threshold(p) / p.radius), rgb = num(ced6d[1].threshold(p));
  const std::string source = "the paper defaults (detect_params in include/ced/params.hpp, the ced6d preset)";
  const std::string doc = read_doc("ALGORITHM.md");
  expect_quoted(doc, "ALGORITHM.md", "Paper defaults:",
                "Paper defaults: r = r_nms = " + num(p.radius) + " m at 0.01 m resolution, k = " +
                    std::to_string(p.min_neighbors) + ", t_xyz = " + ratio + " · r, t_rgb = " + rgb + ".",
                source);
  expect_quoted(doc, "ALGORITHM.md", "t = ratio · r (paper:", "t = ratio · r (paper: " + ratio + " · r)", source);
  expect_quoted(doc, "ALGORITHM.md", "normalised units (paper:", "normalised units (paper: rgb " + rgb + ")", source);
  EXPECT_EQ(num(ced::xyz{}.ratio), ratio) << "ced::xyz's default ratio and the ced6d preset's";
}

TEST(Docs, Presets) {
  // CLI.md's --preset row: "`ced3d` = `xyz:0.2`; ...; `robust6d` = ... + `--refine` (...".
  std::string expected = "`--preset NAME` | ";
  const auto names = ced::preset_names();
  for (std::size_t i = 0; i < names.size(); ++i) {
    expected += (i ? "; `" : "`") + names[i] + "` =";
    const auto specs = ced::preset_specs(names[i]);
    for (std::size_t k = 0; k < specs.size(); ++k) expected += (k ? " + `" : " `") + specs[k] + "`";
    if (ced::preset_refines(names[i])) expected += " + `--refine`";
    if (const double share = ced::preset_keypoint_share(names[i]); share > 0)
      expected += " + `--keypoint-share " + num(share) + "`";
  }
  expect_quoted(read_doc("CLI.md"), "CLI.md", "`--preset NAME` | ", expected,
                "the presets (preset_specs, preset_refines, preset_keypoint_share in src/core/registry.cpp)");
}

TEST(Docs, PresetsInThePythonStubAndTheShareRow) {
  // The stub's preset() and preset_keypoint_share() docstrings and CLI.md's
  // --keypoint-share row; tests/python/test_stubs.py checks the module's own
  // docstrings against the stub.
  const std::string stub = std::regex_replace(
      ced_test::read_bytes((root / "src" / "python" / "ced" / "__init__.pyi").string()), std::regex("[ \t\r\n]+"), " ");
  ASSERT_FALSE(stub.empty()) << "src/python/ced/__init__.pyi is missing or empty";
  const std::string cli = read_doc("CLI.md");
  for (const auto& name : ced::preset_names()) {
    std::string expected = "'" + name + "' (";
    const auto specs = ced::preset_specs(name);
    for (std::size_t k = 0; k < specs.size(); ++k) expected += (k ? ", " : "") + specs[k];
    expected += ")";
    EXPECT_NE(stub.find(expected), std::string::npos)
        << "src/python/ced/__init__.pyi's preset() does not say " << expected << " (preset_specs)";
  }
  // "0.01 for robust3d and robust6d": the presets with a share, by share.
  std::map<double, std::string> by_share;
  for (const auto& name : ced::preset_names())
    if (const double share = ced::preset_keypoint_share(name); share > 0) {
      std::string& names = by_share[share];
      names += (names.empty() ? "" : " and ") + name;
    }
  for (const auto& [share, names] : by_share) {
    const std::string said = num(share) + " for " + names;
    EXPECT_NE(stub.find(": " + said), std::string::npos)
        << "src/python/ced/__init__.pyi's preset_keypoint_share() does not say " << said;
    expect_quoted(cli, "CLI.md", "| the preset's: ", "| the preset's: " + said,
                  "the presets' keypoint shares (preset_keypoint_share in src/core/registry.cpp)");
  }
}

TEST(Docs, ArchitectureNamesEverySourceFile) {
  // The parts section: from "## The parts" to the next "## ".
  const std::string text = ced_test::read_bytes((root / "docs" / "ARCHITECTURE.md").string());
  const auto begin = text.find("## The parts");
  ASSERT_NE(begin, std::string::npos) << "docs/ARCHITECTURE.md has no \"## The parts\"";
  const auto end = text.find("\n## ", begin + 1);
  const std::string parts = text.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
  std::set<std::string> quoted;  // `...` spans
  const std::regex code("`([^`\\s]+)`");
  for (std::sregex_iterator i(parts.begin(), parts.end(), code), e; i != e; ++i) quoted.insert((*i)[1]);

  // Every src/**.cpp is named, itself or one of its folders (`src/core/`).
  std::vector<std::string> sources;
  for (const auto& entry : fs::recursive_directory_iterator(root / "src"))
    if (entry.is_regular_file() && entry.path().extension() == ".cpp")
      sources.push_back(entry.path().lexically_relative(root).generic_string());
  std::sort(sources.begin(), sources.end());
  ASSERT_FALSE(sources.empty());
  for (const auto& source : sources) {
    bool named = quoted.count(source) > 0;
    for (fs::path folder = fs::path(source).parent_path(); !named && folder != "src" && !folder.empty();
         folder = folder.parent_path())
      named = quoted.count(folder.generic_string() + "/") > 0;
    EXPECT_TRUE(named) << "docs/ARCHITECTURE.md's parts (## The parts) name neither `" << source
                       << "` nor its folder: add it to the table, or its folder";
  }

  // Every file it names exists: a path from the top (`src/...`, `cmake/...`),
  // a public header (`ced/...`), a file of src/ by its name or its tail, or a
  // file generated from cmake/<name>.in (`ced/version.hpp`).
  for (const auto& q : quoted) {
    const fs::path p(q);
    const std::string ext = p.extension().string();
    const bool is_path = q.rfind("src/", 0) == 0 || q.rfind("cmake/", 0) == 0;
    if (!is_path && ext != ".cpp" && ext != ".hpp" && ext != ".cmake") continue;
    bool exists = fs::exists(root / p) || fs::exists(root / "include" / p) || fs::exists(root / "modalities" / p) ||
                  fs::exists(root / "cmake" / p) || fs::exists(root / "cmake" / (p.filename().string() + ".in"));
    for (auto i = fs::recursive_directory_iterator(root / "src"); !exists && i != fs::recursive_directory_iterator();
         ++i) {
      const std::string path = i->path().generic_string();
      exists = path.size() > q.size() && path.compare(path.size() - q.size(), q.size(), q) == 0 &&
               path[path.size() - q.size() - 1] == '/';
    }
    EXPECT_TRUE(exists) << "docs/ARCHITECTURE.md's parts name `" << q << "`, which is no file of the project";
  }
}

#ifdef CED_CLI_EXE
#include "cli/detect.hpp"

namespace {

/// `ced detect --help`, one line an option.
std::string detect_help() {
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(CED_CLI_EXE " detect --help 2>&1", "r"), pclose);
  if (!pipe) return {};
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, pipe.get())) > 0;) out.append(buf, n);
  return out;
}

}  // namespace

TEST(Docs, CliDetectDefaults) {
  // The defaults in the code (detect_options, src/cli/detect.hpp; the radius
  // of the presets is detect_params'), in `ced detect --help` and in
  // docs/CLI.md's `ced detect` table must agree.
  const ced_cli::detect_options o;
  const std::vector<std::pair<std::string, std::string>> code = {
      {"--radius", num(ced::detect_params{}.radius)},
      {"--radius-factor", num(o.radius_factor)},
      {"--min-neighbors", std::to_string(o.min_neighbors)},
      {"--threads", std::to_string(o.threads)},
      {"--view", o.view},
      {"--png-size", o.png_size},
      {"--png-color", o.png_color},
      {"--html-max-points", std::to_string(o.html_max_points)}};

  // The help's line of each option (CLI11 wraps nothing: one line an option).
  std::map<std::string, std::string> help_line;
  std::istringstream help(detect_help());
  const std::regex option_line("^ +(?:-[a-z],)?(--[a-z][a-z0-9-]*)\\b.*");
  for (std::string line; std::getline(help, line);) {
    std::smatch m;
    if (std::regex_match(line, m, option_line)) help_line[m[1]] = line;
  }
  ASSERT_GT(help_line.size(), 10u) << "could not read `" CED_CLI_EXE " detect --help`";

  // CLI.md's rows: | `-k, --min-neighbors K` | meaning | 5 |
  const std::string text = ced_test::read_bytes((root / "docs" / "CLI.md").string());
  const auto begin = text.find("## `ced detect`");
  ASSERT_NE(begin, std::string::npos) << "docs/CLI.md has no \"## `ced detect`\"";
  const auto end = text.find("\n## ", begin + 1);
  std::map<std::string, std::string> doc_default;
  std::istringstream table(text.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
  const std::regex row(R"(^\| ((?:[^|\\]|\\.)+) \|.*\| ([^|]*) \|$)");  // a cell may hold "\|"
  const std::regex long_option("--[a-z][a-z0-9-]*");
  for (std::string line; std::getline(table, line);) {
    std::smatch m;
    if (!std::regex_match(line, m, row)) continue;
    const std::string options = m[1];
    for (std::sregex_iterator i(options.begin(), options.end(), long_option), e; i != e; ++i)
      doc_default[i->str()] = m[2];
  }

  for (const auto& [option, value] : code) {
    SCOPED_TRACE(option);
    // The doc's default begins with the value (it may say more: "0.05 with `--preset`, else `auto`").
    const auto d = doc_default.find(option);
    if (d == doc_default.end()) {
      ADD_FAILURE() << "docs/CLI.md's `ced detect` table has no row for " << option;
    } else {
      const std::string first = std::regex_replace(d->second, std::regex("^`?([^ `]*).*$"), "$1");
      EXPECT_EQ(first, value) << "docs/CLI.md gives " << option << " the default \"" << d->second
                              << "\"; the code's is " << value;
    }
    // The help says "default" and the value on the option's line.
    const auto h = help_line.find(option);
    if (h == help_line.end()) {
      ADD_FAILURE() << "`ced detect --help` has no line for " << option;
    } else {
      const std::regex says("\\bdefault\\b.*[ (:]" + std::regex_replace(value, std::regex("[.]"), "\\.") + "\\b|\\b" +
                            std::regex_replace(value, std::regex("[.]"), "\\.") + "\\b.*\\bdefault\\b");
      EXPECT_TRUE(std::regex_search(h->second, says))
          << "`ced detect --help` does not give " << option << " the default " << value << ":\n"
          << h->second;
    }
  }
}
#endif
