// SPDX-License-Identifier: MIT
// Docs drift (#26 item 7): the numbers the docs quote from code constants are
// the constants, and docs/ARCHITECTURE.md's parts name every source file.
// The front door (#58): README.md's length, no measured figure outside
// docs/RESULTS.md, every result's date, machine, command and commit, and
// every relative link of the docs.
// Each check builds the sentence the doc should hold from the code and looks
// for it; a failure shows what the doc says instead.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
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

// The front door and the results page (#58): README.md is short and shows code
// early, the README and the reference pages quote no measured figure of their
// own (docs/RESULTS.md holds them, each row with its date, machine, command and
// commit), and every relative link of the docs reaches a file and a heading.
namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

/// A line that opens or closes a fenced code block.
bool is_fence(const std::string& line) { return trimmed(line).rfind("```", 0) == 0; }

/// The pages that quote no measured figure of their own: the README and the
/// reference pages. docs/RESULTS.md holds the figures, docs/journal/ the
/// dated experiments; neither is checked here.
const std::vector<std::string> pages_without_figures = {
    "README.md",      "docs/ALGORITHM.md",  "docs/ARCHITECTURE.md", "docs/BENCHMARKS.md",
    "docs/CLI.md",    "docs/CPP.md",        "docs/EVALUATION.md",   "docs/MODALITIES.md", "docs/MULTISPECTRAL.md",
    "docs/PYTHON.md", "docs/ROBUSTNESS.md", "docs/SCALE.md",        "docs/VIEWER.md"};

/// A page's prose outside code: one string a paragraph, list item or table
/// row, its lines joined by a space (Markdown wraps a figure and its unit
/// anywhere). Fenced blocks and indented code blocks are left out.
std::vector<std::string> prose_units(const std::string& text) {
  static const std::regex list_item(R"(^(-|\*|\d+\.)\s)");
  std::vector<std::string> units;
  std::string unit;
  bool fence = false;
  const auto flush = [&] {
    if (!unit.empty()) units.push_back(unit);
    unit.clear();
  };
  for (const auto& line : lines_of(text)) {
    const std::string s = trimmed(line);
    if (is_fence(line)) {
      flush();
      fence = !fence;
      continue;
    }
    if (fence) continue;
    if (unit.empty() && line.rfind("    ", 0) == 0 && !s.empty() && s[0] != '-' && s[0] != '|') continue;
    if (s.empty() || s[0] == '#') {
      flush();
      continue;
    }
    if (s[0] == '|' || std::regex_search(s, list_item)) {
      flush();
      unit = s;
      if (s[0] == '|') flush();
      continue;
    }
    unit += (unit.empty() ? "" : " ") + s;
  }
  flush();
  return units;
}

/// What a measured figure looks like in this project's docs: a number with a
/// unit of time or throughput, a speed-up, a lift or a repeatability, a peak
/// of memory, an instruction count, a count of tests. Parameters (radii,
/// thresholds, budgets, sizes of formats, multiples of the resolution) do not
/// match. Checked against the README and the pages as they were before #58,
/// which all fail.
const std::vector<std::pair<std::string, std::regex>>& figure_patterns() {
  static const std::string n = R"(\d+(?:,\d{3})*(?:\.\d+)?)";
  static const std::string r = n + R"((?:\s?(?:–|-)\s?)" + n + ")?";
  static const std::vector<std::pair<std::string, std::regex>> patterns = {
      {"a time", std::regex(r + R"(\s?(?:ms|µs|ns|s|min)(?![\w/]))")},
      {"a throughput", std::regex(r + R"(\s?(?:[kMG]i?B/s|M? ?points(?:/s| a second| per second))(?!\w))")},
      {"a speed-up",
       std::regex(
           r +
           R"(\s?(?:×|x)(?=\s*(?:$|[),;:.]|faster|slower|ced6d|the time|its time|as fast|the paper|over |before|against|in |on )))")},
      {"a speed-up",
       std::regex(r + R"((?:×|x) (?!the resolution|res\b|the radius|r\b|voxel|spacing|the NMS|as many))")},
      {"a lift", std::regex(R"(\blifts?\b(?:(?!\. )[^|]){0,60}?\b)" + n)},
      {"a repeatability", std::regex(R"(\brepeat(?:s|ed|ability)?\b(?:(?!\. )[^|]){0,60}?\b(?:0\.\d{2,3}|\d+\s?%))")},
      {"a peak of memory",
       std::regex(R"(\b(?:peak|peaks|RSS)\b(?:(?!\. )[^|]){0,40}?)" + r + R"(\s?(?:[kMG]i?B|bytes)\b)")},
      {"memory a point", std::regex(r + R"(\s?(?:B/point|B a point)\b)")},
      {"an instruction count", std::regex(r + R"(\s?M instructions)")},
      {"a count of tests", std::regex(R"(\b\d+(?:,\d{3})* (?:tests|test cases)\b(?!/))")}};
  return patterns;
}

