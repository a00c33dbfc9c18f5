// SPDX-License-Identifier: MIT
// LAS read (src/io/las/): every field of every point format, versions, georeferenced
// coordinates, extra bytes, chunks decoded in parallel, selected fields.

#include "las_test_support.hpp"

using namespace las_test;

// ------------------------------------------------------------------ reading

class LasFormat : public ::testing::TestWithParam<int> {};

namespace {
/// The standard fields of point format f have their LAS types.
void expect_standard_types(const point_cloud& c, int f) {
  EXPECT_EQ(c.get_field("intensity").type(), scalar_type::uint16);
  EXPECT_EQ(c.get_field("return_number").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("number_of_returns").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("classification").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("scan_angle").type(), f >= 6 ? scalar_type::int16 : scalar_type::int8);
  EXPECT_EQ(c.get_field("user_data").type(), scalar_type::uint8);
  EXPECT_EQ(c.get_field("point_source_id").type(), scalar_type::uint16);
  if (has_gps(f)) {
    EXPECT_EQ(c.get_field("gps_time").type(), scalar_type::float64);
  }
  if (has_rgb(f)) {
    for (const char* n : {"red", "green", "blue"}) EXPECT_EQ(c.get_field(n).type(), scalar_type::uint16);
  }
  if (has_nir(f)) {
    EXPECT_EQ(c.get_field("nir").type(), scalar_type::uint16);
  }
}

/// The standard fields of point format f hold the points' values.
void expect_standard_values(const point_cloud& c, const std::vector<las_point>& points, int f) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const las_point& p = points[i];
    EXPECT_EQ(values(c, "intensity")[i], p.intensity);
    EXPECT_EQ(values(c, "return_number")[i], p.return_number);
    EXPECT_EQ(values(c, "number_of_returns")[i], p.number_of_returns);
    EXPECT_EQ(values(c, "classification")[i], p.classification);
    EXPECT_EQ(values(c, "scan_angle")[i], p.scan_angle);
    EXPECT_EQ(values(c, "user_data")[i], p.user_data);
    EXPECT_EQ(values(c, "point_source_id")[i], p.point_source_id);
    if (has_gps(f)) {
      EXPECT_EQ(values(c, "gps_time")[i], p.gps_time);
    }
    if (has_rgb(f)) {
      EXPECT_EQ(values(c, "red")[i], p.red);
      EXPECT_EQ(values(c, "green")[i], p.green);
      EXPECT_EQ(values(c, "blue")[i], p.blue);
    }
    if (has_nir(f)) {
      EXPECT_EQ(values(c, "nir")[i], p.nir);
    }
  }
}
}  // namespace

TEST_P(LasFormat, EveryFieldIsRead) {
  const int f = GetParam();
  las_file file;
  file.format = f;
  file.minor = f >= 6 ? 4 : 2;
  file.scale = {0.01, 0.001, 0.5};
  file.offset = {10, -20, 0.25};
  file.points = sample_points(f);
  las_read_info info;
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las", &info);

  EXPECT_EQ(info.version_major, 1);
  EXPECT_EQ(info.version_minor, file.minor);
  EXPECT_EQ(info.point_format, f);
  EXPECT_EQ(info.points, 3u);
  EXPECT_EQ(info.scale, file.scale);
  EXPECT_EQ(info.offset, file.offset);
  EXPECT_EQ(info.system_identifier, "TEST SYSTEM");
  EXPECT_EQ(info.generating_software, "ced test builder");

  ASSERT_EQ(c.size(), 3u);
  // Coordinates reach beyond 1e4: relative to an integer origin.
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(c.origin()[k], std::round(c.origin()[k]));
  for (std::size_t i = 0; i < 3; ++i) {
    const las_point& p = file.points[i];
    const std::int32_t raw[3] = {p.x, p.y, p.z};
    for (std::size_t k = 0; k < 3; ++k) {
      // Float positions: exact to float precision relative to the origin.
      const double expected = raw[k] * file.scale[k] + file.offset[k];
      const double tolerance = 1e-7 * std::max(1.0, std::fabs(expected - c.origin()[k]));
      EXPECT_NEAR(absolute(c, i, k), expected, tolerance) << i << "," << k;
    }
  }

  std::vector<std::string> expected_names = {"intensity",  "return_number", "number_of_returns", "classification",
                                             "scan_angle", "user_data",     "point_source_id"};
  if (has_gps(f)) expected_names.push_back("gps_time");
  if (has_rgb(f)) expected_names.insert(expected_names.end(), {"red", "green", "blue"});
  if (has_nir(f)) expected_names.push_back("nir");
  std::vector<std::string> names;
  for (const auto& fld : c.fields()) names.push_back(fld.name);
  EXPECT_EQ(names, expected_names);

  expect_standard_types(c, f);
  expect_standard_values(c, file.points, f);
}

