// SPDX-License-Identifier: MIT
// LAZ (src/io/laz/, src/io/las/): every record of the public LAZ test files decodes to
// the bytes of its plain-LAS twin, the clouds and keypoints are the twin's,
// and damaged files are refused with an io_error naming the file, never read
// out of bounds.

#include "laz_test_support.hpp"

using namespace laz_test;

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
