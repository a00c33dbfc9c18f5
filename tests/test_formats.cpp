// SPDX-License-Identifier: MIT
// The same cloud in every format and encoding gives the same keypoints,
// including georeferenced coordinates with large offsets.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "file_support.hpp"
#include "io/base/formats.hpp"
#include "test_support.hpp"

namespace {
/// A coloured room on a millimetre grid (so LAS holds it exactly), placed at
/// (500000, 4000000) like projected map coordinates.
ced::point_cloud georeferenced_room() {
  ced::point_cloud c = ced_test::make_room(6000, 17);
  for (float& v : c.positions()) v = static_cast<float>(std::round(double(v) * 1000.0) * 0.001);
  for (std::size_t i = 0; i < c.size(); ++i) c.positions()[3 * i + 2] += 100.0f;
  c.set_origin({500000.0, 4000000.0, 0.0});
  return c;
}
}  // namespace

TEST(Formats, EveryFormatGivesTheSameKeypoints) {
  const ced::point_cloud cloud = georeferenced_room();
  const std::vector<ced::any_modality> mods = {ced::make_modality("xyz"), ced::make_modality("rgb"),
                                               ced::make_modality("intensity:0.3,range=0..65535")};
  const ced::detect_params p;
  const auto want = ced::detect(cloud, p, mods).keypoints;
  ASSERT_GT(want.size(), 20u);

  const auto dir = std::filesystem::path(::testing::TempDir()) / "ced_formats";
  std::filesystem::create_directories(dir);
  struct variant {
    std::string name;
    std::function<void(const std::string&)> write;
  };
  const std::vector<variant> variants = {
      {"a.ply", [&](const std::string& f) { ced::io::write_ply(f, cloud, ced::io::ply_format::binary_little_endian); }},
      {"b.ply", [&](const std::string& f) { ced::io::write_ply(f, cloud, ced::io::ply_format::binary_big_endian); }},
      {"c.ply", [&](const std::string& f) { ced::io::write_ply(f, cloud, ced::io::ply_format::ascii); }},
      {"a.pcd", [&](const std::string& f) { ced::io::write_pcd(f, cloud, ced::io::pcd_format::ascii); }},
      {"b.pcd", [&](const std::string& f) { ced::io::write_pcd(f, cloud, ced::io::pcd_format::binary); }},
      {"c.pcd", [&](const std::string& f) { ced::io::write_pcd(f, cloud, ced::io::pcd_format::binary_compressed); }},
      {"a.las", [&](const std::string& f) { ced::io::write_las(f, cloud); }},
      {"a.csv", [&](const std::string& f) { ced::io::write_csv(f, cloud); }},
  };
  for (const auto& v : variants) {
    const std::string path = (dir / v.name).string();
    v.write(path);
    const ced::point_cloud back = ced::io::read_cloud(path);
    ASSERT_EQ(back.size(), cloud.size()) << v.name;
    EXPECT_EQ(back.origin(), cloud.origin()) << v.name;
    float worst = 0;  // positions agree to far below a micrometre (float rounding of the offsets)
    for (std::size_t i = 0; i < cloud.positions().size(); ++i)
      worst = std::max(worst, std::abs(back.positions()[i] - cloud.positions()[i]));
    EXPECT_LT(worst, 1e-6f) << v.name;
    EXPECT_EQ(ced::detect(back, p, mods).keypoints, want) << v.name;
  }
  std::filesystem::remove_all(dir);
}

