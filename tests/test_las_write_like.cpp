// SPDX-License-Identifier: MIT
// LAS written like its source (las_write_options_like) and `ced convert` LAS -> LAS:
// the records come back byte for byte, and every change is said.

#include "las_test_support.hpp"

using namespace las_test;

namespace {

std::string data_path(const std::string& name) { return std::string(CED_TEST_DATA_DIR) + "/" + name; }

/// "" when the point records `a` and `b` (`stride` bytes each) are the same
/// bytes; else how they differ: the number of records, the first record
/// that differs, and the largest change of a raw X, Y or Z integer.
std::string record_difference(const std::string& a, const std::string& b, std::size_t stride) {
  if (a == b) return "";
  std::ostringstream out;
  if (a.size() != b.size() || stride == 0) {
    out << a.size() << " bytes of records against " << b.size();
    return out.str();
  }
  std::size_t first = a.size() / stride, differ = 0;
  std::int64_t most = 0;
  for (std::size_t i = 0; i < a.size() / stride; ++i) {
    if (std::memcmp(&a[i * stride], &b[i * stride], stride) == 0) continue;
    first = std::min(first, i);
    ++differ;
    for (std::size_t k = 0; k < 3; ++k)
      most = std::max<std::int64_t>(most, std::llabs(std::int64_t(peek<std::int32_t>(a, i * stride + 4 * k)) -
                                                     peek<std::int32_t>(b, i * stride + 4 * k)));
  }
  out << differ << " records differ, the first is record " << first << "; X/Y/Z integers move by up to " << most;
  return out.str();
}

/// The point records of a LAS or LAZ file's bytes (decoded).
std::string records_of(const std::string& bytes, const std::string& name) {
  return ced::io::detail::las_point_records(bytes, name);
}

/// The LAS/LAZ files of tests/data whose positions are exact in floats.
const char* const k_public_las_files[] = {"simple.las",
                                          "autzen_trim.las",
                                          "1.2-with-color.las",
                                          "autzen-bmx-2010.las",
                                          "warsaw_small.las",
                                          "sample_c.las",
                                          "file_with_both_wkt_and_geotiff_vlrs.las",
                                          "simple.laz",
                                          "simple-laszip-1.2r0.laz",
                                          "autzen_trim.laz",
                                          "1.2-with-color.copc.laz"};

}  // namespace

class LasWriteLike : public ::testing::TestWithParam<const char*> {};

TEST_P(LasWriteLike, PointRecordsComeBackByteForByte) {
  const std::string name = GetParam();
  const std::string source = read_bytes(data_path(name));
  las_read_info src;
  const point_cloud cloud = ced::io::read_las_buffer(source, name, &src);
  std::vector<std::string> changes;
  const las_write_options opt = ced::io::las_write_options_like(src, cloud, false, &changes);
  EXPECT_TRUE(changes.empty()) << changes.front();
  const std::string want = records_of(source, name);
  const std::size_t stride = want.size() / std::max<std::size_t>(cloud.size(), 1);
  for (const auto format : {ced::io::file_format::las, ced::io::file_format::laz}) {
    std::stringstream s;
    ced::io::write_cloud(s, cloud, format, opt);
    const std::string out = s.str();
    las_read_info got;
    const point_cloud back = ced::io::read_las_buffer(out, "out", &got);
    const std::string what = name + " as " + ced::io::format_name(format);
    EXPECT_EQ(got.version_minor, src.version_minor) << what;
    EXPECT_EQ(got.point_format, src.point_format) << what;
    EXPECT_EQ(got.scale, src.scale) << what;
    EXPECT_EQ(got.offset, src.offset) << what;
    EXPECT_EQ(got.global_encoding & 1, src.global_encoding & 1) << what;
    EXPECT_EQ(got.compressed, format == ced::io::file_format::laz) << what;
    EXPECT_EQ(record_difference(records_of(out, what), want, stride), "") << what;
    // The fields keep their types (scan_angle: int8 degrees in formats 0-5).
    ASSERT_EQ(back.fields().size(), cloud.fields().size()) << what;
    for (std::size_t j = 0; j < cloud.fields().size(); ++j)
      EXPECT_EQ(back.fields()[j].type(), cloud.fields()[j].type()) << what << " " << cloud.fields()[j].name;
  }
}

