// SPDX-License-Identifier: MIT
// Several files read as one cloud (ced/io/catalogue.hpp): the cloud a merged
// file gives, and the errors of mixed inputs (#61).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/catalogue.hpp"
#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "file_support.hpp"
#include "test_support.hpp"
#include "tiled_support.hpp"

namespace {

namespace fs = std::filesystem;
using ced_test::temp_file;

/// The points `idx` of `c`, in that order, at origin `origin`.
ced::point_cloud subset(const ced::point_cloud& c, const std::vector<std::size_t>& idx,
                        const std::array<double, 3>& origin) {
  ced::point_cloud out;
  out.set_origin(origin);
  for (std::size_t i : idx) {
    const float* p = c.position(i);
    out.push_back(static_cast<float>(double(p[0]) + c.origin()[0] - origin[0]),
                  static_cast<float>(double(p[1]) + c.origin()[1] - origin[1]),
                  static_cast<float>(double(p[2]) + c.origin()[2] - origin[2]));
  }
  for (const auto& f : c.fields()) {
    std::vector<double> v;
    for (std::size_t i : idx) v.push_back(f.values[i]);
    out.add_field(f.name, f.values.type(), v);
  }
  return out;
}

/// Writes `c` as LAS, LAZ or COPC (by the extension) with one scale and offset.
void write_las_like(const std::string& path, const ced::point_cloud& c, const std::array<double, 3>& offset,
                    const std::array<double, 3>& scale = {0.001, 0.001, 0.001}) {
  ced::io::las_write_options o;
  o.scale = scale;
  o.offset = offset;
  std::ofstream out(path, std::ios::binary);
  ced::io::write_cloud(out, c, ced::io::format_of(path), o);
  ASSERT_TRUE(out.good()) << path;
}

/// A georeferenced room cut into files at random borders along x, and one
/// more file of points taken from around both borders (its box overlaps
/// the others'): LAS, LAZ, COPC and LAS.
struct catalogue_fixture {
  std::vector<std::string> files;
  std::string merged;  // the same points, file after file, in one LAS file
};

catalogue_fixture make_catalogue(std::uint32_t seed, const std::string& stem) {
  ced::point_cloud room = ced_test::make_room(12000, seed);
  room.set_origin({512345.0, 4012345.0, 120.0});
  std::mt19937 rng(seed);
  float lo = 1e9f, hi = -1e9f;
  for (std::size_t i = 0; i < room.size(); ++i) {
    lo = std::min(lo, room.position(i)[0]);
    hi = std::max(hi, room.position(i)[0]);
  }
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float c1 = lo + (hi - lo) * (0.2f + 0.2f * u(rng)), c2 = lo + (hi - lo) * (0.55f + 0.25f * u(rng));
  const float margin = 0.1f * (hi - lo);
  std::vector<std::vector<std::size_t>> part(4);
  for (std::size_t i = 0; i < room.size(); ++i) {
    const float x = room.position(i)[0];
    const bool near_border = std::abs(x - c1) < margin || std::abs(x - c2) < margin;
    if (near_border && u(rng) < 0.3f)
      part[3].push_back(i);
    else
      part[x < c1 ? 0 : x < c2 ? 1 : 2].push_back(i);
  }
  const std::array<double, 3> offset = {512000.0, 4012000.0, 100.0};
  const char* ext[4] = {".las", ".laz", ".copc.laz", ".las"};
  catalogue_fixture f;
  for (std::size_t p = 0; p < 4; ++p) {
    f.files.push_back(temp_file(stem + "_part" + std::to_string(p) + ext[p]));
    write_las_like(f.files.back(), subset(room, part[p], room.origin()), offset);
  }
  // The merged file: each part as its file holds it (COPC orders its points
  // by node), file after file, on the same scale and offset.
  ced::point_cloud all;
  for (const auto& path : f.files) {
    const ced::point_cloud c = ced::io::read_cloud(path);
    std::vector<std::size_t> idx(c.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    const ced::point_cloud s = subset(c, idx, room.origin());
    if (all.empty()) {
      all = s;
      continue;
    }
    ced::point_cloud joined;
    joined.set_origin(room.origin());
    for (std::size_t i = 0; i < all.size(); ++i)
      joined.push_back(all.position(i)[0], all.position(i)[1], all.position(i)[2]);
    for (std::size_t i = 0; i < s.size(); ++i) joined.push_back(s.position(i)[0], s.position(i)[1], s.position(i)[2]);
    for (const auto& fd : all.fields()) {
      std::vector<double> v(fd.values.begin(), fd.values.end());
      for (double x : s.get_field(fd.name).values) v.push_back(x);
      joined.add_field(fd.name, fd.values.type(), v);
    }
    all = std::move(joined);
  }
  f.merged = temp_file(stem + "_merged.las");
  write_las_like(f.merged, all, offset);
  return f;
}

void expect_same_cloud(const ced::point_cloud& a, const ced::point_cloud& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.origin(), b.origin());
  EXPECT_TRUE(a.positions() == b.positions());
  ASSERT_EQ(a.fields().size(), b.fields().size());
  for (const auto& f : a.fields()) {
    const ced::field* g = b.find_field(f.name);
    ASSERT_NE(g, nullptr) << f.name;
    EXPECT_EQ(f.values.type(), g->values.type()) << f.name;
    EXPECT_TRUE(f.values == g->values) << f.name;
  }
}

}  // namespace

