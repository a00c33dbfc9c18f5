// SPDX-License-Identifier: MIT
// LAZ (src/io/laz.*): every record of the public LAZ test files decodes to
// the bytes of its plain-LAS twin, the clouds and keypoints are the twin's,
// and damaged files are refused with an io_error naming the file, never read
// out of bounds.
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
#include "io/laz/types.hpp"
#include "io/base/scalar_io.hpp"

using ced::io::io_error;
using ced::io::detail::las_point_records;
using ced::io::detail::load_le;
using ced_test::read_bytes;
using ced_test::temp_file;
using ced_test::write_bytes;

namespace {

std::string data_path(const std::string& name) { return std::string(CED_TEST_DATA_DIR) + "/" + name; }

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
std::string laz_error(const std::string& bytes, const std::string& name = "bad.laz") {
  return ced_test::read_error_of([](const std::string& p) { ced::io::read_cloud(p); }, bytes, name);
}

/// Byte offsets in a LAZ file: its point data, its LASzip VLR's payload.
struct laz_offsets {
  std::size_t points = 0, vlr = 0, vlr_len = 0;
};

laz_offsets offsets_of(const std::string& bytes) {
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
ced::point_cloud autzen_with_saliency() {
  ced::point_cloud c = ced::io::read_cloud(data_path("autzen_trim.laz"));
  std::vector<double> saliency(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) saliency[i] = 0.001 * double(i % 977);
  c.add_field("saliency_xyz", ced::scalar_type::float32, saliency);
  return c;
}

/// `c` written to `path` by a cloud_writer in pieces of 7,919 points (as a
/// tiled run's merge writes).
void write_in_pieces(const std::string& path, const ced::point_cloud& c, ced::io::file_format format) {
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

}  // namespace

TEST(Laz, EveryRecordIsItsLasTwinsRecord) {
  for (const twin& t : k_twins) {
    SCOPED_TRACE(t.laz);
    const std::string laz = las_point_records(read_bytes(data_path(t.laz)), t.laz);
    const std::string las = las_point_records(read_bytes(data_path(t.las)), t.las);
    ASSERT_GT(las.size(), 0u);
    ASSERT_EQ(laz.size(), las.size());
    // The raw bytes: integers, flags, times and colours, not only the scaled coordinates.
    const auto diff = std::mismatch(laz.begin(), laz.end(), las.begin());
    EXPECT_TRUE(diff.first == laz.end()) << "first differing byte " << (diff.first - laz.begin());
  }
}

TEST(Laz, HeaderCountsBoundsAndReturnsAreThoseOfTheDecodedPoints) {
  for (const char* name : k_laz_files) {
    SCOPED_TRACE(name);
    const std::string file = read_bytes(data_path(name));
    const auto* h = reinterpret_cast<const unsigned char*>(file.data());
    const std::string records = las_point_records(file, name);
    const std::size_t stride = load_le<std::uint16_t>(h + 105);
    const std::size_t n = records.size() / stride;
    const bool v14 = h[25] >= 4, extended = (h[104] & 0x3F) >= 6;
    EXPECT_EQ(n, v14 ? load_le<std::uint64_t>(h + 247) : load_le<std::uint32_t>(h + 107));
    std::int32_t lo[3], hi[3];
    std::uint64_t by_return[15] = {};
    for (std::size_t i = 0; i < n; ++i) {
      const auto* r = reinterpret_cast<const unsigned char*>(records.data()) + i * stride;
      for (int k = 0; k < 3; ++k) {
        const auto v = load_le<std::int32_t>(r + 4 * k);
        lo[k] = i ? std::min(lo[k], v) : v;
        hi[k] = i ? std::max(hi[k], v) : v;
      }
      const unsigned ret = extended ? r[14] & 15u : r[14] & 7u;
      if (ret >= 1) ++by_return[ret - 1];
    }
    for (int k = 0; k < (v14 ? 15 : 5); ++k)
      EXPECT_EQ(by_return[k], v14 ? load_le<std::uint64_t>(h + 255 + 8 * k) : load_le<std::uint32_t>(h + 111 + 4 * k))
          << "return " << k + 1;
    for (int k = 0; k < 3; ++k) {
      const double scale = load_le<double>(h + 131 + 8 * k), offset = load_le<double>(h + 155 + 8 * k);
      // Header bounds are max x, min x, max y, ... (to the rounding of raw * scale + offset).
      EXPECT_NEAR(load_le<double>(h + 179 + 16 * k), hi[k] * scale + offset, scale * 1e-3) << "axis " << k;
      EXPECT_NEAR(load_le<double>(h + 187 + 16 * k), lo[k] * scale + offset, scale * 1e-3) << "axis " << k;
    }
  }
}

TEST(Laz, ReadsAsItsLasTwinOnAnyThreadCount) {
  for (const twin& t : k_twins) {
    SCOPED_TRACE(t.laz);
    ced::io::read_report rz, rs;
    const ced::point_cloud laz = ced::io::read_cloud(data_path(t.laz), {}, &rz);
    const ced::point_cloud las = ced::io::read_cloud(data_path(t.las), {}, &rs);
    ced_test::expect_same_cloud(laz, las);
    EXPECT_EQ(rz.details, t.details);
    EXPECT_EQ("LAZ" + rs.details.substr(3), t.details);
    ced::point_cloud one;
    ced::detail::with_thread_limit(1, [&] { one = ced::io::read_cloud(data_path(t.laz)); });
    ced_test::expect_same_cloud(one, las);
    // Only the selected fields, as for LAS.
    ced::io::read_options only;
    only.fields = ced::field_selection::only({"gps_time", "intensity"});
    ced_test::expect_same_cloud(ced::io::read_cloud(data_path(t.laz), only),
                                ced::io::read_cloud(data_path(t.las), only));
  }
}

TEST(Laz, CopcHoldsThePointsOfItsLasTwin) {
  // COPC stores the twin's points (LAS 1.2 format 3) in octree order, as LAS
  // 1.4 format 7 in variable chunks: the same points, field for field, as sets.
  const ced::point_cloud copc = ced::io::read_cloud(data_path("1.2-with-color.copc.laz"));
  const ced::point_cloud las = ced::io::read_cloud(data_path("1.2-with-color.las"));
  ASSERT_EQ(copc.size(), las.size());
  const char* fields[] = {"intensity",
                          "return_number",
                          "number_of_returns",
                          "classification",
                          "user_data",
                          "point_source_id",
                          "gps_time",
                          "red",
                          "green",
                          "blue"};
  const auto rows = [&](const ced::point_cloud& c) {
    std::vector<std::vector<double>> r(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      for (int k = 0; k < 3; ++k) r[i].push_back(std::round((c.origin()[k] + double(c.position(i)[k])) * 100));
      for (const char* f : fields) {
        const auto* column = c.find_field(f);
        EXPECT_NE(column, nullptr) << f;
        r[i].push_back(column ? column->values[i] : 0);
      }
    }
    std::sort(r.begin(), r.end());
    return r;
  };
  EXPECT_TRUE(rows(copc) == rows(las));
}

TEST(Laz, AutzenGivesTheKeypointsOfItsLasTwin) {
  const ced::point_cloud laz = ced::io::read_cloud(data_path("autzen_trim.laz"));
  const ced::point_cloud las = ced::io::read_cloud(data_path("autzen_trim.las"));
  ced::detect_params p;
  p.radius = p.nms_radius = 6.0;  // feet: about five times the median spacing
  const auto want = ced::detect(las, p, ced::preset("ced6d"));
  EXPECT_GT(want.keypoints.size(), 100u);
  const auto got = ced::detect(laz, p, ced::preset("ced6d"));
  EXPECT_EQ(got.keypoints, want.keypoints);
  EXPECT_EQ(got.saliency, want.saliency);  // bitwise
}

TEST(Laz, StreamsChunkByChunkAsItReadsWhole) {
  // Reads of a few points at a time cross the 50,000-point chunks of autzen.
  for (const twin& t : k_twins) {
    SCOPED_TRACE(t.laz);
    const std::string path = data_path(t.laz);
    const ced::point_cloud whole = ced::io::read_cloud(path);
    const auto s = ced::io::open_point_stream(path);
    EXPECT_TRUE(s->streaming());
    EXPECT_EQ(s->declared_points(), whole.size());
    ced::point_cloud chunk;
    while (s->read(4999, {0, 0, 0}, chunk) > 0) {
    }
    EXPECT_EQ(s->origin(), whole.origin());
    s->rewind();
    std::vector<float> xyz;
    std::vector<double> gps;
    while (s->read(4999, s->origin(), chunk) > 0) {
      xyz.insert(xyz.end(), chunk.positions().begin(), chunk.positions().end());
      const auto* f = chunk.find_field("gps_time");
      ASSERT_NE(f, nullptr);
      for (std::size_t i = 0; i < chunk.size(); ++i) gps.push_back(f->values[i]);
    }
    ASSERT_EQ(xyz.size(), whole.positions().size());
    EXPECT_TRUE(std::equal(xyz.begin(), xyz.end(), whole.positions().begin()));
    const auto* g = whole.find_field("gps_time");
    ASSERT_NE(g, nullptr);
    for (std::size_t i = 0; i < whole.size(); ++i) ASSERT_EQ(gps[i], g->values[i]) << i;
  }
}

TEST(Laz, WrittenLazReadsAsTheCloudWrittenAsLas12) {
  // write_cloud(.laz): LAS 1.2 (point formats 0-3; other fields as extra
  // bytes), compressed. Whole and in pieces (cloud_writer, as a tiled run's
  // merge writes), the same bytes.
  const ced::point_cloud c = autzen_with_saliency();
  const std::string laz = temp_file("out.laz"), las = temp_file("out.las");
  EXPECT_EQ(ced::io::format_of(laz), ced::io::file_format::laz);
  ced::io::write_cloud(laz, c);
  ced::io::las_write_options o;
  o.version_minor = 2;
  ced::io::write_las(las, c, o);
  ced::io::read_report r;
  ced_test::expect_same_cloud(ced::io::read_cloud(laz, {}, &r), ced::io::read_cloud(las));
  EXPECT_EQ(r.details, "LAZ 1.2, point format 3");
  EXPECT_LT(std::filesystem::file_size(laz), std::filesystem::file_size(las) / 3);
  const std::string pieces = temp_file("pieces.laz");
  write_in_pieces(pieces, c, ced::io::file_format::laz);  // pieces across the 50,000-point chunks
  EXPECT_TRUE(read_bytes(pieces) == read_bytes(laz));
}

TEST(LazMalformed, TruncatedAnywhere) {
  const std::string file = read_bytes(data_path("autzen_trim.laz"));
  const laz_offsets o = offsets_of(file);
  // In the header, the VLRs, the chunk table offset, the chunks, the table.
  for (std::size_t keep : {std::size_t(100), o.vlr + 10, o.points + 4, o.points + 100, std::size_t(300000),
                           file.size() - 30, file.size() - 1}) {
    SCOPED_TRACE(keep);
    const std::string msg = laz_error(file.substr(0, keep));
    EXPECT_NE(msg, "<no io_error thrown>");
  }
}

TEST(LazMalformed, Version1TruncatedOrCorrupt) {
  // LASzip 1.x: one stream of version 1 items, no chunk table, to the end of the file.
  const std::string file = read_bytes(data_path("simple-laszip-1.2r0.laz"));
  const laz_offsets o = offsets_of(file);
  EXPECT_CONTAINS(laz_error(file.substr(0, o.points + 10)), "too short for its first point record");
  for (std::size_t keep : {o.points + 100, file.size() / 2, file.size() - 40}) {
    SCOPED_TRACE(keep);
    EXPECT_CONTAINS(laz_error(file.substr(0, keep)), "ends early");
  }
  // Flipped bytes in the stream: an error, or other points, never a crash.
  const std::string good = las_point_records(file, "v1.laz");
  for (std::size_t at = o.points + 40; at < file.size(); at += 997) {
    std::string b = file;
    b[at] = static_cast<char>(b[at] ^ 0x5A);
    const std::string msg = laz_error(b);
    if (msg == "<no io_error thrown>") {
      EXPECT_NE(las_point_records(b, "v1.laz"), good) << at;
    }
  }
}

TEST(LazMalformed, ChunkTable) {
  const std::string file = read_bytes(data_path("autzen_trim.laz"));
  const laz_offsets o = offsets_of(file);
  const auto table = load_le<std::int64_t>(reinterpret_cast<const unsigned char*>(file.data()) + o.points);
  {
    std::string b = file;  // points at the first chunk: never written
    put<std::int64_t>(b, o.points, std::int64_t(o.points + 8));
    EXPECT_CONTAINS(laz_error(b), "chunk table is missing");
  }
  {
    std::string b = file;
    put<std::int64_t>(b, o.points, std::int64_t(file.size() + 100));
    EXPECT_CONTAINS(laz_error(b), "outside the file");
  }
  {
    std::string b = file;
    put<std::uint32_t>(b, std::size_t(table), 1u);
    EXPECT_CONTAINS(laz_error(b), "unknown version 1");
  }
  {
    std::string b = file;
    put<std::uint32_t>(b, std::size_t(table) + 4, 4u);  // 4 chunks: the last runs past the table
    EXPECT_CONTAINS(laz_error(b), "LAZ chunk table");
  }
  {
    std::string b = file;
    put<std::uint32_t>(b, std::size_t(table) + 4, 2u);  // 2 chunks hold 100,000 points, not 110,000
    EXPECT_CONTAINS(laz_error(b), "hold 100000 points, the header declares 110000");
  }
  {
    std::string b = file;
    put<std::uint32_t>(b, 107, 160000u);  // more points declared than 3 chunks of 50,000 hold
    EXPECT_CONTAINS(laz_error(b), "hold 150000 points, the header declares 160000");
  }
  {
    std::string b = file;  // the last chunk would hold 20,000 points: its data ends first
    put<std::uint32_t>(b, 107, 120000u);
    EXPECT_CONTAINS(laz_error(b), "LAZ chunk 2 (points 100000 to 119999");
    EXPECT_CONTAINS(laz_error(b), "ends early");
  }
  {
    std::string b = file;  // ... or 5,000: its data goes on after them
    put<std::uint32_t>(b, 107, 105000u);
    EXPECT_CONTAINS(laz_error(b), "bytes after its last point");
  }
}

TEST(LazMalformed, LaszipVlr) {
  const std::string file = read_bytes(data_path("simple.laz"));
  const laz_offsets o = offsets_of(file);
  const auto with = [&](std::size_t at, std::uint16_t v) {
    std::string b = file;
    put<std::uint16_t>(b, at, v);
    return laz_error(b);
  };
  EXPECT_CONTAINS(with(o.vlr, 7), "unknown compressor 7");
  EXPECT_CONTAINS(with(o.vlr, 3), "compressor 3 with point format 3");
  EXPECT_CONTAINS(with(o.vlr + 2, 1), "unknown coder 1");
  EXPECT_CONTAINS(with(o.vlr + 34 + 4, 1), "of versions 1 and 2 mixed");
  EXPECT_CONTAINS(with(o.vlr + 34 + 4, 5),
                  "point10 v5 (20 bytes): not supported (pointwise items are versions 1 and 2");
  EXPECT_CONTAINS(with(o.vlr + 34 + 6, 9), "do not match point format 3");  // gpstime11 -> wavepacket13
  // An item whose size lies is named with its size (it was "do not match point format 3").
  EXPECT_CONTAINS(with(o.vlr + 34 + 12 + 2, 7), "item 3, rgb12, says it has 7 bytes; that item has 6");
  EXPECT_CONTAINS(with(o.vlr + 34 + 12 + 2, 8), "item 3, rgb12, says it has 8 bytes; that item has 6");
  EXPECT_CONTAINS(with(o.vlr + 34 + 2, 0), "item 1, point10, says it has 0 bytes; that item has 20");
  EXPECT_CONTAINS(with(o.vlr + 32, 40), "items do not fit");
  {
    std::string b = file;  // the point format byte says LAZ, but no VLR says how
    b[o.vlr - 54 + 2] = 'X';
    EXPECT_CONTAINS(laz_error(b), "no LASzip VLR");
  }
  {
    std::string b = file;  // point format 1 (no colour) with point format 3's items
    b[104] = static_cast<char>(0x81);
    put<std::uint16_t>(b, 105, 28);
    EXPECT_CONTAINS(laz_error(b), "unexpected rgb12 v2 (6 bytes) after the items of point format 1");
  }
  {
    std::string b = file;
    b[104] = static_cast<char>(0xC3);
    EXPECT_CONTAINS(laz_error(b), "unknown compression");
  }
}

TEST(LazMalformed, DamagedChunksAreRefusedNeverMisread) {
  // Bytes of the coded data changed at random: each read either throws an
  // io_error naming the chunk, or (rarely) decodes some other points; it never
  // reads out of bounds (the sanitizer builds run this) or hangs.
  const std::string file = read_bytes(data_path("simple.laz"));
  const laz_offsets o = offsets_of(file);
  const std::size_t first = o.points + 8 + 34;  // the chunk's coded bytes, after its first record
  const auto table =
      static_cast<std::size_t>(load_le<std::int64_t>(reinterpret_cast<const unsigned char*>(file.data()) + o.points));
  std::mt19937 rng(7);
  int refused = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::string b = file;
    const int flips = 1 + trial % 4;
    for (int f = 0; f < flips; ++f) b[first + rng() % (table - first)] = static_cast<char>(rng() & 0xFF);
    const std::string msg = ced_test::io_error_of([&] { las_point_records(b, "damaged.laz"); });
    if (msg != "<no io_error thrown>") {
      EXPECT_CONTAINS(msg, "LAZ chunk 0");
      ++refused;
    }
  }
  EXPECT_GT(refused, 150);  // the decoder must end exactly at the chunk's end
}

namespace {

/// A LAS 1.2 file (no VLRs) of point format `format` holding `records`
/// (`stride` bytes each) as they are.
std::string las_with_records(int format, std::size_t stride, const std::string& records) {
  std::string h(227, '\0');
  std::memcpy(&h[0], "LASF", 4);
  h[24] = 1;
  h[25] = 2;
  put<std::uint16_t>(h, 94, 227);
  put<std::uint32_t>(h, 96, 227);
  h[104] = static_cast<char>(format);
  put<std::uint16_t>(h, 105, static_cast<std::uint16_t>(stride));
  put<std::uint32_t>(h, 107, static_cast<std::uint32_t>(records.size() / stride));
  for (int k = 0; k < 3; ++k) put<double>(h, 131 + 8 * k, 0.01);
  return h + records;
}

/// n records of point format `format` with `extra` extra bytes: coherent
/// like a scan (`random` false: small steps, returns of pulses, GPS times
/// in two interleaved flight lines with jumps and repeats, grey and coloured
/// points) or every byte random.
std::string make_records(int format, std::size_t extra, std::size_t n, bool random, unsigned seed) {
  static constexpr std::size_t k_size[4] = {20, 28, 26, 34};
  const std::size_t stride = k_size[format] + extra;
  std::mt19937 rng(seed);
  std::string r(n * stride, '\0');
  if (random) {
    for (char& c : r) c = static_cast<char>(rng());
    return r;
  }
  std::int32_t xyz[3] = {1000, -2000, 300};
  double line_time[2] = {1e5, 3.7e8};
  std::uint16_t rgb[3] = {100, 200, 300};
  for (std::size_t i = 0; i < n; ++i) {
    unsigned char* p = reinterpret_cast<unsigned char*>(&r[i * stride]);
    for (int k = 0; k < 3; ++k) xyz[k] += static_cast<std::int32_t>(rng() % 41) - 20 + (rng() % 97 == 0 ? 100000 : 0);
    std::memcpy(p, xyz, 12);
    const std::uint16_t intensity = static_cast<std::uint16_t>(rng() % 3 == 0 ? rng() : 500 + rng() % 8);
    std::memcpy(p + 12, &intensity, 2);
    const unsigned returns = 1 + rng() % 3, number = 1 + (rng() % 5 == 0 ? rng() % 7 : returns - 1);
    p[14] = static_cast<unsigned char>(number | returns << 3 | (rng() % 9 == 0 ? 0x40 : 0) | (i % 50 == 0 ? 0x80 : 0));
    p[15] = static_cast<unsigned char>(rng() % 6 == 0 ? rng() % 32 : 2);
    p[16] = static_cast<unsigned char>(static_cast<int>(i % 60) - 30);
    p[17] = static_cast<unsigned char>(i / 100);
    const std::uint16_t source = static_cast<std::uint16_t>(i / 400);
    std::memcpy(p + 18, &source, 2);
    std::size_t at = 20;
    if (format == 1 || format == 3) {
      const int line = (i / 3) % 2;  // two flight lines interleaved
      const unsigned step = rng() % 10;
      line_time[line] += step == 0 ? 0.0 : step < 7 ? 1e-5 : step < 9 ? 3e-5 * (rng() % 20) : 1e4;
      double t = line_time[line];
      if (rng() % 211 == 0) t = -t;  // a sign flip: a huge integer difference
      std::memcpy(p + at, &t, 8);
      at += 8;
    }
    if (format >= 2) {
      if (rng() % 4 == 0)
        for (auto& c : rgb) c = static_cast<std::uint16_t>(rng());
      else if (rng() % 3 == 0)
        rgb[1] = rgb[2] = rgb[0];  // grey
      std::memcpy(p + at, rgb, 6);
      at += 6;
    }
    for (std::size_t e = 0; e < extra; ++e) p[at + e] = static_cast<unsigned char>(e == 0 ? i % 7 : rng());
  }
  return r;
}

}  // namespace

TEST(LazWriter, CompressesLAStoolsAutzenToTheSameBytes) {
  // LASzip's own compression of the LAS twin, point data and chunk table
  // byte for byte (the VLR's description and version differ).
  const std::string want = read_bytes(data_path("autzen_trim.laz"));
  const std::string got = ced::io::detail::laz_from_las(read_bytes(data_path("autzen_trim.las")), "autzen_trim.las");
  ASSERT_EQ(got.size(), want.size());
  const std::size_t points = offsets_of(want).points;
  ASSERT_EQ(offsets_of(got).points, points);
  EXPECT_TRUE(got.compare(points, std::string::npos, want, points, std::string::npos) == 0);
}

TEST(LazWriter, EveryFormatExtraBytesAndChunkingRoundTrips) {
  static constexpr std::size_t k_size[4] = {20, 28, 26, 34};
  for (int format = 0; format <= 3; ++format)
    for (std::size_t extra : {std::size_t(0), std::size_t(3)})
      for (bool random : {false, true}) {
        SCOPED_TRACE("format " + std::to_string(format) + ", extra " + std::to_string(extra) +
                     (random ? ", random bytes" : ", scan-like"));
        const std::size_t n = 3001;
        const std::string records = make_records(format, extra, n, random, unsigned(format * 10 + extra));
        const std::string las = las_with_records(format, k_size[format] + extra, records);
        for (std::uint32_t chunk : {1u, 7u, 1000u, 50000u}) {
          const std::string laz = ced::io::detail::laz_from_las(las, "t.las", chunk);
          EXPECT_TRUE(las_point_records(laz, "t.laz") == records) << "chunks of " << chunk;
        }
        const std::vector<std::uint32_t> variable = {1, 2, 998, 1000, 1000};
        const std::string laz = ced::io::detail::laz_from_las(las, "t.las", 0, variable);
        EXPECT_TRUE(las_point_records(laz, "t.laz") == records) << "variable chunks";
        if (!random) {
          EXPECT_LT(laz.size(), las.size() * 2 / 3);  // it compresses
          // And the reader reads it as the LAS, field for field.
          write_bytes(temp_file("rt.las"), las);
          write_bytes(temp_file("rt.laz"), laz);
          ced_test::expect_same_cloud(ced::io::read_cloud(temp_file("rt.laz")),
                                      ced::io::read_cloud(temp_file("rt.las")));
        }
      }
}

TEST(LazWriter, EmptyAndSinglePointFiles) {
  for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(2)}) {
    const std::string records = make_records(3, 0, n, false, 5);
    const std::string laz = ced::io::detail::laz_from_las(las_with_records(3, 34, records), "t.las");
    EXPECT_TRUE(las_point_records(laz, "t.laz") == records) << n << " points";
  }
}