INSTANTIATE_TEST_SUITE_P(PublicFiles, LasWriteLike, ::testing::ValuesIn(k_public_las_files),
                         [](const ::testing::TestParamInfo<const char*>& p) {
                           std::string s = p.param;
                           for (char& c : s)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return s;
                         });

TEST(LasWriteLike, FinerThanAFloatMovesOnceThenIsStable) {
  // 1_4_w_evlr.las: scale 1.16e-6 (Z 1.0e-6). Positions are floats relative
  // to the origin: X spans ~500 around the origin's X (float steps up to
  // 2^-16 = 1.5e-5 at 250 from it), Z lies at ~5596 from the origin's Z (0:
  // the centre is within 1e4; steps of 2^-11 = 4.9e-4), both coarser than the
  // scale; Y spans ~5 (steps of 2.4e-7, finer). The source's X and Z
  // integers cannot all come back, which is said once an axis; the first
  // write moves them by at most half a float step; what it wrote comes back
  // byte for byte.
  const std::string name = "1_4_w_evlr.las";
  const std::string source = read_bytes(data_path(name));
  las_read_info src;
  const point_cloud a = ced::io::read_las_buffer(source, name, &src);
  std::vector<std::string> changes;
  const las_write_options opt = ced::io::las_write_options_like(src, a, false, &changes);
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].rfind("X positions are floats", 0), 0u) << changes[0];
  EXPECT_EQ(changes[1].rfind("Z positions are floats", 0), 0u) << changes[1];
  EXPECT_EQ(opt.scale, src.scale);
  ASSERT_TRUE(opt.offset.has_value());
  EXPECT_EQ(*opt.offset, src.offset);
  std::stringstream s1;
  ced::io::write_las(s1, a, opt);
  const std::string want = records_of(source, name), first = records_of(s1.str(), "first");
  ASSERT_EQ(first.size(), want.size());
  const std::size_t stride = 30;
  float far[3] = {0, 0, 0};
  for (std::size_t i = 0; i < a.positions().size(); ++i) far[i % 3] = std::max(far[i % 3], std::fabs(a.positions()[i]));
  double most[3] = {0, 0, 0};
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(first.compare(i * stride + 12, stride - 12, want, i * stride + 12, stride - 12), 0) << i;
    for (std::size_t k = 0; k < 3; ++k) {
      const double moved = std::fabs(double(peek<std::int32_t>(first, i * stride + 4 * k)) -
                                     peek<std::int32_t>(want, i * stride + 4 * k)) *
                           src.scale[k];
      most[k] = std::max(most[k], moved);
      const double half_step = (double(std::nextafter(far[k], 2 * far[k])) - far[k]) / 2;
      EXPECT_LE(moved, half_step + src.scale[k]) << i << "," << k;
    }
  }
  EXPECT_GT(most[0], 0);  // the test's premise: the integers did move
  EXPECT_EQ(most[1], 0);
  EXPECT_GT(most[2], 0);
  las_read_info mid;
  const point_cloud b = ced::io::read_las_buffer(s1.str(), "first", &mid);
  std::stringstream s2;
  ced::io::write_las(s2, b, ced::io::las_write_options_like(mid, b));
  EXPECT_EQ(record_difference(records_of(s2.str(), "second"), first, stride), "");
}

