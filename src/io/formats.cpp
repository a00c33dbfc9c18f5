// SPDX-License-Identifier: MIT
// The built-in file formats: a row each. A new format is a file that makes
// its entry (see io/base/formats.hpp) and a row here.
#include "io/base/formats.hpp"

#include <stdexcept>

namespace ced::io::detail {

format_entry ply_entry();   // ply/stream.cpp
format_entry pcd_entry();   // pcd/stream.cpp
format_entry las_entry();   // las/entries.cpp
format_entry laz_entry();   // las/entries.cpp
format_entry copc_entry();  // las/entries.cpp
format_entry csv_entry();   // csv/stream.cpp

namespace {
std::vector<format_entry>& table() {
  static std::vector<format_entry> t{ply_entry(), pcd_entry(), las_entry(), laz_entry(), copc_entry(), csv_entry()};
  return t;
}
}  // namespace

const std::vector<format_entry>& formats() { return table(); }

const format_entry& format_entry_of(file_format f) {
  for (const format_entry& e : table())
    if (e.id == f) return e;
  throw std::invalid_argument("no format given");
}

void add_format(format_entry entry) {
  for (const format_entry& e : table())
    if (e.id == entry.id || e.name == entry.name)
      throw std::invalid_argument("add_format: '" + entry.name + "' exists");
  table().push_back(std::move(entry));
}

}  // namespace ced::io::detail