TEST(LazMalformed, LayeredChunks) {
  // 1_4_w_evlr.laz: one layered chunk of 1,000 points after the first 30-byte
  // record: the point count, 9 layer sizes, the layers.
  const std::string file = read_bytes(data_path("1_4_w_evlr.laz"));
  const laz_offsets o = offsets_of(file);
  const std::size_t count_at = o.points + 8 + 30, sizes_at = count_at + 4;
  {
    std::string b = file;
    put<std::uint32_t>(b, count_at, 999u);
    EXPECT_CONTAINS(laz_error(b), "its point count differs from the chunk table's");
  }
  {
    std::string b = file;  // the z layer claims more bytes than the chunk has
    put<std::uint32_t>(b, sizes_at + 4, 1u << 20);
    EXPECT_CONTAINS(laz_error(b), "its layers run past the chunk's end");
  }
  {
    std::string b = file;  // one byte moved from the z layer to the x/y layer
    const auto xy = load_le<std::uint32_t>(reinterpret_cast<const unsigned char*>(b.data()) + sizes_at);
    const auto z = load_le<std::uint32_t>(reinterpret_cast<const unsigned char*>(b.data()) + sizes_at + 4);
    put<std::uint32_t>(b, sizes_at, xy + 1);
    put<std::uint32_t>(b, sizes_at + 4, z - 1);
    EXPECT_CONTAINS(laz_error(b), "LAZ chunk 0");
  }
  // Random damage to the layers: refused or (rarely) other points, never a crash.
  const auto table =
      static_cast<std::size_t>(load_le<std::int64_t>(reinterpret_cast<const unsigned char*>(file.data()) + o.points));
  const std::size_t first = sizes_at + 36;
  std::mt19937 rng(11);
  int refused = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::string b = file;
    for (int f = 0; f <= trial % 3; ++f) b[first + rng() % (table - first)] = static_cast<char>(rng() & 0xFF);
    const std::string msg = ced_test::io_error_of([&] { las_point_records(b, "damaged.laz"); });
    if (msg != "<no io_error thrown>") {
      EXPECT_CONTAINS(msg, "LAZ chunk 0");
      ++refused;
    }
  }
  EXPECT_GT(refused, 120);
}