TEST_P(LasFormat, FlagsBecomeFieldsWhenSet) {
  const int f = GetParam();
  las_file file;
  file.format = f;
  file.minor = f >= 6 ? 4 : 3;
  file.points = sample_points(f);
  file.points[0].synthetic = true;
  file.points[1].key_point = true;
  file.points[2].withheld = true;
  file.points[2].scan_direction = true;
  file.points[1].edge = true;
  if (f >= 6) {
    file.points[0].overlap = true;
    file.points[2].scanner_channel = 3;
  }
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  EXPECT_EQ(values(c, "synthetic"), (std::vector<double>{1, 0, 0}));
  EXPECT_EQ(values(c, "key_point"), (std::vector<double>{0, 1, 0}));
  EXPECT_EQ(values(c, "withheld"), (std::vector<double>{0, 0, 1}));
  EXPECT_EQ(values(c, "scan_direction_flag"), (std::vector<double>{0, 0, 1}));
  EXPECT_EQ(values(c, "edge_of_flight_line"), (std::vector<double>{0, 1, 0}));
  if (f >= 6) {
    EXPECT_EQ(values(c, "overlap"), (std::vector<double>{1, 0, 0}));
    EXPECT_EQ(values(c, "scanner_channel"), (std::vector<double>{0, 0, 3}));
  } else {
    EXPECT_EQ(c.find_field("overlap"), nullptr);
  }
  // The flags do not leak into the fields next to them.
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(values(c, "classification")[i], file.points[i].classification);
    EXPECT_EQ(values(c, "return_number")[i], file.points[i].return_number);
    EXPECT_EQ(values(c, "number_of_returns")[i], file.points[i].number_of_returns);
  }
  EXPECT_EQ(c.get_field("withheld").type(), scalar_type::uint8);

  // Without any flag set, no flag fields.
  file.points = sample_points(f);
  const point_cloud plain = ced::io::read_las_buffer(file.build(), "mem.las");
  for (const char* n : {"synthetic", "key_point", "withheld", "overlap", "scanner_channel", "scan_direction_flag",
                        "edge_of_flight_line"})
    EXPECT_EQ(plain.find_field(n), nullptr) << n;
}

INSTANTIATE_TEST_SUITE_P(AllFormats, LasFormat, ::testing::Range(0, 11),
                         [](const auto& p) { return "format" + std::to_string(p.param); });

TEST(LasRead, LegacyVersions) {
  for (int minor : {0, 1, 2, 3, 4}) {
    las_file file;
    file.minor = minor;
    file.format = 1;
    file.points = sample_points(1);
    las_read_info info;
    const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las", &info);
    EXPECT_EQ(info.version_minor, minor);
    EXPECT_EQ(c.size(), 3u);
    EXPECT_EQ(values(c, "gps_time")[1], -1.5);
  }
}

