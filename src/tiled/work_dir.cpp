// SPDX-License-Identifier: MIT
// Tiled runs: the work directory. ced claims it (a marker file), fills it
// (plan.json, cache/, parts/, and kept/ while a longer reach is tried) and
// removes only what it made.
#include "tiled/work_dir.hpp"

#include <exception>
#include <string>
#include <system_error>
#include <vector>

#include "ced/io/output_file.hpp"
#include "ced/tiled.hpp"
#include "io/base/scalar_io.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// The marker's text; "created" says whether ced made the directory (then
/// it removes the directory too, once empty).
std::string marker_text(bool created) {
  return std::string("ced tiled-run work directory: ced removes its own files here when the run succeeds\n") +
         "created " + (created ? "yes" : "no") + "\n";
}

bool has_marker(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(fs::symlink_status(dir / work_dir_marker, ec));
}

/// A name ced gives a file of its work directory: `base` (plan.json) or
/// t<digits><suffix> when `base` is empty, or the temporary of such a name
/// (io::detail::temporary_name()).
bool ced_file_name(std::string name, const std::string& base, const std::string& suffix) {
  std::string of;
  long pid = 0;
  if (io::detail::parse_temporary_name(name, of, pid)) name = of;
  if (!base.empty()) return name == base;
  if (name.size() < 1 + suffix.size() + 1 || name[0] != 't' ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  // t<id><suffix>, or a piece of a tile cache filled in shares: t<id>s<share><suffix>.
  const std::string id = name.substr(1, name.size() - 1 - suffix.size());
  const std::size_t s = id.find('s');
  const auto digits = [](const std::string& d) {
    return !d.empty() && d.find_first_not_of("0123456789") == std::string::npos;
  };
  return s == std::string::npos ? digits(id) : digits(id.substr(0, s)) && digits(id.substr(s + 1));
}

/// Removes ced's files (names ced_file_name() accepts) from `dir`, and
/// `dir` itself when it is then empty. Other files stay.
void remove_ced_files(const fs::path& dir, const std::string& base, const std::string& suffix) {
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(dir, ec))) return;
  std::vector<fs::path> ours;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code e2;
    if (fs::is_regular_file(it->symlink_status(e2)) && ced_file_name(it->path().filename().string(), base, suffix))
      ours.push_back(it->path());
  }
  for (const auto& p : ours) fs::remove(p, ec);
  fs::remove(dir, ec);  // only when empty
}

/// Refuses a directory that holds files ced did not make (naming the first).
[[noreturn]] void refuse_foreign(const std::string& work_dir) {
  std::error_code ec;
  std::string first;
  for (fs::directory_iterator it(fs::path(work_dir), ec), end; !ec && it != end && first.empty(); it.increment(ec))
    first = it->path().filename().string();
  throw work_dir_error("work directory '" + work_dir + "' holds files ced did not make (" +
                       (first.empty() ? std::string("it cannot be listed") : "'" + first + "'") +
                       "): ced works only in a new or empty directory, and never deletes what it did not "
                       "create; choose another --work-dir");
}

}  // namespace

void tiled_detail::clear_tiles(const fs::path& dir) {
  remove_ced_files(dir / "cache", "", ".bin");
  remove_ced_files(dir / "parts", "", ".part");
}

void tiled_detail::keep_parts(const fs::path& dir) {
  clear_kept(dir);
  remove_ced_files(dir / "cache", "", ".bin");
  std::error_code ec;
  fs::rename(dir / "parts", dir / "kept", ec);
  if (ec) remove_ced_files(dir / "parts", "", ".part");  // not kept: the next try detects every tile
}

void tiled_detail::clear_kept(const fs::path& dir) { remove_ced_files(dir / "kept", "", ".part"); }

void tiled_detail::claim_work_dir(const std::string& work_dir) {
  const fs::path dir(work_dir);
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  bool created = false;
  if (!fs::exists(st)) {
    // Only the last component is created: a mistyped parent is an error.
    if (dir.has_parent_path() && !fs::is_directory(dir.parent_path(), ec))
      throw work_dir_error("work directory '" + work_dir + "': its parent directory does not exist");
    if (!fs::create_directory(dir, ec) || ec)
      throw io::io_error(
          work_dir, "cannot create the work directory: " + (ec ? ec.message() : std::string("it appeared meanwhile")));
    created = true;
  } else if (!fs::is_directory(st)) {
    throw work_dir_error("work directory '" + work_dir + "' exists and is not a directory");
  } else if (has_marker(dir)) {
    return;
  } else if (!fs::is_empty(dir, ec) || ec) {
    refuse_foreign(work_dir);
  }
  io::write_text_file_atomic((dir / work_dir_marker).string(), marker_text(created));
}

void remove_work_dir(const std::string& work_dir) noexcept {
  try {
    const fs::path dir(work_dir);
    if (work_dir.empty() || !has_marker(dir)) return;
    std::error_code ec;
    std::string marker;
    try {
      marker = io::detail::read_whole_file((dir / work_dir_marker).string());
    } catch (const std::exception&) {
    }
    const bool created = marker.find("\ncreated yes\n") != std::string::npos;
    clear_tiles(dir);
    clear_kept(dir);
    remove_ced_files(dir, "plan.json", "");
    fs::remove(dir / work_dir_marker, ec);
    if (created) fs::remove(dir, ec);  // only when empty: a file someone put there keeps it
  } catch (...) {
  }
}

}  // namespace ced