TEST(LazMalformed, LayeredVlr) {
  const std::string file = read_bytes(data_path("1.2-with-color.copc.laz"));
  const laz_offsets o = offsets_of(file);
  const auto with = [&](std::size_t at, std::uint16_t v) {
    std::string b = file;
    put<std::uint16_t>(b, at, v);
    return laz_error(b);
  };
  EXPECT_CONTAINS(with(o.vlr, 2), "compressor 2 with point format 7");
  EXPECT_CONTAINS(with(o.vlr + 34 + 4, 2), "point14 v2 (30 bytes): not supported (layered items are versions 3 and 4)");
  EXPECT_CONTAINS(with(o.vlr + 34 + 6, 12), "do not match point format 7");  // rgb14 -> rgbnir14
  {
    std::string b = file;  // point format 9 (waveforms), records long enough for it
    b[104] = static_cast<char>(0x89);
    put<std::uint16_t>(b, 105, 59);
    EXPECT_CONTAINS(laz_error(b), "point format 9 is not supported in LAZ");
  }
}

TEST(Laz, LayeredFieldsDecodeAloneAsWithTheRest) {
  // A selection decodes only its fields' layers (the others are skipped);
  // each selected field must still be the whole decode's.
  for (const char* name : {"append-bug.laz", "1.2-with-color.copc.laz", "1_4_w_evlr.laz"}) {
    SCOPED_TRACE(name);
    const ced::point_cloud all = ced::io::read_cloud(data_path(name));
    for (const std::vector<std::string>& only : {std::vector<std::string>{"red", "green", "blue"},
                                                 {"nir"},
                                                 {"intensity", "gps_time"},
                                                 {"classification"},
                                                 {"scan_angle", "user_data", "point_source_id"},
                                                 {"withheld", "overlap"},
                                                 {}}) {
      ced::io::read_options o;
      o.fields = ced::field_selection::only(only);
      const ced::point_cloud some = ced::io::read_cloud(data_path(name), o);
      ASSERT_EQ(some.size(), all.size());
      EXPECT_TRUE(std::equal(some.positions().begin(), some.positions().end(), all.positions().begin()));
      for (const auto& f : some.fields()) {
        const auto* g = all.find_field(f.name);
        ASSERT_NE(g, nullptr) << f.name;
        for (std::size_t i = 0; i < all.size(); ++i) ASSERT_EQ(f.values[i], g->values[i]) << f.name << " " << i;
      }
    }
  }
}