TEST(LasWriteLike, MovedPointsFallBackAndSaySo) {
  las_read_info src;
  point_cloud c = ced::io::read_las(data_path("simple.las"), &src);
  std::vector<std::string> changes;
  las_write_options opt = ced::io::las_write_options_like(src, c, false, &changes);
  EXPECT_TRUE(changes.empty());
  ASSERT_TRUE(opt.offset.has_value());
  c.positions()[4] += 0.003f;  // off the 0.01 grid
  opt = ced::io::las_write_options_like(src, c, false, &changes);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("not on the source's grid"), std::string::npos) << changes[0];
  EXPECT_EQ(opt.scale, (std::array<double, 3>{0.001, 0.001, 0.001}));
  EXPECT_FALSE(opt.offset.has_value());
  EXPECT_EQ(opt.point_format, 3);  // the format and version are kept
  EXPECT_EQ(opt.version_minor, 2);
  std::stringstream s;
  ced::io::write_las(s, c, opt);
  const point_cloud back = ced::io::read_las_buffer(s.str(), "out");
  EXPECT_NEAR(back.origin()[1] + back.position(1)[1], c.origin()[1] + c.position(1)[1], 0.0005 + 1e-4);
}

TEST(LasWriteLike, FormatsThatCannotBeKeptAreNamed) {
  const point_cloud c = ced::io::read_las(data_path("simple.las"));
  las_read_info src;
  src.version_minor = 2;
  src.point_format = 3;
  src.scale = {0.01, 0.01, 0.01};
  std::vector<std::string> changes;
  las_write_options o = ced::io::las_write_options_like(src, c, true, &changes);  // COPC
  EXPECT_EQ(o.point_format, 7);
  EXPECT_EQ(o.version_minor, 4);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("COPC"), std::string::npos);
  changes.clear();
  src.point_format = 5;  // waveform packets
  o = ced::io::las_write_options_like(src, c, false, &changes);
  EXPECT_EQ(o.point_format, 3);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("waveform"), std::string::npos);
  changes.clear();
  src.point_format = 1;
  src.version_minor = 0;
  o = ced::io::las_write_options_like(src, c, false, &changes);
  EXPECT_EQ(o.version_minor, 2);
  EXPECT_EQ(o.point_format, 1);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_NE(changes[0].find("LAS 1.0"), std::string::npos);
  // A source whose gps_time is adjusted standard time says so again.
  src.global_encoding = 1;
  EXPECT_TRUE(ced::io::las_write_options_like(src, c).adjusted_standard_gps_time);
}

TEST(LasWrite, ExplicitPointFormatAndOffset) {
  point_cloud c;
  c.set_origin({500000, 4000000, 0});
  c.push_back(1.25f, -2.5f, 3.0f);
  c.push_back(-1.0f, 0.5f, 0.25f);
  las_write_options o;
  o.version_minor = 2;
  o.point_format = 3;  // gps_time and colour slots, though the cloud has neither
  o.scale = {0.01, 0.01, 0.01};
  o.offset = std::array<double, 3>{499000, 3999000, -10};
  std::stringstream s;
  ced::io::write_las(s, c, o);
  const std::string bytes = s.str();
  las_read_info info;
  const point_cloud back = ced::io::read_las_buffer(bytes, "out", &info);
  EXPECT_EQ(info.point_format, 3);
  EXPECT_EQ(info.version_minor, 2);
  EXPECT_EQ(info.offset, (*o.offset));
  EXPECT_EQ(peek<std::int32_t>(bytes, 227), 100125);  // (500001.25 - 499000) / 0.01
  EXPECT_EQ(peek<std::int32_t>(bytes, 227 + 4), 99750);
  EXPECT_EQ(peek<std::int32_t>(bytes, 227 + 8), 1300);
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(absolute(back, i, k), absolute(c, i, k), 1e-6);
  o.point_format = 7;  // LAS 1.4 only
  EXPECT_THROW(ced::io::write_las(s, c, o), std::invalid_argument);
  o.point_format = 4;  // waveform
  EXPECT_THROW(ced::io::write_las(s, c, o), std::invalid_argument);
  o.point_format = -1;
  o.offset = std::array<double, 3>{0, std::numeric_limits<double>::quiet_NaN(), 0};
  EXPECT_THROW(ced::io::write_las(s, c, o), std::invalid_argument);
}