/// The first measured figure of a prose unit that does not link to
/// docs/RESULTS.md, with its kind; empty when there is none.
std::string measured_figure(const std::string& unit) {
  if (unit.find("RESULTS.md") != std::string::npos) return {};
  for (const auto& [kind, pattern] : figure_patterns()) {
    std::smatch m;
    if (std::regex_search(unit, m, pattern)) return kind + " \"" + m.str() + "\"";
  }
  return {};
}

/// GitHub's anchor of a heading: lower case, spaces to '-', punctuation
/// dropped but '-' and '_' (and, beyond ASCII, the Latin-1 and general
/// punctuation, arrows and mathematical operators; letters stay).
std::string heading_slug(const std::string& heading) {
  std::string slug;
  for (std::size_t i = 0; i < heading.size();) {
    const auto c = static_cast<unsigned char>(heading[i]);
    if (c < 0x80) {
      if (std::isalnum(c) || c == '-' || c == '_')
        slug += static_cast<char>(std::tolower(c));
      else if (c == ' ')
        slug += '-';
      ++i;
      continue;
    }
    const std::size_t len = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : 2;
    char32_t cp = c & (len == 2 ? 0x1F : len == 3 ? 0x0F : 0x07);
    for (std::size_t k = 1; k < len && i + k < heading.size(); ++k) cp = (cp << 6) | (heading[i + k] & 0x3F);
    const bool punctuation = (cp >= 0xA0 && cp <= 0xBF) || cp == 0xD7 || cp == 0xF7 || (cp >= 0x2000 && cp <= 0x206F) ||
                             (cp >= 0x2190 && cp <= 0x23FF);
    if (!punctuation) slug += heading.substr(i, len);
    i += len;
  }
  return slug;
}