namespace {

/// The COPC sample with its info VLR's root page pointed at `offset`, `size`.
std::string copc_with_root(std::uint64_t offset, std::uint64_t size) {
  std::string b = read_bytes(data_path("1.2-with-color.copc.laz"));
  put<std::uint64_t>(b, 375 + 54 + 40, offset);
  put<std::uint64_t>(b, 375 + 54 + 48, size);
  return b;
}

/// The io_error that asking `bytes`' stream for its runs in a box throws.
std::string runs_error(const std::string& bytes) {
  const std::string path = temp_file("copc.laz");
  write_bytes(path, bytes);
  return ced_test::io_error_of([&] {
    const double lo[3] = {-1e300, -1e300, -1e300}, hi[3] = {1e300, 1e300, 1e300};
    (void)ced::io::open_point_stream(path)->runs_within(lo, hi);
  });
}

}  // namespace

TEST(Copc, RunsWithinABoxHoldItsPoints) {
  const std::string path = data_path("1.2-with-color.copc.laz");
  const ced::point_cloud all = ced::io::read_cloud(path);
  const auto s = ced::io::open_point_stream(path);
  // Plain LAS and LAZ have no index.
  const double any_lo[3] = {0, 0, 0}, any_hi[3] = {1, 1, 1};
  EXPECT_FALSE(ced::io::open_point_stream(data_path("autzen_trim.laz"))->runs_within(any_lo, any_hi));
  // A box of a quarter of the cloud: its runs hold every point in it, and fewer than all.
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = 1e300;
    hi[k] = -1e300;
  }
  for (std::size_t i = 0; i < all.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], all.origin()[k] + all.position(i)[k]);
      hi[k] = std::max(hi[k], all.origin()[k] + all.position(i)[k]);
    }
  const double box_lo[3] = {lo[0], lo[1], lo[2]};
  const double box_hi[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2]};
  const auto runs = s->runs_within(box_lo, box_hi);
  ASSERT_TRUE(runs);
  std::vector<char> in_run(all.size(), 0);
  std::uint64_t total = 0, last_end = 0;
  for (const auto& r : *runs) {
    EXPECT_GE(r.first, last_end);  // ascending, apart
    last_end = r.first + r.count;
    total += r.count;
    for (std::uint64_t i = r.first; i < r.first + r.count; ++i) in_run[i] = 1;
  }
  EXPECT_LT(total, all.size());
  std::size_t inside = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    bool in = true;
    for (int k = 0; k < 3; ++k) {
      const double v = all.origin()[k] + all.position(i)[k];
      in = in && v >= box_lo[k] && v <= box_hi[k];
    }
    if (!in) continue;
    ++inside;
    EXPECT_TRUE(in_run[i]) << "point " << i << " is in the box but in no run";
  }
  EXPECT_GT(inside, 100u);
  // A run reads as the whole file's points, with the fields the names give.
  std::vector<std::string> names;
  for (const auto& f : all.fields()) names.push_back(f.name);
  ced::point_cloud c;
  const auto& r = runs->back();
  s->read_run(r, names, all.origin(), c);
  ASSERT_EQ(c.size(), r.count);
  ASSERT_EQ(c.fields().size(), all.fields().size());
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) ASSERT_EQ(c.position(i)[k], all.position(r.first + i)[k]);
}