// LAS, LAZ and COPC files cut at random borders, one overlapping the others:
// the cloud and the keypoints of the merged file, with 1 and 2 threads, and
// each point's file and index.
TEST(Catalogue, TheFilesAreTheMergedCloud) {
  for (std::uint32_t seed : {3u, 11u}) {
    SCOPED_TRACE(seed);
    const auto fx = make_catalogue(seed, "cat" + std::to_string(seed));
    ced::io::catalogue_report rep;
    const ced::point_cloud cat = ced::io::read_catalogue(fx.files, {}, &rep);
    const ced::point_cloud merged = ced::io::read_cloud(fx.merged);
    expect_same_cloud(cat, merged);
    ASSERT_EQ(rep.first.size(), 5u);
    EXPECT_EQ(rep.first.back(), cat.size());
    for (std::size_t f = 0; f < 4; ++f) {
      const ced::point_cloud one = ced::io::read_cloud(fx.files[f]);
      ASSERT_EQ(rep.first[f + 1] - rep.first[f], one.size());
      const std::uint64_t mid = rep.first[f] + one.size() / 2;
      const auto [file, index] = rep.locate(mid);
      EXPECT_EQ(file, f);
      EXPECT_EQ(index, one.size() / 2);
      for (int k = 0; k < 3; ++k)  // the same point, to float rounding
        EXPECT_NEAR(double(cat.position(mid)[k]) + cat.origin()[k], double(one.position(index)[k]) + one.origin()[k],
                    1e-4);
    }
    for (unsigned threads : {1u, 2u}) {
      ced::detect_params p;
      p.radius = p.nms_radius = 0.05;
      p.threads = threads;
      const auto a = ced::detect(cat, p, ced::preset("ced6d"));
      const auto b = ced::detect(merged, p, ced::preset("ced6d"));
      EXPECT_EQ(a.keypoints, b.keypoints);
      EXPECT_GT(a.keypoints.size(), 20u);
    }
  }
}

// Files with different scales and offsets: each point where its own file
// puts it.
TEST(Catalogue, DifferentScalesAndOffsets) {
  ced::point_cloud room = ced_test::make_room(3000, 5);
  room.set_origin({300000.0, 5000000.0, 50.0});
  std::vector<std::size_t> a, b;
  for (std::size_t i = 0; i < room.size(); ++i) (i % 2 ? a : b).push_back(i);
  const std::string fa = temp_file("scales_a.las"), fb = temp_file("scales_b.laz");
  write_las_like(fa, subset(room, a, room.origin()), {300000.0, 5000000.0, 0.0}, {0.001, 0.001, 0.001});
  write_las_like(fb, subset(room, b, room.origin()), {299990.0, 4999990.0, 10.0}, {0.0005, 0.0025, 0.01});
  ced::io::catalogue_report rep;
  const ced::point_cloud cat = ced::io::read_catalogue({fa, fb}, {}, &rep);
  ASSERT_EQ(cat.size(), room.size());
  const double tol[3] = {0.0006, 0.0013, 0.0051};
  for (std::size_t g = 0; g < cat.size(); ++g) {
    const auto [f, i] = rep.locate(g);
    const std::size_t src = (f == 0 ? a : b)[i];
    for (int k = 0; k < 3; ++k)
      ASSERT_NEAR(double(cat.position(g)[k]) + cat.origin()[k], double(room.position(src)[k]) + room.origin()[k],
                  tol[k])
          << "point " << g;
  }
}