TEST(LasRead, Las14PointCounts) {
  las_file file;
  file.minor = 4;
  file.format = 6;
  file.points = sample_points(6);
  file.legacy_count_in_14 = false;  // legacy count 0, the 64-bit count holds it
  las_read_info info;
  EXPECT_EQ(ced::io::read_las_buffer(file.build(), "mem.las", &info).size(), 3u);
  EXPECT_EQ(info.points, 3u);

  // A legacy format in a 1.4 file with only the legacy count set.
  file.format = 3;
  file.points = sample_points(3);
  file.legacy_count_in_14 = true;
  std::string bytes = file.build();
  poke<std::uint64_t>(bytes, 247, 0);
  EXPECT_EQ(ced::io::read_las_buffer(bytes, "mem.las").size(), 3u);
}

TEST(LasRead, EmptyFile) {
  las_file file;
  file.format = 3;
  las_read_info info;
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las", &info);
  EXPECT_TRUE(c.empty());
  EXPECT_EQ(info.points, 0u);
  EXPECT_NE(c.find_field("red"), nullptr);
}

TEST(LasRead, SmallCoordinatesKeepAZeroOrigin) {
  las_file file;
  file.format = 0;
  file.scale = {0.001, 0.001, 0.001};
  file.points.resize(2);
  file.points[0].x = 1500;  // 1.5 m
  file.points[1].y = -250;
  file.points[1].z = 9999999;  // 9999.999 m
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  EXPECT_EQ(c.origin(), (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(c.position(0)[0], 1.5f);
  EXPECT_EQ(c.position(1)[1], -0.25f);
  EXPECT_EQ(c.position(1)[2], 9999.999f);
}

TEST(LasRead, GeoreferencedCoordinatesKeepMillimetres) {
  las_file file;
  file.minor = 4;
  file.format = 6;
  file.scale = {0.001, 0.001, 0.001};
  file.offset = {500000, 4000000, 0};
  std::vector<std::array<double, 3>> truth;
  for (int i = 0; i < 2000; ++i) {
    las_point p;
    p.x = -700000 + 811 * i;  // ~1.6 km along x, around 500000
    p.y = 3000000 - 977 * i;  // ~2 km along y, around 4000000
    p.z = 100000 + 13 * i;    // 100 m + ...
    truth.push_back({p.x * 0.001 + 500000, p.y * 0.001 + 4000000, p.z * 0.001});
    file.points.push_back(p);
  }
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  ASSERT_EQ(c.size(), truth.size());
  EXPECT_NE(c.origin()[0], 0.0);
  EXPECT_NE(c.origin()[1], 0.0);
  double worst = 0;
  for (std::size_t i = 0; i < c.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::fabs(absolute(c, i, k) - truth[i][k]));
  EXPECT_LT(worst, 1e-3);
}

namespace {
/// Two points of format 7 with extra bytes of every type: scaled, offset,
/// undocumented, deprecated arrays, a name that clashes, names to trim.
las_file every_extra_type_file() {
  las_file file;
  file.minor = 4;
  file.format = 7;
  std::string eb;
  eb += descriptor(1, 0, "u8");
  eb += descriptor(2, 0, "i8");
  eb += descriptor(3, 0, "u16");
  eb += descriptor(4, 0, "i16");
  eb += descriptor(5, 0, "u32");
  eb += descriptor(6, 0, "i32");
  eb += descriptor(7, 0, "u64");
  eb += descriptor(8, 0, "i64");
  eb += descriptor(9, 0, "f32");
  eb += descriptor(10, 0, "f64");
  eb += descriptor(3, 8, "scaled", {0.01, 1, 1});                          // ushort, scale only
  eb += descriptor(4, 8 | 16, "scaled_offset", {0.5, 1, 1}, {100, 0, 0});  // short, scale and offset
  eb += descriptor(6, 16, "offset_only", {1, 1, 1}, {-1000.5, 0, 0});      // long, offset only
  eb += descriptor(0, 3, "undocumented");                                  // 3 bytes to skip
  eb += descriptor(13, 0, "pair");                                         // deprecated 2 x ushort
  eb += descriptor(22, 8, "triple", {0.1, 0.2, 0.5});                      // deprecated 3 x uchar, scaled
  eb += descriptor(1, 0, "intensity");                                     // clashes with a standard field
  eb += descriptor(1, 0, std::string("pad  \0\0", 7));                     // trailing spaces and NULs trimmed
  eb += descriptor(1, 0, "");                                              // no name
  file.vlrs.push_back(vlr("LASF_Projection", 2112, "fake WKT"));
  file.vlrs.push_back(vlr("LASF_Spec", 4, eb));
  file.vlrs.push_back(vlr("other", 1, std::string(10, 'x')));

  for (int i = 0; i < 2; ++i) {
    las_point p;
    p.intensity = static_cast<std::uint16_t>(1000 + i);
    std::string& e = p.extra;
    put(e, static_cast<std::uint8_t>(i ? 255 : 0));
    put(e, static_cast<std::int8_t>(i ? -128 : 127));
    put(e, static_cast<std::uint16_t>(i ? 65535 : 1));
    put(e, static_cast<std::int16_t>(i ? -32768 : 32767));
    put(e, static_cast<std::uint32_t>(i ? 4294967295u : 2));
    put(e, static_cast<std::int32_t>(i ? -2147483647 - 1 : 2147483647));
    put(e, static_cast<std::uint64_t>(i ? (std::uint64_t{1} << 53) : 3));
    put(e, static_cast<std::int64_t>(i ? -(std::int64_t{1} << 52) : -4));
    put(e, i ? 0.25f : -1.5e10f);
    put(e, i ? 1.0 / 3.0 : -2.5e-300);
    put(e, static_cast<std::uint16_t>(i ? 12345 : 0));
    put(e, static_cast<std::int16_t>(i ? -4 : 6));
    put(e, static_cast<std::int32_t>(i ? 1000 : 0));
    e += "abc";
    put(e, static_cast<std::uint16_t>(i ? 10 : 20));
    put(e, static_cast<std::uint16_t>(i ? 30 : 40));
    put(e, static_cast<std::uint8_t>(10));
    put(e, static_cast<std::uint8_t>(20));
    put(e, static_cast<std::uint8_t>(i ? 30 : 40));
    put(e, static_cast<std::uint8_t>(77));
    put(e, static_cast<std::uint8_t>(5));
    put(e, static_cast<std::uint8_t>(6));
    e += "zz";  // undescribed trailing bytes in the record
    file.points.push_back(p);
  }
  return file;
}
}  // namespace

TEST(LasRead, ExtraBytesOfSeveralTypes) {
  const las_file file = every_extra_type_file();
  const point_cloud c = ced::io::read_las_buffer(file.build(), "mem.las");
  ASSERT_EQ(c.size(), 2u);
  const auto expect = [&](const std::string& name, scalar_type type, std::vector<double> v) {
    const ced::field* fld = c.find_field(name);
    ASSERT_NE(fld, nullptr) << name;
    EXPECT_EQ(fld->type(), type) << name;
    EXPECT_EQ(fld->values, v) << name;
  };
  expect("u8", scalar_type::uint8, {0, 255});
  expect("i8", scalar_type::int8, {127, -128});
  expect("u16", scalar_type::uint16, {1, 65535});
  expect("i16", scalar_type::int16, {32767, -32768});
  expect("u32", scalar_type::uint32, {2, 4294967295.0});
  expect("i32", scalar_type::int32, {2147483647.0, -2147483648.0});
  expect("u64", scalar_type::uint64, {3, 9007199254740992.0});
  expect("i64", scalar_type::int64, {-4, -4503599627370496.0});
  expect("f32", scalar_type::float32, {double(-1.5e10f), 0.25});
  expect("f64", scalar_type::float64, {-2.5e-300, 1.0 / 3.0});
  expect("scaled", scalar_type::float64, {0, 12345 * 0.01});
  expect("scaled_offset", scalar_type::float64, {6 * 0.5 + 100, -4 * 0.5 + 100});
  expect("offset_only", scalar_type::float64, {-1000.5, -0.5});
  expect("pair_0", scalar_type::uint16, {20, 10});
  expect("pair_1", scalar_type::uint16, {40, 30});
  expect("triple_0", scalar_type::float64, {10 * 0.1, 10 * 0.1});
  expect("triple_1", scalar_type::float64, {20 * 0.2, 20 * 0.2});
  expect("triple_2", scalar_type::float64, {40 * 0.5, 30 * 0.5});
  expect("intensity", scalar_type::uint16, {1000, 1001});
  expect("intensity_extra", scalar_type::uint8, {77, 77});
  expect("pad", scalar_type::uint8, {5, 5});
  expect("extra_18", scalar_type::uint8, {6, 6});
  EXPECT_EQ(c.find_field("undocumented"), nullptr);
  // Extra fields follow the standard ones, in descriptor order.
  EXPECT_EQ(c.fields()[11].name, "u8");
}

// ------------------------------------------------------------ malformed input

TEST(LasRead, ChunksDecodedInParallelAreTheFilesPoints) {
  // 40 000 records of 34 bytes: several chunks of records, decoded in
  // parallel from the file (pread) and from memory. The withheld flag is set
  // by the last point only: every chunk of read_las has the field, and so
  // has every chunk of a stream after its first pass.
  las_file file;
  file.format = 3;
  file.offset = {500000, 4000000, 0};
  const std::size_t n = 40000;
  for (std::size_t i = 0; i < n; ++i) {
    las_point p;
    p.x = static_cast<std::int32_t>(i * 7 % 100003) - 50000;
    p.y = static_cast<std::int32_t>(i * 13 % 99991);
    p.z = static_cast<std::int32_t>(i % 1000);
    p.intensity = static_cast<std::uint16_t>(i);
    p.classification = static_cast<int>(i % 32);
    p.gps_time = 0.5 * static_cast<double>(i);
    p.red = static_cast<std::uint16_t>(3 * i);
    p.withheld = i + 1 == n;
    file.points.push_back(p);
  }
  const std::string bytes = file.build();
  const std::string path = temp_file("chunks.las");
  write_bytes(path, bytes);
  const point_cloud c = ced::io::read_las(path);
  ced_test::expect_same_cloud(c, ced::io::read_las_buffer(bytes, "mem.las"));
  ASSERT_EQ(c.size(), n);
  ASSERT_NE(c.find_field("withheld"), nullptr);
  for (std::size_t i = 0; i < n; i += 997) {
    const las_point& p = file.points[i];
    EXPECT_NEAR(absolute(c, i, 0), 500000 + p.x * 0.01, 0.01) << i;
    EXPECT_EQ(values(c, "intensity")[i], p.intensity) << i;
    EXPECT_EQ(values(c, "classification")[i], p.classification) << i;
    EXPECT_EQ(values(c, "gps_time")[i], p.gps_time) << i;
    EXPECT_EQ(values(c, "red")[i], p.red) << i;
    EXPECT_EQ(values(c, "withheld")[i], 0.0) << i;
  }
  EXPECT_EQ(values(c, "withheld")[n - 1], 1.0);

  // Only the selected fields, the same values.
  const point_cloud some = ced::io::read_las(path, nullptr, ced::field_selection::only({"gps_time", "withheld"}));
  ASSERT_EQ(some.fields().size(), 2u);
  EXPECT_EQ(some.positions(), c.positions());
  EXPECT_EQ(values(some, "gps_time"), values(c, "gps_time"));
  EXPECT_EQ(values(some, "withheld"), values(c, "withheld"));

  // The stream: the first chunk has no flag before its first pass, then the
  // chunks are read_las's points.
  auto s = ced::io::open_las_stream(path);
  point_cloud chunk;
  ASSERT_EQ(s->read(30000, {0, 0, 0}, chunk), 30000u);
  EXPECT_EQ(chunk.find_field("withheld"), nullptr);
  while (s->read(30000, {0, 0, 0}, chunk) > 0) {
  }
  EXPECT_EQ(s->origin(), c.origin());
  s->rewind();
  std::size_t at = 0;
  while (s->read(12345, s->origin(), chunk) > 0) {
    ASSERT_EQ(chunk.fields().size(), c.fields().size());
    for (std::size_t i = 0; i < chunk.size(); ++i)
      for (std::size_t k = 0; k < 3; ++k) ASSERT_EQ(chunk.position(i)[k], c.position(at + i)[k]);
    for (std::size_t f = 0; f < c.fields().size(); ++f)
      for (std::size_t i = 0; i < chunk.size(); ++i)
        ASSERT_EQ(chunk.fields()[f].values[i], c.fields()[f].values[at + i]);
    at += chunk.size();
  }
  EXPECT_EQ(at, n);
}

TEST(LasRead, OnlySelectedFieldsAreDecoded) {
  las_file file;
  file.minor = 4;
  file.format = 7;  // colour
  file.vlrs.push_back(vlr("LASF_Spec", 4, descriptor(1, 0, "intensity") + descriptor(3, 0, "nir_extra")));
  for (int i = 0; i < 3; ++i) {
    las_point p;
    p.intensity = static_cast<std::uint16_t>(100 + i);
    p.red = static_cast<std::uint16_t>(10 * i);
    p.green = static_cast<std::uint16_t>(20 * i);
    p.blue = static_cast<std::uint16_t>(30 * i);
    p.x = 1000 * i;
    put(p.extra, static_cast<std::uint8_t>(7 + i));
    put(p.extra, static_cast<std::uint16_t>(500 + i));
    file.points.push_back(p);
  }
  const std::string bytes = file.build();
  const point_cloud all = ced::io::read_las_buffer(bytes, "mem.las");
  ASSERT_NE(all.find_field("intensity_extra"), nullptr);  // the extra field's name, with every field read
  // Names matched ignoring case; an extra field keeps the name it has when
  // every field is read, whatever is selected.
  const point_cloud some = ced::io::read_las_buffer(bytes, "mem.las", nullptr,
                                                    ced::field_selection::only({"RED", "green", "intensity_extra"}));
  std::vector<std::string> names;
  for (const auto& f : some.fields()) names.push_back(f.name);
  EXPECT_EQ(names, (std::vector<std::string>{"red", "green", "intensity_extra"}));
  for (const auto& f : some.fields()) {
    EXPECT_EQ(f.values, all.get_field(f.name).values) << f.name;
    EXPECT_EQ(f.type(), all.get_field(f.name).type()) << f.name;
  }
  EXPECT_EQ(some.positions(), all.positions());
  EXPECT_EQ(some.origin(), all.origin());
  // Nothing selected: positions only. Everything: the default.
  EXPECT_TRUE(ced::io::read_las_buffer(bytes, "mem.las", nullptr, ced::field_selection::only({})).fields().empty());
  EXPECT_EQ(ced::io::read_las_buffer(bytes, "mem.las", nullptr, {}).fields().size(), all.fields().size());
  // read_cloud applies the selection to every format.
  const std::string dir = ced_test::temp_dir().string();
  ced::io::write_cloud(dir + "/all.ply", all);
  ced::io::read_options o;
  o.fields = ced::field_selection::only({"blue", "nir_extra"});
  const point_cloud ply = ced::io::read_cloud(dir + "/all.ply", o);
  ASSERT_EQ(ply.fields().size(), 2u);
  EXPECT_EQ(ply.get_field("blue").values, all.get_field("blue").values);
  EXPECT_EQ(ply.get_field("nir_extra").values, all.get_field("nir_extra").values);
}