TEST(Las, PointsReadAtRandomAreTheWholeFilesPoints) {
  // LAS reads only the records asked, LAZ decodes only the chunks that hold
  // them (the fetch of tiled runs' keypoints); each point as the whole read
  // gives it, the flags named. autzen in chunks of 997 points: runs of
  // neighbouring chunks (decoded 8 at a time) and chunks skipped.
  const std::string small_chunks = temp_file("autzen_997.laz");
  write_bytes(small_chunks,
              ced::io::detail::laz_from_las(read_bytes(data_path("autzen_trim.las")), "autzen_trim.las", 997));
  for (const std::string& path : {data_path("autzen_trim.las"), data_path("1_4_w_evlr.las"), data_path("simple.las"),
                                  data_path("autzen_trim.laz"), data_path("1_4_w_evlr.laz"), data_path("simple.laz"),
                                  data_path("1.2-with-color.copc.laz"), small_chunks}) {
    SCOPED_TRACE(path);
    const ced::point_cloud all = ced::io::read_cloud(path);
    std::vector<std::string> names;
    for (const auto& f : all.fields()) names.push_back(f.name);
    std::vector<std::uint64_t> at;  // ends, a dense run, gaps of every size
    for (std::uint64_t i = 0; i < all.size(); i += 1 + i / 3) at.push_back(i);
    for (std::uint64_t i :
         {std::uint64_t(all.size() / 2), std::uint64_t(all.size() / 2 + 1), std::uint64_t(all.size() - 1)})
      if (i > at.back()) at.push_back(i);
    auto s = ced::io::open_point_stream(path);
    ced::point_cloud c;
    ASSERT_TRUE(s->read_points(at, names, all.origin(), c));
    ASSERT_EQ(c.size(), at.size());
    ASSERT_EQ(c.fields().size(), all.fields().size());
    for (std::size_t j = 0; j < at.size(); ++j) {
      ASSERT_EQ(0, std::memcmp(c.position(j), all.position(at[j]), 12)) << j;
      for (std::size_t f = 0; f < c.fields().size(); ++f) {
        ASSERT_EQ(c.fields()[f].name, all.fields()[f].name);
        ASSERT_EQ(c.fields()[f].values[j], all.fields()[f].values[at[j]]) << c.fields()[f].name << " " << j;
      }
    }
    // Indices not ascending, or past the points: a caller's bug, refused.
    EXPECT_THROW(ced::io::open_point_stream(path)->read_points({3, 2}, names, all.origin(), c), std::logic_error);
    EXPECT_THROW(ced::io::open_point_stream(path)->read_points({all.size()}, names, all.origin(), c), std::logic_error);
  }
}

