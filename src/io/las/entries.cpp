// SPDX-License-Identifier: MIT
// The entries of LAS, LAZ and COPC in the table of formats (formats.cpp):
// one reader (LAZ and COPC decoded by it) and one streaming reader for the
// three, a writer each.

#include "ced/io/io.hpp"
#include "ced/io/stream.hpp"
#include "io/base/formats.hpp"
#include "io/las/layout.hpp"

namespace ced::io::detail {

namespace {
format_entry las_family(file_format id, const char* name, std::vector<std::string> extensions) {
  format_entry e;
  e.id = id;
  e.name = name;
  e.extensions = std::move(extensions);
  e.read = [](const std::string& path, const read_options& o, read_report& r) {
    las_read_info info;
    point_cloud c = read_las(path, &info, o.fields);
    r.details = las_details(info);
    r.las = info;
    return c;
  };
  e.stream = [](const std::string& path, const read_options& o) { return open_las_stream(path, o.fields); };
  e.streams_any_file = true;
  return e;
}
}  // namespace

format_entry las_entry() {
  format_entry e = las_family(file_format::las, "las", {"las"});
  e.write = [](std::ostream& out, const point_cloud& c, const las_write_options* las) {
    if (las)
      write_las(out, c, *las);
    else
      write_las(out, c);
  };
  e.pieces = las_pieces;
  e.pieces_seek_back = true;
  return e;
}

format_entry laz_entry() {
  format_entry e = las_family(file_format::laz, "laz", {"laz"});
  e.write = [](std::ostream& out, const point_cloud& c, const las_write_options* las) { write_laz(out, c, las); };
  e.pieces = laz_pieces;
  e.pieces_seek_back = true;
  return e;
}

format_entry copc_entry() {
  format_entry e = las_family(file_format::copc, "copc", {"copc.laz"});
  e.write = [](std::ostream& out, const point_cloud& c, const las_write_options* las) { write_copc(out, c, las); };
  e.pieces = [](std::ostream&, const point_cloud& layout, std::uint64_t n) { return copc_pieces(layout, n); };
  return e;
}

}  // namespace ced::io::detail