TEST(Formats, ExtensionsAndRefusals) {
  EXPECT_EQ(ced::io::format_of("a/b.PLY"), ced::io::file_format::ply);
  EXPECT_EQ(ced::io::format_of("x.xyz"), ced::io::file_format::csv);
  EXPECT_EQ(ced::io::format_of("x.las"), ced::io::file_format::las);
  auto message = [](const std::string& path) {
    try {
      ced::io::format_of(path);
    } catch (const ced::io::io_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(ced::io::format_of("scan.laz"), ced::io::file_format::laz);  // read by the LAS reader
  EXPECT_EQ(message("scan.laz"), "");
  EXPECT_NE(message("scan.e57").find("convert"), std::string::npos);
  EXPECT_NE(message("scan.obj").find("unsupported"), std::string::npos);
  EXPECT_NE(message("dir.d/scan").find("--format"), std::string::npos);
  EXPECT_THROW(ced::io::parse_format("obj"), std::invalid_argument);
}

TEST(Formats, WritersRefuseMoreValuesPerPointThanTheReadersAccept) {
  // The PLY, PCD and CSV readers accept at most 65 536 values per point (x, y
  // and z included): the writers refuse a cloud with more, before writing
  // anything (#25: 65 533 fields read, plus a saliency written, gave files
  // ced could not read back).
  auto cloud_of = [](std::size_t fields) {
    ced::point_cloud c;
    c.push_back(0, 0, 0);
    c.push_back(1, 2, 3);
    for (std::size_t k = 0; k < fields; ++k) c.add_field("f" + std::to_string(k), ced::scalar_type::uint8, {1, 2});
    return c;
  };
  const ced::point_cloud too_many = cloud_of(65534);
  const auto dir = std::filesystem::path(::testing::TempDir()) / "ced_formats_limit";
  std::filesystem::create_directories(dir);
  for (const char* name : {"wide.ply", "wide.pcd", "wide.csv"}) {
    const std::string path = (dir / name).string();
    try {
      ced::io::write_cloud(path, too_many);
      ADD_FAILURE() << name << ": written";
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("65536"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(path)) << name;
    std::ostringstream out;
    EXPECT_THROW(ced::io::write_cloud(out, too_many, ced::io::format_of(path)), ced::io::io_error) << name;
    EXPECT_TRUE(out.str().empty()) << name;
  }
  // The most the readers accept round-trips.
  const ced::point_cloud most = cloud_of(65533);
  for (const char* name : {"most.ply", "most.pcd", "most.csv"}) {
    const std::string path = (dir / name).string();
    ced::io::write_cloud(path, most);
    EXPECT_EQ(ced::io::read_cloud(path).fields().size(), 65533u) << name;
  }
  std::filesystem::remove_all(dir);
}

TEST(Formats, TheReadersGiveTheSameCloudForAnyNumberOfThreads) {
  // Binary records are decoded in chunks of 128 KiB on read_options::threads
  // threads: a cloud of many chunks, read on 1 and 2 threads and all cores.
  ced::point_cloud cloud = ced_test::make_room(60000, 5);
  for (float& v : cloud.positions()) v = static_cast<float>(std::round(double(v) * 1000.0) * 0.001);
  const auto dir = std::filesystem::path(::testing::TempDir()) / "ced_formats_threads";
  std::filesystem::create_directories(dir);
  for (const char* name : {"room.las", "room.ply", "room.pcd"}) {
    SCOPED_TRACE(name);
    const std::string file = (dir / name).string();
    ced::point_cloud written = cloud;
    // PLY and PCD keep a NaN point (PCD's reader drops it): a chunk of fewer
    // finite points than records. LAS cannot store one.
    if (std::string(name) != "room.las") written.positions()[3 * 45000] = std::numeric_limits<float>::quiet_NaN();
    ced::io::write_cloud(file, written);
    ced::io::read_options o;
    o.threads = 1;
    const ced::point_cloud want = ced::io::read_cloud(file, o);
    EXPECT_GE(want.size(), 59999u);
    for (const unsigned threads : {2u, 0u}) {
      o.threads = threads;
      const ced::point_cloud got = ced::io::read_cloud(file, o);
      ASSERT_EQ(got.size(), want.size());
      EXPECT_EQ(got.origin(), want.origin());
      ASSERT_EQ(got.positions().size(), want.positions().size());  // bitwise: PLY keeps the NaN
      EXPECT_EQ(std::memcmp(got.positions().data(), want.positions().data(), 4 * want.positions().size()), 0);
      ASSERT_EQ(got.fields().size(), want.fields().size());
      for (std::size_t f = 0; f < got.fields().size(); ++f) EXPECT_EQ(got.fields()[f].values, want.fields()[f].values);
    }
  }
}

TEST(Formats, PipesAreReadWhole) {
  // A pipe has no size and no offsets: the readers read it whole, front to
  // back, and give the cloud of the regular file.
  const ced::point_cloud cloud = georeferenced_room();
  const auto dir = std::filesystem::path(::testing::TempDir()) / "ced_formats_pipe";
  std::filesystem::create_directories(dir);
  for (const char* name : {"room.las", "room.ply", "room.pcd"}) {
    SCOPED_TRACE(name);
    const std::string file = (dir / name).string(), pipe = (dir / (std::string("pipe_") + name)).string();
    ced::io::write_cloud(file, cloud);
    std::filesystem::remove(pipe);
    ASSERT_EQ(mkfifo(pipe.c_str(), 0600), 0);
    std::thread writer([&] {
      std::ifstream in(file, std::ios::binary);
      std::ofstream out(pipe, std::ios::binary);
      out << in.rdbuf();
    });
    ced::io::read_options o;
    o.format = ced::io::format_of(file);
    const ced::point_cloud got = ced::io::read_cloud(pipe, o);
    writer.join();
    const ced::point_cloud want = ced::io::read_cloud(file);
    ASSERT_EQ(got.size(), want.size());
    EXPECT_EQ(got.origin(), want.origin());
    EXPECT_EQ(got.positions(), want.positions());
    ASSERT_EQ(got.fields().size(), want.fields().size());
    for (std::size_t f = 0; f < got.fields().size(); ++f) EXPECT_EQ(got.fields()[f].values, want.fields()[f].values);
  }
}

// Issue #58: a format is a file that makes its entry and a row in the table
// (src/io/formats.cpp). This one is added at run time: every way in and out
// of a file goes through it with no other change.
namespace {
struct dummy_pieces final : ced::io::detail::piece_writer {
  void write(std::ostream& out, const ced::point_cloud& chunk) override {
    for (std::size_t i = 0; i < chunk.size(); ++i) {
      const auto p = chunk.position(i);
      out << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
    }
  }
};

ced::io::detail::format_entry dummy_entry() {
  using namespace ced::io;
  detail::format_entry e;
  e.id = static_cast<file_format>(100);
  e.name = "dummy";
  e.extensions = {"dmy"};
  e.read = [](const std::string& path, const read_options&, read_report& r) {
    std::ifstream in(path);
    std::string magic;
    std::size_t n = 0;
    if (!(in >> magic >> n) || magic != "dummy") throw io_error(path + ": not a dummy file");
    std::vector<float> xyz(3 * n);
    for (float& v : xyz)
      if (!(in >> v)) throw io_error(path + ": truncated");
    ced::point_cloud c;
    for (std::size_t i = 0; i < n; ++i) c.push_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    r.details = "DUMMY";
    return c;
  };
  e.write = [](std::ostream& out, const ced::point_cloud& c, const las_write_options*) {
    out << "dummy " << c.size() << '\n';
    dummy_pieces().write(out, c);
  };
  e.pieces = [](std::ostream& out, const ced::point_cloud&, std::uint64_t n) {
    out << "dummy " << n << '\n';
    return std::unique_ptr<detail::piece_writer>(new dummy_pieces);
  };
  return e;  // no streaming reader: open_point_stream() reads the file whole
}
}  // namespace

TEST(Formats, AFormatIsAnEntryInTheTable) {
  using namespace ced::io;
  detail::add_format(dummy_entry());
  EXPECT_EQ(parse_format("dummy"), static_cast<file_format>(100));
  EXPECT_EQ(format_name(static_cast<file_format>(100)), "dummy");
  EXPECT_EQ(format_of("a/B.DMY"), static_cast<file_format>(100));
  EXPECT_THROW(detail::add_format(dummy_entry()), std::invalid_argument);
  try {
    format_of("x.foo");
    ADD_FAILURE() << "x.foo has a format";
  } catch (const io_error& e) {
    EXPECT_NE(std::string(e.what()).find(".dmy"), std::string::npos) << e.what();
  }

  const ced::point_cloud cloud = ced_test::make_room(500, 3);
  const std::string path = ced_test::temp_file("c.dmy");
  write_cloud(path, cloud);
  read_report report;
  const ced::point_cloud back = read_cloud(path, {}, &report);
  EXPECT_EQ(report.format, static_cast<file_format>(100));
  EXPECT_EQ(report.details, "DUMMY");
  ASSERT_EQ(back.size(), cloud.size());

  std::ostringstream whole, pieces;
  write_cloud(whole, back, static_cast<file_format>(100));
  cloud_writer w(pieces, back, back.size(), static_cast<file_format>(100));
  w.write(back);
  w.finish();
  EXPECT_EQ(pieces.str(), whole.str());

  auto s = open_point_stream(path);
  ced::point_cloud chunk;
  EXPECT_EQ(s->read(1 << 20, s->origin(), chunk), cloud.size());
  EXPECT_EQ(s->details(), "DUMMY");
}