TEST(Copc, DamagedHierarchy) {
  const std::string file = read_bytes(data_path("1.2-with-color.copc.laz"));
  EXPECT_CONTAINS(runs_error(copc_with_root(file.size() - 10, 64)), "outside the file");
  EXPECT_CONTAINS(runs_error(copc_with_root(31604, 33)), "not a whole number of 32-byte entries");
  {
    std::string b = copc_with_root(31604, 2080);
    put<std::int32_t>(b, 31604 + 4, 5);  // the root node 0-5-0-0: outside a depth-0 octree
    EXPECT_CONTAINS(runs_error(b), "is outside the octree");
  }
  {
    std::string b = copc_with_root(31604, 2080);
    put<std::uint64_t>(b, 31604 + 16, 100);  // the root node's points at byte 100: no chunk there
    EXPECT_CONTAINS(runs_error(b), "is not a chunk of the chunk table");
  }
  {
    std::string b = copc_with_root(31604, 2080);  // the first entry a child page: the root page itself
    put<std::uint64_t>(b, 31604 + 16, 31604);
    put<std::int32_t>(b, 31604 + 24, 2080);
    put<std::int32_t>(b, 31604 + 28, -1);
    EXPECT_CONTAINS(runs_error(b), "reached twice");
  }
}

namespace {

/// The keypoints (indices) of every tile of `plan` merged.
std::vector<std::uint64_t> merged_keypoints(const ced::tile_plan& plan) {
  std::vector<ced::tile_part> parts;
  for (const auto& t : plan.tiles) parts.push_back(ced::detect_tile(plan, ced::read_tile(plan, t.id)));
  return ced::merge_parts(plan, std::move(parts)).index;
}

/// `file` with its header's bounds on axis k set to [lo, hi].
std::string with_bounds(std::string file, int k, double lo, double hi) {
  put<double>(file, 179 + 16 * std::size_t(k), hi);
  put<double>(file, 187 + 16 * std::size_t(k), lo);
  return file;
}

/// A plan over the COPC file `path` from its index, and the whole run's
/// keypoints; the plan has several tiles.
struct index_plan {
  ced::tiled_request request;
  ced::tile_plan plan;
  std::vector<std::uint64_t> whole;
};
index_plan plan_from_the_index(const std::string& path, const char* preset, double radius, double tile_size) {
  index_plan out;
  ced::detect_params p;
  p.radius = p.nms_radius = radius;
  const auto whole = ced::detect(ced::io::read_cloud(path), p, ced::preset(preset));
  out.whole.assign(whole.keypoints.begin(), whole.keypoints.end());
  out.request.input = path;
  out.request.params = p;
  out.request.modalities = ced::preset_specs(preset);
  out.request.tile_size = tile_size;
  out.plan = ced::plan_tiles(out.request);
  EXPECT_TRUE(out.plan.indexed) << preset;
  EXPECT_GT(out.plan.tiles.size(), 3u);
  EXPECT_FALSE(out.whole.empty());
  return out;
}

}  // namespace

TEST(Copc, PlanFromTheIndexGivesTheWholeResult) {
  const std::string path = data_path("1.2-with-color.copc.laz");
  const ced::point_cloud all = ced::io::read_cloud(path);
  for (const char* preset : {"ced6d", "ced3d"}) {
    index_plan ip = plan_from_the_index(path, preset, 60, 800);
    const ced::tile_plan& plan = ip.plan;
    ced::tiled_request& r = ip.request;
    EXPECT_EQ(plan.file_points, all.size());
    // The plan survives its file, and the tiles read through the index give the whole result.
    const ced::tile_plan again = ced::tile_plan::from_json(plan.to_json(), "plan.json");
    EXPECT_TRUE(again.indexed);
    EXPECT_EQ(merged_keypoints(again), ip.whole) << preset;
    // With scan: a plan by passes over the points (exact counts), the same keypoints.
    r.scan = true;
    const ced::tile_plan scanned = ced::plan_tiles(r);
    EXPECT_FALSE(scanned.indexed);
    EXPECT_EQ(merged_keypoints(scanned), merged_keypoints(plan)) << preset;
    EXPECT_EQ(scanned.origin, plan.origin);
  }
  // A grid of more than 2^20 tiles: planned by the passes, which list only
  // the tiles that own points (a plan from the index would list them all).
  ced::tiled_request fine;
  fine.input = path;
  fine.params.radius = fine.params.nms_radius = 1;
  fine.modalities = ced::preset_specs("ced3d");
  fine.tile_size = 8;
  const ced::tile_plan many = ced::plan_tiles(fine);
  EXPECT_GT(many.grid.count(), std::uint64_t(1) << 20);
  EXPECT_FALSE(many.indexed);
  EXPECT_LE(many.tiles.size(), all.size());
}

