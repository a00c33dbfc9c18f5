// SPDX-License-Identifier: MIT
// Benchmarks of the readers and writers: each reads (or writes) one file of
// its format, warm from the page cache, and reports bytes per second of the
// file. The files are generated once, in a temporary directory removed at
// exit: a LAS 1.2 point format 3 file of 2 M points (68 MB), and a cloud of
// 2.5 M points with xyz, rgb and normals (about 68 MB) as binary PLY, binary
// and binary_compressed PCD; 500 k of those points as CSV, ascii PLY and ascii PCD.
// LAZ: 20 copies of the real Autzen LiDAR sample (tests/data/autzen_trim.las),
// 2.2 M points, compressed by ced's LAZ writer into chunks of 50,000 points
// (the bytes LASzip writes), beside the same points as LAS.
//
//   build/bin/bench_io [benchmark flags, e.g. --benchmark_filter=LAS]
#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/stream.hpp"
#include "io/laz/types.hpp"
#include "io/base/scalar_io.hpp"

namespace {

namespace fs = std::filesystem;

/// The temporary directory of the files, removed at exit.
struct data_dir {
  fs::path path;
  data_dir() {
    path = fs::temp_directory_path() / ("ced_bench_io_" + std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~data_dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

data_dir& dir() {
  static data_dir d;
  return d;
}

/// n random points in a 100 m cube with, when `las`, the fields of LAS point
/// format 3 (and a georeferenced origin); else uchar red/green/blue and float
/// normal_x/y/z.
ced::point_cloud make_cloud(std::size_t n, bool las) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ced::point_cloud c;
  c.set_origin(las ? std::array<double, 3>{500000.0, 4000000.0, 100.0} : std::array<double, 3>{0, 0, 0});
  c.resize(n);
  float* p = c.positions().data();
  for (std::size_t i = 0; i < 3 * n; ++i) p[i] = static_cast<float>(u(rng) * 100.0);
  const auto column_of = [&](double lo, double hi) {
    std::vector<double> v(n);
    for (double& x : v) x = lo + u(rng) * (hi - lo);
    return v;
  };
  if (las) {
    c.add_field("intensity", ced::scalar_type::uint16, column_of(0, 65535));
    c.add_field("return_number", ced::scalar_type::uint8, column_of(1, 3));
    c.add_field("number_of_returns", ced::scalar_type::uint8, column_of(3, 3));
    c.add_field("classification", ced::scalar_type::uint8, column_of(0, 31));
    c.add_field("gps_time", ced::scalar_type::float64, column_of(0, 1e6));
    for (const char* name : {"red", "green", "blue"}) c.add_field(name, ced::scalar_type::uint16, column_of(0, 65535));
  } else {
    for (const char* name : {"red", "green", "blue"}) c.add_field(name, ced::scalar_type::uint8, column_of(0, 255));
    for (const char* name : {"normal_x", "normal_y", "normal_z"})
      c.add_field(name, ced::scalar_type::float32, column_of(-1, 1));
  }
  return c;
}

const ced::point_cloud& las_cloud() {
  static const ced::point_cloud c = make_cloud(2'000'000, true);
  return c;
}
const ced::point_cloud& rgbn_cloud() {
  static const ced::point_cloud c = make_cloud(2'500'000, false);
  return c;
}

/// The file `name`, written once by write(path).
template <class Write>
const std::string& input(const std::string& name, Write&& write) {
  static std::map<std::string, std::string> made;
  auto it = made.find(name);
  if (it == made.end()) {
    const std::string path = dir().file(name);
    write(path);
    it = made.emplace(name, path).first;
  }
  return it->second;
}

const std::string& las_file() {
  return input("pf3.las", [](const std::string& p) {
    ced::io::las_write_options o;
    o.version_minor = 2;
    ced::io::write_las(p, las_cloud(), o);
  });
}
const std::string& ply_file() {
  return input("rgbn.ply", [](const std::string& p) {
    ced::io::write_ply(p, rgbn_cloud(), ced::io::ply_format::binary_little_endian);
  });
}
const std::string& pcd_file() {
  return input("rgbn.pcd",
               [](const std::string& p) { ced::io::write_pcd(p, rgbn_cloud(), ced::io::pcd_format::binary); });
}
const std::string& pcdc_file() {
  return input("rgbn_compressed.pcd", [](const std::string& p) {
    ced::io::write_pcd(p, rgbn_cloud(), ced::io::pcd_format::binary_compressed);
  });
}
/// Every fifth point of the xyz+rgb+normals cloud (500 k points), for the text formats.
ced::point_cloud text_cloud() {
  ced::point_cloud c = rgbn_cloud();
  std::vector<std::uint8_t> keep(c.size(), 0);
  for (std::size_t i = 0; i < keep.size(); i += 5) keep[i] = 1;
  c.filter(keep);
  return c;
}
const std::string& csv_file() {
  return input("rgbn.csv", [](const std::string& p) { ced::io::write_csv(p, text_cloud()); });
}
const std::string& ascii_pcd_file() {
  return input("rgbn_ascii.pcd",
               [](const std::string& p) { ced::io::write_pcd(p, text_cloud(), ced::io::pcd_format::ascii); });
}
const std::string& ascii_ply_file() {
  return input("rgbn_ascii.ply",
               [](const std::string& p) { ced::io::write_ply(p, text_cloud(), ced::io::ply_format::ascii); });
}

/// 20 copies of the Autzen sample side by side in x, each 1,000 s later in
/// GPS time, as LAS 1.2 point format 3 bytes (2.2 M points, 75 MB).
const std::string& autzen20_las_bytes() {
  static const std::string bytes = [] {
    std::ifstream in(std::string(CED_TEST_DATA_DIR) + "/autzen_trim.las", std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string one = ss.str();
    using ced::io::detail::load_le;
    using ced::io::detail::store_le;
    const auto* d = reinterpret_cast<const unsigned char*>(one.data());
    const std::size_t offset = load_le<std::uint32_t>(d + 96), n = load_le<std::uint32_t>(d + 107), stride = 34;
    std::string out = one.substr(0, offset);
    auto* h = reinterpret_cast<unsigned char*>(out.data());
    store_le<std::uint32_t>(h + 107, static_cast<std::uint32_t>(20 * n));
    const std::int32_t span = 200000;  // raw units, wider than the sample
    for (int copy = 0; copy < 20; ++copy)
      for (std::size_t i = 0; i < n; ++i) {
        std::string r = one.substr(offset + i * stride, stride);
        auto* p = reinterpret_cast<unsigned char*>(r.data());
        store_le<std::int32_t>(p, load_le<std::int32_t>(p) + copy * span);
        store_le<double>(p + 20, load_le<double>(p + 20) + 1000.0 * copy);
        out += r;
      }
    return out;
  }();
  return bytes;
}
const std::string& autzen20_las() {
  return input("autzen20.las",
               [](const std::string& p) { std::ofstream(p, std::ios::binary) << autzen20_las_bytes(); });
}
const std::string& autzen20_laz() {
  return input("autzen20.laz", [](const std::string& p) {
    std::ofstream(p, std::ios::binary) << ced::io::detail::laz_from_las(autzen20_las_bytes(), "autzen20.las");
  });
}

/// autzen20 as LAS 1.4 (point format 7, as ced writes it), then as COPC.
const std::string& autzen20_las14_bytes() {
  static const std::string bytes = [] {
    std::ostringstream out;
    ced::io::write_las(out, ced::io::read_cloud(autzen20_las()));
    return out.str();
  }();
  return bytes;
}
const std::string& autzen20_copc() {
  return input("autzen20.copc.laz", [](const std::string& p) {
    std::ofstream(p, std::ios::binary) << ced::io::detail::copc_from_las(autzen20_las14_bytes(), "autzen20.las");
  });
}

/// Reads `path` with read_cloud() on each iteration.
void read_file(benchmark::State& state, const std::string& path, const ced::io::read_options& options = {}) {
  const auto bytes = static_cast<std::int64_t>(fs::file_size(path));
  std::size_t points = 0;
  for (auto _ : state) {
    const ced::point_cloud c = ced::io::read_cloud(path, options);
    points = c.size();
    benchmark::DoNotOptimize(c.positions().data());
  }
  state.SetBytesProcessed(state.iterations() * bytes);
  state.counters["points"] = static_cast<double>(points);
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(points) * static_cast<double>(state.iterations()),
                                                  benchmark::Counter::kIsRate);
}

/// Reads `path` through open_point_stream() in chunks of 1 M points, a whole
/// pass each iteration (the first pass, as a tiled run makes it).
void stream_file(benchmark::State& state, const std::string& path) {
  const auto bytes = static_cast<std::int64_t>(fs::file_size(path));
  for (auto _ : state) {
    auto s = ced::io::open_point_stream(path);
    ced::point_cloud chunk;
    while (s->read(1'000'000, {0, 0, 0}, chunk) > 0) benchmark::DoNotOptimize(chunk.positions().data());
  }
  state.SetBytesProcessed(state.iterations() * bytes);
}

/// Writes `cloud` to `name` with write(path, cloud) on each iteration.
template <class Write>
void write_file(benchmark::State& state, const std::string& name, const ced::point_cloud& cloud, Write&& write) {
  const std::string path = dir().file(name);
  for (auto _ : state) write(path, cloud);
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(fs::file_size(path)));
  fs::remove(path);
}

void BM_read_las(benchmark::State& s) { read_file(s, las_file()); }
void BM_read_las_xyz_intensity(benchmark::State& s) {
  ced::io::read_options o;
  o.fields = ced::field_selection::only({"intensity"});
  read_file(s, las_file(), o);
}
void BM_read_ply(benchmark::State& s) { read_file(s, ply_file()); }
void BM_read_ply_xyz_rgb(benchmark::State& s) {
  ced::io::read_options o;
  o.fields = ced::field_selection::only(ced::rgb_field_names());
  read_file(s, ply_file(), o);
}
void BM_read_pcd(benchmark::State& s) { read_file(s, pcd_file()); }
void BM_read_pcd_compressed(benchmark::State& s) { read_file(s, pcdc_file()); }
void BM_read_csv(benchmark::State& s) { read_file(s, csv_file()); }
void BM_read_ply_ascii(benchmark::State& s) { read_file(s, ascii_ply_file()); }
void BM_read_pcd_ascii(benchmark::State& s) { read_file(s, ascii_pcd_file()); }
void BM_stream_las(benchmark::State& s) { stream_file(s, las_file()); }
void BM_stream_ply(benchmark::State& s) { stream_file(s, ply_file()); }
void BM_stream_pcd(benchmark::State& s) { stream_file(s, pcd_file()); }

void BM_read_laz(benchmark::State& s) { read_file(s, autzen20_laz()); }
void BM_read_laz_as_las(benchmark::State& s) { read_file(s, autzen20_las()); }
void BM_stream_laz(benchmark::State& s) { stream_file(s, autzen20_laz()); }
/// The LAZ writer alone (in memory): the 2.2 M records coded in chunks in parallel.
void BM_compress_laz(benchmark::State& s) {
  const std::string& las = autzen20_las_bytes();
  std::size_t out = 0;
  for (auto _ : s) out = ced::io::detail::laz_from_las(las, "autzen20.las").size();
  s.SetBytesProcessed(s.iterations() * static_cast<std::int64_t>(las.size()));
  s.counters["laz_bytes"] = static_cast<double>(out);
}

void BM_read_copc(benchmark::State& s) { read_file(s, autzen20_copc()); }
/// What ced6d reads: positions and colour, the layers of the other fields skipped.
void BM_read_copc_xyz_rgb(benchmark::State& s) {
  ced::io::read_options o;
  o.fields = ced::field_selection::only(ced::rgb_field_names());
  read_file(s, autzen20_copc(), o);
}
/// The COPC writer alone (in memory): octree, then a layered chunk a node, in parallel.
void BM_compress_copc(benchmark::State& s) {
  const std::string& las = autzen20_las14_bytes();
  std::size_t out = 0;
  for (auto _ : s) out = ced::io::detail::copc_from_las(las, "autzen20.las").size();
  s.SetBytesProcessed(s.iterations() * static_cast<std::int64_t>(las.size()));
  s.counters["copc_bytes"] = static_cast<double>(out);
}

void BM_write_las(benchmark::State& s) {
  write_file(s, "out.las", las_cloud(), [](const std::string& p, const ced::point_cloud& c) {
    ced::io::las_write_options o;
    o.version_minor = 2;
    ced::io::write_las(p, c, o);
  });
}
void BM_write_ply(benchmark::State& s) {
  write_file(s, "out.ply", rgbn_cloud(), [](const std::string& p, const ced::point_cloud& c) {
    ced::io::write_ply(p, c, ced::io::ply_format::binary_little_endian);
  });
}
void BM_write_pcd(benchmark::State& s) {
  write_file(s, "out.pcd", rgbn_cloud(), [](const std::string& p, const ced::point_cloud& c) {
    ced::io::write_pcd(p, c, ced::io::pcd_format::binary);
  });
}
void BM_write_pcd_compressed(benchmark::State& s) {
  write_file(s, "out_c.pcd", rgbn_cloud(), [](const std::string& p, const ced::point_cloud& c) {
    ced::io::write_pcd(p, c, ced::io::pcd_format::binary_compressed);
  });
}

/// The text writers, on the 500 k points of the text readers.
const ced::point_cloud& text_cloud_once() {
  static const ced::point_cloud c = text_cloud();
  return c;
}
void BM_write_csv(benchmark::State& s) {
  write_file(s, "out.csv", text_cloud_once(),
             [](const std::string& p, const ced::point_cloud& c) { ced::io::write_csv(p, c); });
}
void BM_write_ply_ascii(benchmark::State& s) {
  write_file(s, "out_a.ply", text_cloud_once(), [](const std::string& p, const ced::point_cloud& c) {
    ced::io::write_ply(p, c, ced::io::ply_format::ascii);
  });
}
void BM_write_pcd_ascii(benchmark::State& s) {
  write_file(s, "out_a.pcd", text_cloud_once(), [](const std::string& p, const ced::point_cloud& c) {
    ced::io::write_pcd(p, c, ced::io::pcd_format::ascii);
  });
}

}  // namespace

BENCHMARK(BM_read_las)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_las_xyz_intensity)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_ply)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_ply_xyz_rgb)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_pcd)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_pcd_compressed)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_csv)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_ply_ascii)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_pcd_ascii)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_laz)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_laz_as_las)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_stream_laz)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_compress_laz)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_copc)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_read_copc_xyz_rgb)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_compress_copc)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_stream_las)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_stream_ply)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_stream_pcd)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_las)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_ply)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_pcd)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_pcd_compressed)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_csv)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_ply_ascii)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_write_pcd_ascii)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