#ifdef CED_CLI_EXE
namespace {

/// Runs `ced <args>`, its stderr into *err; the exit status.
int run_cli(const std::string& args, std::string* err) {
  const char* exe = std::getenv("CED_CLI");
  const std::string log = temp_file("cli_stderr.txt");
  const std::string cmd = std::string(exe && *exe ? exe : CED_CLI_EXE) + " " + args + " 2>" + log;
  const int rc = std::system(cmd.c_str());
  if (err) *err = read_bytes(log);
  return rc;
}

}  // namespace

TEST(LasConvert, LasToLasKeepsTheRecordsVersionAndFormat) {
  struct pair {
    const char* in;
    const char* out;
  };
  for (const pair p : {pair{"simple.las", "a.las"}, pair{"autzen-bmx-2010.las", "b.las"},
                       pair{"1.2-with-color.copc.laz", "c.las"}, pair{"simple.laz", "d.las"},
                       pair{"simple.las", "e.laz"}, pair{"file_with_both_wkt_and_geotiff_vlrs.las", "f.laz"}}) {
    const std::string out = temp_file(p.out);
    std::string err;
    ASSERT_EQ(run_cli("convert " + data_path(p.in) + " " + out, &err), 0) << err;
    // Nothing of the points changes; only the VLRs that no writer carries (a CRS) are named.
    const std::string wkt = "'LASF_Projection' 2112";
    const std::string vlrs = std::string(p.in).find("simple") == 0 ? ""
                             : std::string(p.in).find("wkt") != std::string::npos
                                 ? "'LASF_Projection' 34735, 'LASF_Projection' 34736, 'LASF_Projection' 34737, " + wkt
                             : std::string(p.in).find("copc") != std::string::npos ? wkt + ", and 1 extended VLR(s)"
                                                                                   : wkt;
    EXPECT_EQ(err, vlrs.empty() ? ""
                                : "ced: note: " + out + ": " + data_path(p.in) + "'s VLRs " + vlrs +
                                      " (a coordinate system, if one is among them) are not copied\n")
        << p.in;
    las_read_info src, got;
    ced::io::read_las(data_path(p.in), &src);
    ced::io::read_las(out, &got);
    EXPECT_EQ(got.version_minor, src.version_minor) << p.in;
    EXPECT_EQ(got.point_format, src.point_format) << p.in;
    EXPECT_EQ(got.scale, src.scale) << p.in;
    EXPECT_EQ(got.offset, src.offset) << p.in;
    const std::string want = records_of(read_bytes(data_path(p.in)), p.in);
    EXPECT_EQ(
        record_difference(records_of(read_bytes(out), out), want, want.size() / std::max<std::uint64_t>(src.points, 1)),
        "")
        << p.in;
  }
}

TEST(LasConvert, ChangesAreSaidOnceOnStderr) {
  std::string err;
  const std::string out = temp_file("voxel.las");
  ASSERT_EQ(run_cli("convert " + data_path("simple.las") + " " + out + " --voxel 20", &err), 0) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("not on the source's grid"), std::string::npos) << err;
  las_read_info got;
  ced::io::read_las(out, &got);
  EXPECT_EQ(got.scale, (std::array<double, 3>{0.001, 0.001, 0.001}));
  EXPECT_EQ(got.point_format, 3);
  EXPECT_EQ(got.version_minor, 2);
  // COPC holds formats 6-8 only.
  ASSERT_EQ(run_cli("convert " + data_path("simple.las") + " " + temp_file("s.copc.laz"), &err), 0) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("COPC"), std::string::npos) << err;
  // A PLY has no scale.
  ASSERT_EQ(run_cli("convert " + data_path("falloff_patch.ply") + " " + temp_file("p.las"), &err), 0) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("no LAS scale"), std::string::npos) << err;
}
#endif