TEST(Copc, PlanFromTheIndexTrustsTheHeaderOnlyAsFarAsItHolds) {
  const std::string file = read_bytes(data_path("1.2-with-color.copc.laz"));
  const auto* h = reinterpret_cast<const unsigned char*>(file.data());
  const double lo = load_le<double>(h + 187), hi = load_le<double>(h + 179);
  ced::detect_params p;
  p.radius = p.nms_radius = 60;
  ced::tiled_request r;
  r.params = p;
  r.modalities = ced::preset_specs("ced6d");
  r.tile_size = 800;
  // Bounds looser than the points (by 0.4 % of the extent): the whole read
  // and the plan both take their origin from them, and the tiles are exact.
  {
    const std::string path = temp_file("loose.copc.laz");
    write_bytes(path, with_bounds(file, 0, lo - 0.004 * (hi - lo), hi));
    const ced::point_cloud all = ced::io::read_cloud(path);
    r.input = path;
    const ced::tile_plan plan = ced::plan_tiles(r);
    EXPECT_EQ(plan.origin, all.origin());
    const auto whole = ced::detect(all, p, ced::preset("ced6d"));
    EXPECT_EQ(merged_keypoints(plan), std::vector<std::uint64_t>(whole.keypoints.begin(), whole.keypoints.end()));
  }
  // Bounds that miss points: a tile names the point and says to scan.
  {
    const std::string path = temp_file("tight.copc.laz");
    write_bytes(path, with_bounds(file, 0, lo, hi - 0.1 * (hi - lo)));
    r.input = path;
    const ced::tile_plan plan = ced::plan_tiles(r);
    std::string error;
    for (const auto& t : plan.tiles) {
      error = ced_test::io_error_of([&] { (void)ced::read_tile(plan, t.id); });
      if (!error.empty()) break;
    }
    EXPECT_CONTAINS(error, "lies outside the header's bounds");
    EXPECT_CONTAINS(error, "--scan");
    r.scan = true;  // the passes do not need the header
    const ced::tile_plan scanned = ced::plan_tiles(r);
    const auto whole = ced::detect(ced::io::read_cloud(path), p, ced::preset("ced6d"));
    EXPECT_EQ(merged_keypoints(scanned), std::vector<std::uint64_t>(whole.keypoints.begin(), whole.keypoints.end()));
    r.scan = false;
  }
  // An index that does not hold the header's points.
  {
    std::string b = file;
    put<std::uint32_t>(b, 107, 1064);  // legacy point count one short
    put<std::uint64_t>(b, 247, 1064);  // LAS 1.4 point count
    r.input = temp_file("short.copc.laz");
    write_bytes(r.input, b);
    EXPECT_CONTAINS(ced_test::io_error_of([&] { (void)ced::plan_tiles(r); }), "1064");
  }
}

namespace {

/// The chunks of a LAZ file held in `bytes`, and its layout.
std::vector<ced::io::detail::laz_chunk> chunks_of(const std::string& bytes, ced::io::detail::laz_layout& layout) {
  const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
  const laz_offsets o = offsets_of(bytes);
  const int format = d[104] & 0x3F;
  const std::size_t record = load_le<std::uint16_t>(d + 105);
  const std::uint64_t count = d[25] >= 4 ? load_le<std::uint64_t>(d + 247) : load_le<std::uint32_t>(d + 107);
  layout = ced::io::detail::parse_laszip_vlr(d + o.vlr, o.vlr_len, format, record, "t.laz");
  const ced::io::detail::laz_read_fn read = [&](std::uint64_t at, std::size_t n, char* out) {
    std::memcpy(out, bytes.data() + at, n);
  };
  return ced::io::detail::laz_chunks(layout, o.points, bytes.size(), count, read, "t.laz");
}

}  // namespace

TEST(LazWriter, LayeredChunksAreThoseOfTheirWriters) {
  // Each layered chunk of files written by LASzip (through laspy and PDAL),
  // re-coded from its decoded records by ced's encoder, byte for byte.
  for (const char* name : {"1_4_w_evlr.laz", "1.2-with-color.copc.laz", "append-bug.laz"}) {
    SCOPED_TRACE(name);
    const std::string bytes = read_bytes(data_path(name));
    ced::io::detail::laz_layout layout;
    const auto chunks = chunks_of(bytes, layout);
    ASSERT_EQ(layout.compressor, 3);
    const std::string records = las_point_records(bytes, name);
    std::size_t same = 0;
    for (const auto& c : chunks) {
      std::string got;
      ced::io::detail::encode_laz_chunk(
          layout, reinterpret_cast<const unsigned char*>(records.data()) + c.first_point * layout.record_length,
          c.points, got);
      if (got == bytes.substr(c.offset, c.bytes))
        ++same;
      else
        ADD_FAILURE() << "chunk at " << c.offset << ": " << got.size() << " bytes, LASzip " << c.bytes;
    }
    EXPECT_EQ(same, chunks.size());
  }
}

namespace {

/// n records of LAS 1.4 point format `format` (6-8) with `extra` extra
/// bytes: every byte random (`mode` 0); scan-like (1: small steps, returns,
/// GPS times in two interleaved lines, switches between scanner channels);
/// or scan-like with every field but the position the same (2: layers of 0
/// bytes).
std::string make_records14(int format, std::size_t extra, std::size_t n, int mode, unsigned seed) {
  const std::size_t stride = (format == 6 ? 30 : format == 7 ? 36 : 38) + extra;
  std::mt19937 rng(seed);
  std::string r(n * stride, '\0');
  for (char& c : r) c = static_cast<char>(rng());
  if (mode == 0) return r;
  std::int32_t xyz[3] = {1000, -2000, 300};
  double line_time[2] = {1e5, 3.7e8};
  const std::string first = r.substr(0, stride);
  for (std::size_t i = 0; i < n; ++i) {
    unsigned char* p = reinterpret_cast<unsigned char*>(&r[i * stride]);
    if (mode == 2) std::memcpy(p, first.data(), stride);
    for (int k = 0; k < 3; ++k) xyz[k] += static_cast<std::int32_t>(rng() % 41) - 20 + (rng() % 97 == 0 ? 100000 : 0);
    std::memcpy(p, xyz, 12);
    if (mode == 2) continue;
    const unsigned returns = 1 + rng() % 5, number = 1 + (rng() % 5 == 0 ? rng() % 15 : rng() % returns);
    p[14] = static_cast<unsigned char>(number | returns << 4);
    const unsigned channel = (i / 37) % 4 == 3 ? unsigned(rng() % 4) : unsigned((i / 37) % 4);
    p[15] = static_cast<unsigned char>((rng() % 7 == 0 ? rng() % 16 : 0) | channel << 4 | (i % 50 == 0 ? 0x80 : 0));
    p[16] = static_cast<unsigned char>(rng() % 6 == 0 ? rng() % 64 : 2);
    const std::int16_t angle = static_cast<std::int16_t>(static_cast<int>(i % 600) - 300);
    std::memcpy(p + 18, &angle, 2);
    const std::uint16_t source = static_cast<std::uint16_t>(i / 400);
    std::memcpy(p + 20, &source, 2);
    const int line = (i / 3) % 2;
    const unsigned step = rng() % 10;
    line_time[line] += step == 0 ? 0.0 : step < 7 ? 1e-5 : step < 9 ? 3e-5 * (rng() % 20) : 1e4;
    double t = line_time[line];
    if (rng() % 211 == 0) t = -t;
    std::memcpy(p + 22, &t, 8);
    if (format >= 7 && rng() % 3 != 0) std::memcpy(p + 30, p - stride + 30 + (i == 0 ? stride : 0), 6);
  }
  return r;
}

}  // namespace

