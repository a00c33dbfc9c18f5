// SPDX-License-Identifier: MIT
// Helpers of the tests split from test_laz.cpp.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "ced/io/las.hpp"
#include "ced/io/stream.hpp"
#include "ced/tiled.hpp"
#include "core/parallel.hpp"
#include "file_support.hpp"
#include "io/base/scalar_io.hpp"
#include "io/laz/types.hpp"

using ced::io::io_error;
using ced::io::detail::las_point_records;
using ced::io::detail::load_le;
using ced_test::read_bytes;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace laz_test {

inline std::string data_path(const std::string& name) { return std::string(CED_TEST_DATA_DIR) + "/" + name; }

struct twin {
  const char* laz;
  const char* las;
  const char* details;  ///< read_report::details of the LAZ
};
/// LAZ files and their plain twins: point format 3 in one chunk and in three
/// (point10, gpstime11, rgb12 v2), with 27 extra bytes (byte v2), and LAS
/// 1.4 point format 6 with extended VLRs (layered: point14 v3).
constexpr twin k_twins[] = {{"simple.laz", "simple.las", "LAZ 1.2, point format 3"},
                            {"simple-laszip-1.2r0.laz", "simple.las", "LAZ 1.2, point format 3"},
                            {"autzen_trim.laz", "autzen_trim.las", "LAZ 1.2, point format 3"},
                            {"extra.laz", "extrabytes.las", "LAZ 1.4, point format 3"},
                            {"1_4_w_evlr.laz", "1_4_w_evlr.las", "LAZ 1.4, point format 6"}};
/// Every LAZ file of tests/data (with COPC's layered point format 7 and a
/// point format 8 file with NIR and extra bytes, which have no twin).
constexpr const char* k_laz_files[] = {"simple.laz",     "simple-laszip-1.2r0.laz", "autzen_trim.laz", "extra.laz",
                                       "1_4_w_evlr.laz", "1.2-with-color.copc.laz", "append-bug.laz"};

/// The io_error reading `bytes` (as a file `name`) throws; it must name the file.
inline std::string laz_error(const std::string& bytes, const std::string& name = "bad.laz") {
  return ced_test::read_error_of([](const std::string& p) { ced::io::read_cloud(p); }, bytes, name);
}

/// Byte offsets in a LAZ file: its point data, its LASzip VLR's payload.
struct laz_offsets {
  std::size_t points = 0, vlr = 0, vlr_len = 0;
};

inline laz_offsets offsets_of(const std::string& bytes) {
  const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
  laz_offsets o;
  o.points = load_le<std::uint32_t>(d + 96);
  std::size_t pos = load_le<std::uint16_t>(d + 94);
  for (std::uint32_t i = 0, n = load_le<std::uint32_t>(d + 100); i < n; ++i) {
    const std::size_t len = load_le<std::uint16_t>(d + pos + 20);
    if (load_le<std::uint16_t>(d + pos + 18) == 22204) {
      o.vlr = pos + 54;
      o.vlr_len = len;
    }
    pos += 54 + len;
  }
  return o;
}

template <class T>
void put(std::string& s, std::size_t at, T v) {
  std::memcpy(&s[at], &v, sizeof v);
}

/// The autzen sample with a float saliency field added (as keypoint clouds have).
inline ced::point_cloud autzen_with_saliency() {
  ced::point_cloud c = ced::io::read_cloud(data_path("autzen_trim.laz"));
  std::vector<double> saliency(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) saliency[i] = 0.001 * double(i % 977);
  c.add_field("saliency_xyz", ced::scalar_type::float32, saliency);
  return c;
}

/// `c` written to `path` by a cloud_writer in pieces of 7,919 points (as a
/// tiled run's merge writes).
inline void write_in_pieces(const std::string& path, const ced::point_cloud& c, ced::io::file_format format) {
  std::ofstream f(path, std::ios::binary);
  ced::io::cloud_writer w(f, c, c.size(), format);
  for (std::size_t at = 0; at < c.size(); at += 7919) {
    std::vector<std::uint8_t> keep(c.size(), 0);
    for (std::size_t i = at; i < std::min(c.size(), at + 7919); ++i) keep[i] = 1;
    ced::point_cloud piece = c;
    piece.filter(keep);
    w.write(piece);
  }
  w.finish();
}

}  // namespace laz_test