namespace {
std::string error_of(const std::vector<std::string>& inputs, const ced::io::read_options& o = {}) {
  try {
    ced::io::read_catalogue(ced::io::catalogue_files(inputs), o);
  } catch (const ced::io::io_error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// Folders (their point files, by name) and @lists (relative to the list,
// comments skipped) name the files.
TEST(Catalogue, FoldersAndLists) {
  const fs::path dir = fs::path(temp_file("catdir"));
  fs::create_directories(dir / "sub");
  ced::point_cloud c = ced_test::make_room(500, 2);
  ced::io::write_cloud((dir / "b.ply").string(), c);
  ced::io::write_cloud((dir / "a.ply").string(), c.empty() ? c : ced_test::make_room(400, 3));
  std::ofstream((dir / "notes.md").string()) << "not a cloud\n";
  ced::io::write_cloud((dir / "sub" / "c.ply").string(), ced_test::make_room(300, 4));
  const auto files = ced::io::catalogue_files({dir.string()});
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(fs::path(files[0]).filename(), "a.ply");
  EXPECT_EQ(fs::path(files[1]).filename(), "b.ply");

  const std::string list = (dir / "list.txt").string();
  std::ofstream(list) << "# tiles\n\nsub/c.ply\n  b.ply  \n";
  const auto listed = ced::io::catalogue_files({"@" + list});
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(fs::path(listed[0]).filename(), "c.ply");
  EXPECT_EQ(ced::io::read_catalogue(listed).size(), 800u);

  EXPECT_NE(error_of({(dir / "nothing_here").string()}).find("no such file or folder"), std::string::npos);
  EXPECT_NE(error_of({(dir / "sub" / "c.ply").string(), "@" + list}).find("named twice"), std::string::npos);
  fs::copy_file(dir / "b.ply", dir / "sub" / "b_copy.ply");
  const std::string dup = error_of({(dir / "b.ply").string(), (dir / "sub" / "b_copy.ply").string()});
  EXPECT_NE(dup.find("same bytes"), std::string::npos) << dup;
  const fs::path empty = dir / "empty";
  fs::create_directories(empty);
  EXPECT_NE(error_of({empty.string()}).find("no point files"), std::string::npos);
}

// Mixed inputs: a field some files lack, a field in two types, two
// coordinate systems: each an error naming the file.
TEST(Catalogue, MixedInputsAreNamedErrors) {
  ced::point_cloud with = ced_test::make_room(400, 8);
  ced::point_cloud without = ced_test::make_room(400, 9);
  ced::point_cloud slim;
  for (std::size_t i = 0; i < without.size(); ++i)
    slim.push_back(without.position(i)[0], without.position(i)[1], without.position(i)[2]);
  const std::string a = temp_file("mixed_a.ply"), b = temp_file("mixed_b.ply");
  ced::io::write_cloud(a, with);
  ced::io::write_cloud(b, slim);
  const std::string lacks = error_of({a, b});
  EXPECT_NE(lacks.find(b), std::string::npos) << lacks;
  EXPECT_NE(lacks.find("has no field"), std::string::npos) << lacks;
  // A run that needs only positions reads them.
  ced::io::read_options xyz_only;
  xyz_only.fields = ced::field_selection::only({});
  EXPECT_EQ(ced::io::read_catalogue({a, b}, xyz_only).size(), 800u);

  // A field in two types that hold each other's values becomes the wider;
  // two that do not (int8, uint8) are an error naming both.
  auto with_t = [&](ced::scalar_type type, double value, const std::string& name) {
    ced::point_cloud c = slim;
    c.add_field("t", type, std::vector<double>(slim.size(), value));
    ced::io::write_cloud(temp_file(name), c);
    return temp_file(name);
  };
  const std::string f32 = with_t(ced::scalar_type::float32, 0.5, "t_f32.ply");
  const std::string f64 = with_t(ced::scalar_type::float64, 0.1, "t_f64.ply");
  const ced::point_cloud widened = ced::io::read_catalogue({f32, f64});
  ASSERT_EQ(widened.get_field("t").values.type(), ced::scalar_type::float64);
  EXPECT_EQ(widened.get_field("t").values[0], 0.5);
  EXPECT_EQ(widened.get_field("t").values[400], 0.1);
  const std::string i8 = with_t(ced::scalar_type::int8, -3, "t_i8.ply");
  const std::string u8 = with_t(ced::scalar_type::uint8, 200, "t_u8.ply");
  const std::string types = error_of({i8, u8});
  EXPECT_NE(types.find("uint8"), std::string::npos) << types;
  EXPECT_NE(types.find(u8), std::string::npos) << types;
  EXPECT_NE(types.find(i8), std::string::npos) << types;

  // 8-bit colour beside 16-bit becomes 16-bit, the same fraction of full scale.
  ced::point_cloud c16 = slim;
  for (const char* ch : {"red", "green", "blue"}) {
    std::vector<double> v(with.get_field(ch).values.begin(), with.get_field(ch).values.end());
    for (double& x : v) x *= 257;
    c16.add_field(ch, ced::scalar_type::uint16, v);
  }
  ASSERT_EQ(with.get_field("red").values.type(), ced::scalar_type::uint8);
  ced::point_cloud c8 = slim;
  for (const char* ch : {"red", "green", "blue"}) c8.add_field(ch, with.get_field(ch).values);
  const std::string e8 = temp_file("rgb8.ply"), e16 = temp_file("rgb16.ply");
  ced::io::write_cloud(e8, c8);
  ced::io::write_cloud(e16, c16);
  const ced::point_cloud both = ced::io::read_catalogue({e8, e16});
  ASSERT_EQ(both.get_field("red").values.type(), ced::scalar_type::uint16);
  for (std::size_t i = 0; i < slim.size(); ++i) {
    ASSERT_EQ(both.get_field("green").values[i], with.get_field("green").values[i] * 257);
    ASSERT_EQ(both.get_field("green").values[i], both.get_field("green").values[slim.size() + i]);
  }

  const std::string crs = error_of({std::string(CED_TEST_DATA_DIR) + "/simple.las",
                                    std::string(CED_TEST_DATA_DIR) + "/file_with_both_wkt_and_geotiff_vlrs.las"});
  EXPECT_NE(crs.find("coordinate system"), std::string::npos) << crs;
}

// A folder or @LIST of LAS, LAZ and COPC files through the tiles: planned
// from the headers (run_tiled) and by passes (scan), a plan as JSON with its
// tiles one by one, 1 and 2 threads: the whole catalogue's keypoints, as
// global indices (file after file).
TEST(Catalogue, TilesEqualTheWholeCatalogue) {
  const auto fx = make_catalogue(17, "tiled");
  const std::string list = temp_file("tiled.list");
  {
    std::ofstream out(list);
    out << "# the parts\n";
    for (const auto& f : fx.files) out << fs::path(f).filename().string() << "\n";
  }
  const ced::point_cloud whole_cloud = ced::io::read_catalogue(fx.files);
  ced::tiled_request r;
  r.input = "@" + list;
  r.tile_size = 0.25;
  r.params.radius = r.params.nms_radius = 0.04;
  r.modalities = {"xyz:0.2", "rgb:0.1"};
  const auto whole = ced::detect(whole_cloud, r.params, ced_test::specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 20u);
  const std::vector<std::uint64_t> expected(whole.begin(), whole.end());
  for (bool scan : {false, true})
    for (unsigned threads : {1u, 2u}) {
      SCOPED_TRACE(std::string(scan ? "scan" : "header") + ", " + std::to_string(threads) + " thread(s)");
      r.scan = scan;
      r.params.threads = threads;
      ced::tiled_run_options o;
      o.work_dir = temp_file("tiled_work");
      ced::tile_plan used;
      EXPECT_EQ(ced::run_tiled(r, o, &used).index, expected);
      EXPECT_GT(used.tiles.size(), 4u);
    }
  r.scan = false;
  const ced::tile_plan plan = ced::tile_plan::from_json(ced::plan_tiles(r).to_json(), "plan.json");
  std::vector<ced::tile_part> parts;
  for (const ced::tile_entry& t : plan.tiles) parts.push_back(ced_test::detect_planned_tile(plan, t.id));
  EXPECT_EQ(ced::merge_parts(plan, std::move(parts)).index, expected);
}

namespace {

/// The tile cache filled in `shares` shares (as ced-mpi's ranks fill it,
/// here one after the other, the last first): the plan, and the keypoints
/// of its tiles merged.
std::vector<std::uint64_t> run_in_shares(const ced::tiled_request& r, unsigned shares, ced::tile_plan& plan) {
  ced::tiled_run_options o;
  o.work_dir = temp_file("shares_work");
  const std::string begun = ced::begin_cache_shares(r, o, shares, plan);
  EXPECT_FALSE(begun.empty());
  std::vector<std::string> learnt(shares);
  for (unsigned k = shares; k-- > 0;) learnt[k] = ced::fill_cache_share(begun, k, o);
  plan = ced::finish_cache_shares(begun, learnt, o);
  for (const ced::tile_entry& t : plan.tiles) ced::detect_cached_tile(plan, o.work_dir, t.id);
  const ced::tile_part merged = ced::finish_tiled(plan, o.work_dir);
  EXPECT_FALSE(fs::exists(o.work_dir));
  return merged.index;
}

/// Narrows the x bounds of a LAS file's header (LAS 1.2 to 1.4: max x at
/// byte 179, min x at 187) to their lower half: its points then lie outside.
void narrow_header(const std::string& path) {
  std::fstream f(path, std::ios::binary | std::ios::in | std::ios::out);
  double hi = 0, lo = 0;
  f.seekg(179);
  f.read(reinterpret_cast<char*>(&hi), 8);
  f.read(reinterpret_cast<char*>(&lo), 8);
  hi = lo + 0.5 * (hi - lo);
  f.seekp(179);
  f.write(reinterpret_cast<const char*>(&hi), 8);
  ASSERT_TRUE(f.good()) << path;
}

}  // namespace

// #61: the pass that fills the tile cache shared between processes, none
// reading the whole catalogue: the plan of one process (but for
// cache_shares) and the whole catalogue's keypoints, for any number of
// shares; and when a header belies its points, the passes of one process.
TEST(Catalogue, TheCacheFilledInSharesGivesTheWholeCatalogue) {
  const auto fx = make_catalogue(23, "shares");
  const std::string list = temp_file("shares.list");
  {
    std::ofstream out(list);
    for (const auto& f : fx.files) out << fs::path(f).filename().string() << "\n";
  }
  ced::tiled_request r;
  r.input = "@" + list;
  r.tile_size = 0.25;
  r.params.radius = r.params.nms_radius = 0.04;
  r.modalities = {"xyz:0.2", "rgb:0.1"};
  const auto whole = ced::detect(ced::io::read_catalogue(fx.files), r.params, ced_test::specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 20u);
  const std::vector<std::uint64_t> expected(whole.begin(), whole.end());
  ced::tiled_run_options o;
  o.work_dir = temp_file("shares_single_work");
  ced::tile_plan single;
  EXPECT_EQ(ced::run_tiled(r, o, &single).index, expected);
  for (unsigned shares : {2u, 3u, 7u}) {
    SCOPED_TRACE(std::to_string(shares) + " shares");
    ced::tile_plan plan;
    EXPECT_EQ(run_in_shares(r, shares, plan), expected);
    EXPECT_EQ(plan.cache_shares, shares);
    ASSERT_EQ(plan.tiles.size(), single.tiles.size());
    for (std::size_t t = 0; t < plan.tiles.size(); ++t) {
      EXPECT_EQ(plan.tiles[t].id, single.tiles[t].id);
      EXPECT_EQ(plan.tiles[t].core_points, single.tiles[t].core_points);
      EXPECT_EQ(plan.tiles[t].points, single.tiles[t].points);
    }
    ASSERT_EQ(plan.fields.size(), single.fields.size());
    for (std::size_t f = 0; f < plan.fields.size(); ++f) {
      EXPECT_EQ(plan.fields[f].name, single.fields[f].name);
      EXPECT_EQ(plan.fields[f].range.lo, single.fields[f].range.lo) << plan.fields[f].name;
      EXPECT_EQ(plan.fields[f].range.hi, single.fields[f].range.hi) << plan.fields[f].name;
    }
    plan.cache_shares = 1;
    EXPECT_EQ(plan.to_json(), single.to_json());
  }
  // One process: no shares, the plan and cache made as prepare_tiled() makes them.
  {
    ced::tile_plan plan;
    o.work_dir = temp_file("shares_one_work");
    EXPECT_TRUE(ced::begin_cache_shares(r, o, 1, plan).empty());
    EXPECT_EQ(plan.cache_shares, 1u);
    EXPECT_EQ(plan.tiles.size(), single.tiles.size());
    ced::remove_work_dir(o.work_dir);
  }
  // A header whose bounds miss its points: the shares' plan cannot stand,
  // and the first process plans and caches by passes.
  narrow_header(fx.files[2]);
  const auto lied = ced::detect(ced::io::read_catalogue(fx.files), r.params, ced_test::specs(r.modalities)).keypoints;
  ced::tile_plan plan;
  EXPECT_EQ(run_in_shares(r, 3, plan), std::vector<std::uint64_t>(lied.begin(), lied.end()));
  EXPECT_EQ(plan.cache_shares, 1u);
}

/// A georeferenced strip of ground (4 m by 0.9 m, bumps and a colour pattern)
/// cut across x at whole metres into LAS, LAZ, COPC and LAS files.
std::vector<std::string> make_strip(std::uint32_t seed, const std::string& stem) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.004f, 0.004f);
  std::vector<ced::point_cloud> parts(4);
  std::vector<std::vector<double>> red(4), green(4), blue(4);
  for (auto& p : parts) p.set_origin({512345.0, 4012345.0, 120.0});
  for (int i = 0; i < 200; ++i)
    for (int j = 0; j < 45; ++j) {
      const float x = 0.02f * float(i) + jitter(rng), y = 0.02f * float(j) + jitter(rng);
      const float z = 0.05f * std::sin(5.0f * x) * std::cos(7.0f * y) + (std::fmod(x, 0.5f) < 0.1f ? 0.03f : 0.0f);
      const std::size_t k = std::min<std::size_t>(3, std::size_t(x));
      parts[k].push_back(x, y, z);
      red[k].push_back(std::fmod(3.0f * x, 1.0f) < 0.5f ? 60000 : 5000);
      green[k].push_back(std::fmod(4.0f * y, 1.0f) < 0.5f ? 50000 : 9000);
      blue[k].push_back(20000);
    }
  const char* ext[4] = {".las", ".laz", ".copc.laz", ".las"};
  std::vector<std::string> files;
  for (std::size_t k = 0; k < 4; ++k) {
    parts[k].add_field("red", ced::scalar_type::uint16, red[k]);
    parts[k].add_field("green", ced::scalar_type::uint16, green[k]);
    parts[k].add_field("blue", ced::scalar_type::uint16, blue[k]);
    files.push_back(temp_file(stem + "_strip" + std::to_string(k) + ext[k]));
    write_las_like(files.back(), parts[k], {512000.0, 4012000.0, 100.0});
  }
  return files;
}

// #61: `ced plan` of a catalogue of LAS, LAZ and COPC files from their
// headers alone, when its tiles are large against the files (a tile then
// decodes the files its core and halo meet, the COPC file through its
// index): the whole catalogue's keypoints; a header that misses its points
// stops the tile that finds it. Small tiles are planned by passes.
TEST(Catalogue, APlanFromTheHeadersWhenTheTilesAreLarge) {
  const std::vector<std::string> files = make_strip(29, "headers");
  const std::string list = temp_file("headers.list");
  {
    std::ofstream out(list);
    for (const auto& f : files) out << fs::path(f).filename().string() << "\n";
  }
  ced::tiled_request r;
  r.input = "@" + list;
  r.params.radius = r.params.nms_radius = 0.05;
  r.modalities = {"xyz:0.2", "rgb:0.1"};
  const auto whole = ced::detect(ced::io::read_catalogue(files), r.params, ced_test::specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 20u);
  r.tile_size = 0.3;
  EXPECT_FALSE(ced::plan_tiles(r).indexed);  // each tile would decode most files: passes
  r.tile_size = 1.0;
  const ced::tile_plan plan = ced::tile_plan::from_json(ced::plan_tiles(r).to_json(), "plan.json");
  ASSERT_TRUE(plan.indexed);
  EXPECT_TRUE(plan.runs.empty());
  ASSERT_GT(plan.tiles.size(), 2u);
  std::vector<ced::tile_part> parts;
  for (const ced::tile_entry& t : plan.tiles) {
    const ced::tile_points pts = ced::read_tile(plan, t.id);
    EXPECT_TRUE(pts.indexed);
    EXPECT_LT(pts.decoded, 9000u);  // not every file
    parts.push_back(ced::detect_tile(plan, pts));
  }
  EXPECT_EQ(ced::merge_parts(plan, std::move(parts)).index, std::vector<std::uint64_t>(whole.begin(), whole.end()));
  // A header narrowed to half its points' x: the plan from the headers
  // still covers them (the next file's bounds do), and a tile that reads the
  // file stops.
  narrow_header(files[1 - 1]);
  const ced::tile_plan lied = ced::plan_tiles(r);
  ASSERT_TRUE(lied.indexed);
  bool stopped = false;
  for (const ced::tile_entry& t : lied.tiles) try {
      ced::read_tile(lied, t.id);
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("its file's header bounds"), std::string::npos) << e.what();
      stopped = true;
    }
  EXPECT_TRUE(stopped);
}