/// The anchors of a Markdown file: its headings' slugs (a repeated slug gets
/// -1, -2, ... as on GitHub) and its `<a id="...">` tags.
std::set<std::string> anchors_of(const fs::path& file) {
  static const std::regex heading(R"(^#{1,6} (.*?)\s*#*\s*$)");
  static const std::regex id(R"re(<a id="([^"]+)")re");
  std::set<std::string> anchors;
  std::map<std::string, int> seen;
  bool fence = false;
  for (const auto& line : lines_of(ced_test::read_bytes(file.string()))) {
    if (is_fence(line)) fence = !fence;
    if (fence || is_fence(line)) continue;
    std::smatch m;
    if (std::regex_match(line, m, heading)) {
      const std::string slug = heading_slug(m[1]);
      const int n = seen[slug]++;
      anchors.insert(n == 0 ? slug : slug + "-" + std::to_string(n));
    }
    for (std::sregex_iterator i(line.begin(), line.end(), id), e; i != e; ++i) anchors.insert((*i)[1]);
  }
  return anchors;
}

/// The Markdown files whose links are checked: README.md, docs/*.md and docs/journal/*.md.
std::vector<fs::path> markdown_files() {
  std::vector<fs::path> files = {root / "README.md"};
  for (const auto& dir : {root / "docs", root / "docs" / "journal"})
    if (fs::is_directory(dir))
      for (const auto& entry : fs::directory_iterator(dir))
        if (entry.is_regular_file() && entry.path().extension() == ".md") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::string> table_cells(const std::string& row) {
  std::vector<std::string> cells;
  std::string cell;
  for (std::size_t i = 1; i < row.size(); ++i) {  // row[0] is the leading '|'
    if (row[i] == '\\' && i + 1 < row.size() && row[i + 1] == '|') {
      cell += '|';
      ++i;
    } else if (row[i] == '|') {
      cells.push_back(trimmed(cell));
      cell.clear();
    } else {
      cell += row[i];
    }
  }
  if (!trimmed(cell).empty()) cells.push_back(trimmed(cell));
  return cells;
}

}  // namespace

TEST(Docs, ReadmeIsShortAndShowsCodeEarly) {
  const auto lines = lines_of(ced_test::read_bytes((root / "README.md").string()));
  ASSERT_FALSE(lines.empty()) << "README.md is missing or empty";
  EXPECT_LE(lines.size(), 150u) << "README.md has " << lines.size()
                                << " lines; the front door holds at most 150 (figures go to docs/RESULTS.md)";
  const auto fence = std::find_if(lines.begin(), lines.end(), is_fence);
  ASSERT_NE(fence, lines.end()) << "README.md has no code block";
  EXPECT_LE(fence - lines.begin() + 1, 40)
      << "README.md's first code block opens at line " << fence - lines.begin() + 1 << "; it must by line 40";
}

TEST(Docs, NoMeasuredFigureOutsideTheResultsPage) {
  for (const auto& page : pages_without_figures) {
    const std::string text = ced_test::read_bytes((root / page).string());
    EXPECT_FALSE(text.empty()) << page << " is missing or empty";
    for (const auto& unit : prose_units(text)) {
      const std::string figure = measured_figure(unit);
      EXPECT_TRUE(figure.empty()) << page << " quotes a measured figure, " << figure << ", in:\n  \""
                                  << unit.substr(0, 200) << (unit.size() > 200 ? "...\"" : "\"")
                                  << "\n  Put it in a row of docs/RESULTS.md and link the row instead.";
    }
  }
  // The check itself: figures as the README quoted them before #58 are found.
  EXPECT_FALSE(measured_figure("A whole `ced detect` took 47 ms on our 2-vCPU machine").empty());
  EXPECT_FALSE(measured_figure("against 1,322 ms for the paper's own code: 28× faster").empty());
  EXPECT_FALSE(measured_figure("robust6d's mean lift is 11.14 and robust3d's 7.78").empty());
  EXPECT_FALSE(measured_figure("a whole ced6d run peaks at 103 bytes a point (1.0 GB)").empty());
  EXPECT_FALSE(measured_figure("binary PLY, PCD and LAS read at 1.1–3.9 GB/s").empty());
  EXPECT_FALSE(measured_figure("robust6d repeats 0.72–0.76 of its keypoints").empty());
  EXPECT_TRUE(measured_figure("within a budget of 64 MiB or 16 bytes a point, whichever is more").empty());
  EXPECT_TRUE(measured_figure("the radius is 5 × voxel, epsilon 2 × the resolution").empty());
  EXPECT_TRUE(measured_figure("47 ms ([results](docs/RESULTS.md#whole-process-now))").empty());
}

TEST(Docs, EveryResultHasItsDateMachineCommandAndCommit) {
  const auto lines = lines_of(ced_test::read_bytes((root / "docs" / "RESULTS.md").string()));
  ASSERT_FALSE(lines.empty()) << "docs/RESULTS.md is missing or empty";
  const std::regex separator(R"(^\|(\s*:?-+:?\s*\|)+\s*$)");
  const std::regex date(R"(^\d{4}-\d{2}-\d{2}$)");
  const std::regex command_link(R"(\[[^\]]+\]\([^)]+\)|`[^`]+`)");
  const std::regex commit(R"(^[0-9a-f]{7,40}$)");
  std::size_t rows = 0;
  bool fence = false;
  for (std::size_t i = 0; i + 1 < lines.size(); ++i) {
    if (is_fence(lines[i])) fence = !fence;
    if (fence || lines[i].rfind("|", 0) != 0 || !std::regex_match(lines[i + 1], separator)) continue;
    // A table: its header names the columns.
    const auto header = table_cells(lines[i]);
    std::map<std::string, std::size_t> column;
    for (std::size_t k = 0; k < header.size(); ++k) column[header[k]] = k;
    for (const char* name : {"date", "machine", "command", "commit"})
      ASSERT_TRUE(column.count(name)) << "docs/RESULTS.md line " << i + 1 << ": a table without a \"" << name
                                      << "\" column";
    for (std::size_t j = i + 2; j < lines.size() && lines[j].rfind("|", 0) == 0; ++j) {
      ++rows;
      const auto cells = table_cells(lines[j]);
      SCOPED_TRACE("docs/RESULTS.md line " + std::to_string(j + 1) + ": " + lines[j].substr(0, 120));
      ASSERT_EQ(cells.size(), header.size()) << "a row of another number of cells than its header";
      EXPECT_TRUE(std::regex_match(cells[column["date"]], date))
          << "the date \"" << cells[column["date"]] << "\" is not YYYY-MM-DD";
      EXPECT_FALSE(cells[column["machine"]].empty()) << "no machine";
      EXPECT_TRUE(std::regex_search(cells[column["command"]], command_link))
          << "the command \"" << cells[column["command"]] << "\" is neither a link nor a command";
      EXPECT_TRUE(std::regex_match(cells[column["commit"]], commit))
          << "the commit \"" << cells[column["commit"]] << "\" is not 7 to 40 hex digits";
    }
  }
  EXPECT_GT(rows, 0u) << "docs/RESULTS.md has no table of results";
}

TEST(Docs, RelativeLinksReachAFileAndAHeading) {
  // [text](path#anchor) outside code: the path exists, and the anchor is a
  // heading (or an <a id>) of the Markdown file it names.
  const std::regex link(R"(\]\(([^)\s]+)\))");
  const std::regex inline_code("`[^`]*`");
  const std::regex scheme("^[a-z]+:");
  std::map<fs::path, std::set<std::string>> anchors;
  const auto files = markdown_files();
  ASSERT_GT(files.size(), 10u);
  for (const auto& file : files) {
    const auto lines = lines_of(ced_test::read_bytes(file.string()));
    const std::string name = file.lexically_relative(root).generic_string();
    bool fence = false;
    for (std::size_t no = 0; no < lines.size(); ++no) {
      if (is_fence(lines[no])) fence = !fence;
      if (fence || is_fence(lines[no])) continue;
      const std::string line = std::regex_replace(lines[no], inline_code, "");
      for (std::sregex_iterator i(line.begin(), line.end(), link), e; i != e; ++i) {
        const std::string target = (*i)[1];
        if (std::regex_search(target, scheme)) continue;
        const auto hash = target.find('#');
        const std::string path = target.substr(0, hash);
        const fs::path dest = path.empty() ? file : (file.parent_path() / path).lexically_normal();
        if (!fs::exists(dest)) {
          ADD_FAILURE() << name << ":" << no + 1 << " links " << target << ": no such file";
          continue;
        }
        if (hash == std::string::npos || dest.extension() != ".md") continue;
        if (!anchors.count(dest)) anchors[dest] = anchors_of(dest);
        EXPECT_TRUE(anchors[dest].count(target.substr(hash + 1)))
            << name << ":" << no + 1 << " links " << target << ": " << dest.lexically_relative(root).generic_string()
            << " has no such heading";
      }
    }
  }
  EXPECT_EQ(heading_slug("robust6d keeps 1 % of its candidates (2026-12-06)"),
            "robust6d-keeps-1--of-its-candidates-2026-12-06");
  EXPECT_EQ(heading_slug("ced — N-modal keypoint detection"), "ced--n-modal-keypoint-detection");
  EXPECT_EQ(heading_slug("Campaign of 2026-12-02: `fuzz_rgbd`"), "campaign-of-2026-12-02-fuzz_rgbd");
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