TEST(LazWriter, LayeredRecordsOfAnyBytesRoundTrip) {
  namespace d = ced::io::detail;
  for (int format = 6; format <= 8; ++format)
    for (std::size_t extra : {std::size_t(0), std::size_t(3)})
      for (int mode = 0; mode < 3; ++mode) {
        SCOPED_TRACE("format " + std::to_string(format) + ", extra " + std::to_string(extra) + ", mode " +
                     std::to_string(mode));
        const std::size_t n = 2500;
        const std::string records = make_records14(format, extra, n, mode, unsigned(format * 10 + extra + mode));
        const std::size_t stride = records.size() / n;
        const d::laz_layout layout = d::layered_layout(format, stride);
        for (std::size_t chunk : {std::size_t(1), std::size_t(2), std::size_t(700), n}) {
          std::string out(records.size(), '\0');
          std::size_t coded = 0;
          for (std::size_t at = 0; at < n; at += chunk) {
            const std::size_t m = std::min(chunk, n - at);
            std::string bytes;
            d::encode_laz_chunk(layout, reinterpret_cast<const unsigned char*>(records.data()) + at * stride, m, bytes);
            coded += bytes.size();
            const d::laz_chunk c{at, m, 0, bytes.size()};
            d::decode_laz_chunk(layout, c, 0, reinterpret_cast<const unsigned char*>(bytes.data()),
                                reinterpret_cast<unsigned char*>(out.data()) + at * stride, "t.laz");
          }
          EXPECT_TRUE(out == records) << "chunks of " << chunk;
          if (mode > 0 && chunk > 2) {  // it compresses (mode 1 keeps intensity, user data, NIR, extra bytes random)
            EXPECT_LT(coded, records.size() * 3 / 4) << "chunks of " << chunk;
          }
        }
      }
}

namespace {

/// The rows (position, then every field) of a cloud, sorted: the cloud as a
/// set of points, whatever their order.
std::vector<std::vector<double>> sorted_rows(const ced::point_cloud& c) {
  std::vector<std::vector<double>> rows(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (int k = 0; k < 3; ++k) rows[i].push_back(c.origin()[k] + double(c.position(i)[k]));
    for (const auto& f : c.fields()) rows[i].push_back(f.values[i]);
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

}  // namespace

TEST(Copc, WrittenFileHoldsTheCloudInItsOctree) {
  // write_cloud(.copc.laz): LAS 1.4 records grouped by octree node, one
  // layered chunk a node. The points are those of the cloud written as
  // LAS 1.4 (in node order), each inside its node's cube; whole and in
  // pieces, the same bytes.
  const ced::point_cloud c = autzen_with_saliency();
  const std::string copc = temp_file("out.copc.laz"), las = temp_file("out14.las");
  EXPECT_EQ(ced::io::format_of(copc), ced::io::file_format::copc);
  EXPECT_EQ(ced::io::format_of("A.COPC.LAZ"), ced::io::file_format::copc);
  ced::io::write_cloud(copc, c);
  ced::io::write_las(las, c);
  ced::io::read_report r;
  const ced::point_cloud got = ced::io::read_cloud(copc, {}, &r);
  EXPECT_EQ(r.details, "LAZ 1.4, point format 7, COPC");
  const ced::point_cloud want = ced::io::read_cloud(las);
  ASSERT_EQ(got.size(), want.size());
  ASSERT_EQ(got.fields().size(), want.fields().size());
  EXPECT_TRUE(sorted_rows(got) == sorted_rows(want));
  EXPECT_LT(std::filesystem::file_size(copc), std::filesystem::file_size(las) / 3);
  // The hierarchy: nodes at several depths, each a chunk, holding every point once, inside its cube.
  const auto s = ced::io::open_point_stream(copc);
  const auto nodes = s->index_nodes();
  ASSERT_TRUE(nodes);
  EXPECT_GT(nodes->size(), 8u);
  std::vector<int> seen(got.size(), 0);
  for (const auto& n : *nodes)
    for (std::uint64_t i = n.run.first; i < n.run.first + n.run.count; ++i) {
      ++seen[i];
      for (int k = 0; k < 3; ++k) {
        const double v = got.origin()[k] + double(got.position(i)[k]);
        ASSERT_GE(v, n.box[k] - 1e-3);
        ASSERT_LE(v, n.box[3 + k] + 1e-3);
      }
    }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(got.size()));
  // In pieces (a tiled run's merge), the same bytes.
  const std::string pieces = temp_file("pieces.copc.laz");
  write_in_pieces(pieces, c, ced::io::file_format::copc);
  EXPECT_TRUE(read_bytes(pieces) == read_bytes(copc));
  // What it cannot write is refused, naming it.
  EXPECT_THROW(ced::io::detail::copc_from_las(read_bytes(data_path("autzen_trim.las")), "autzen_trim.las"),
               std::invalid_argument);
}

TEST(Copc, WrittenFileTilesThroughItsIndexAsTheWholeRun) {
  const ced::point_cloud c = ced::io::read_cloud(data_path("autzen_trim.laz"));
  const std::string copc = temp_file("tiles.copc.laz");
  ced::io::write_cloud(copc, c);
  for (const char* preset : {"ced6d", "ced3d"}) {
    const index_plan ip = plan_from_the_index(copc, preset, 3, 100);
    EXPECT_EQ(merged_keypoints(ip.plan), ip.whole) << preset;
  }
}
