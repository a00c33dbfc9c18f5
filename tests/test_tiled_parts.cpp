// SPDX-License-Identifier: MIT
// Tiled runs, a tile's part as a file (src/tiled/part_file.cpp, records.cpp):
// it reads back as written, its bytes are the documented little-endian
// layout, and a part of another format version is refused by name.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {

using ced_test::detect_planned_tile;
using ced_test::expect_same_part;
using ced_test::room_request;

/// The little-endian unsigned value of n bytes at `at` of `b`.
std::uint64_t le(const std::string& b, std::size_t at, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t k = 0; k < n; ++k) v |= std::uint64_t(static_cast<unsigned char>(b[at + k])) << (8 * k);
  return v;
}

/// The bits of a value of w bytes at p (host order), as an unsigned number.
std::uint64_t bits_of(const void* p, std::size_t w) {
  std::uint8_t b1;
  std::uint16_t b2;
  std::uint32_t b4;
  std::uint64_t b8;
  switch (w) {
    case 1:
      return std::memcpy(&b1, p, 1), b1;
    case 2:
      return std::memcpy(&b2, p, 2), b2;
    case 4:
      return std::memcpy(&b4, p, 4), b4;
    default:
      return std::memcpy(&b8, p, 8), b8;
  }
}

/// A plan and the part of its tile with the most keypoints, written to `name`.
struct written_part {
  ced::tile_plan plan;
  ced::tile_part part;
  std::string path;
};
written_part write_a_part(const std::string& name, std::uint32_t seed) {
  written_part w;
  w.plan = ced::plan_tiles(room_request(3000, seed, name + ".las", 0.15));
  for (const auto& t : w.plan.tiles) {
    ced::tile_part p = detect_planned_tile(w.plan, t.id);
    if (p.index.size() > w.part.index.size()) w.part = std::move(p);
  }
  w.path = ced_test::temp_file(name + ".part");
  ced::write_part(w.path, w.plan, w.part);
  return w;
}

/// The io_error message of read_part(path), or "<no io_error thrown>".
std::string read_error(const std::string& path, const ced::tile_plan& plan) {
  try {
    ced::read_part(path, plan);
  } catch (const ced::io::io_error& e) {
    return e.what();
  }
  return "<no io_error thrown>";
}

}  // namespace

TEST(TiledParts, AWrittenPartReadsBackAsDetected) {
  const written_part w = write_a_part("parts_roundtrip", 31);
  ASSERT_GT(w.part.index.size(), 1u);
  const ced::tile_part back = ced::read_part(w.path, w.plan);
  EXPECT_EQ(back.tile, w.part.tile);
  EXPECT_EQ(back.plan, w.plan.digest());
  EXPECT_EQ(back.detect_ms, w.part.detect_ms);
  expect_same_part(back, w.part, "read back");
}

TEST(TiledParts, APartFileIsTheDocumentedLittleEndianLayout) {
  const written_part w = write_a_part("parts_layout", 32);
  ASSERT_GT(w.part.index.size(), 1u);
  const std::string b = ced_test::read_bytes(w.path);
  const std::size_t m = w.part.saliency.size();
  ASSERT_EQ(m, 2u);
  EXPECT_EQ(b.substr(0, 8), std::string("CEDPART\0", 8));
  EXPECT_EQ(le(b, 8, 4), 4u);  // the format version
  EXPECT_EQ(b.substr(12, 16), w.plan.digest());
  EXPECT_EQ(le(b, 28, 8), w.part.tile);
  EXPECT_EQ(le(b, 36, 8), w.part.index.size());
  EXPECT_EQ(le(b, 44, 4), m);
  EXPECT_EQ(le(b, 48, 4), w.plan.fields.size());
  for (std::size_t k = 0; k < m; ++k) EXPECT_EQ(le(b, 52 + 8 * k, 8), w.part.candidates[k]);
  EXPECT_EQ(le(b, 52 + 8 * m, 8), w.part.any_candidates);
  EXPECT_EQ(le(b, 60 + 8 * m, 8), bits_of(&w.part.detect_ms, 8));
  // The records: index, file index, x y z, the fields, the saliencies, then the rank.
  std::size_t fields = 0;
  for (const auto& f : w.plan.fields) fields += ced::size_of(f.type);
  const std::size_t head = 68 + 8 * m, record = 28 + fields + 4 * m + 4;
  ASSERT_EQ(b.size(), head + w.part.index.size() * record);
  for (std::size_t j = 0; j < w.part.index.size(); ++j) {
    const std::size_t at = head + j * record;
    EXPECT_EQ(le(b, at, 8), w.part.index[j]);
    EXPECT_EQ(le(b, at + 8, 8), w.part.file_index[j]);
    for (std::size_t k = 0; k < 3; ++k)
      EXPECT_EQ(le(b, at + 16 + 4 * k, 4), bits_of(w.part.keypoints.position(j) + k, 4));
    std::size_t f_at = at + 28;
    for (const auto& f : w.part.keypoints.fields()) {
      const std::size_t width = ced::size_of(f.type());
      EXPECT_EQ(le(b, f_at, width), bits_of(f.values.bytes() + width * j, width)) << f.name;
      f_at += width;
    }
    for (std::size_t k = 0; k < m; ++k) EXPECT_EQ(le(b, f_at + 4 * k, 4), bits_of(&w.part.saliency[k][j], 4));
    EXPECT_EQ(le(b, f_at + 4 * m, 4), bits_of(&w.part.rank[j], 4));
  }
}

TEST(TiledParts, APartOfAnotherFormatVersionIsRefused) {
  const written_part w = write_a_part("parts_version", 33);
  const std::string b = ced_test::read_bytes(w.path);
  ASSERT_NO_THROW(ced::read_part(w.path, w.plan));
  // The version bumped (and its last byte corrupted): named with this ced's.
  using bump = std::pair<std::string, std::string>;  // the 4 bytes, the version they say
  for (const auto& [bytes, version] : {bump{std::string("\x05\0\0\0", 4), "5"}, bump{std::string("\x03\0\0\0", 4), "3"},
                                       bump{std::string("\x04\0\0\x01", 4), "16777220"}}) {
    std::string bumped = b;
    bumped.replace(8, 4, bytes);
    const std::string path = ced_test::temp_file("parts_version_" + version + ".part");
    ced_test::write_bytes(path, bumped);
    const std::string what = read_error(path, w.plan);
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find("tile part format version " + version + ", this ced reads version 4"), std::string::npos)
        << what;
    try {
      ced::merge_part_files(w.plan, {path}, {});
      ADD_FAILURE() << "a part of format version " << version << " was merged";
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("format version " + version), std::string::npos) << e.what();
    }
  }
  // A part of the first format: "CEDPART1", no version field.
  std::string v1 = b;
  v1.replace(0, 12, "CEDPART1");
  const std::string path = ced_test::temp_file("parts_version_1.part");
  ced_test::write_bytes(path, v1);
  const std::string what = read_error(path, w.plan);
  EXPECT_NE(what.find(path + ": tile part format version 1, this ced reads version 4"), std::string::npos) << what;
  // Not a part at all.
  std::string other = b;
  other[3] = 'X';
  ced_test::write_bytes(path, other);
  EXPECT_NE(read_error(path, w.plan).find("not a ced tile part"), std::string::npos) << read_error(path, w.plan);
}
