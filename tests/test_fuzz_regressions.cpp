// SPDX-License-Identifier: MIT
// Replays the fuzzing seed corpora (tests/fuzz/corpus/<target>/) and the
// inputs that once crashed a fuzzer (tests/fuzz/regressions/<target>/)
// through the same entry points as the libFuzzer targets in tests/fuzz: each
// input must be read or rejected with io_error / std::invalid_argument. A
// crash, a sanitizer report or any other exception fails the test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/csv.hpp"
#include "ced/io/las.hpp"
#include "ced/io/pcd.hpp"
#include "ced/io/ply.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path k_fuzz_dir = fs::path(CED_TEST_DATA_DIR) / ".." / "fuzz";

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Every regular file under corpus/<target> and regressions/<target>, sorted.
std::vector<fs::path> inputs(const std::string& target) {
  std::vector<fs::path> files;
  for (const char* kind : {"corpus", "regressions"}) {
    const fs::path dir = k_fuzz_dir / kind / target;
    if (!fs::is_directory(dir)) continue;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// Feeds each input to `read`; it must return or throw io_error/invalid_argument.
void replay(const std::string& target, const std::function<void(std::string_view)>& read) {
  const auto files = inputs(target);
  ASSERT_FALSE(files.empty()) << "no inputs for '" << target << "' under " << k_fuzz_dir;
  for (const auto& f : files) {
    SCOPED_TRACE(f.string());
    const std::string bytes = read_all(f);
    try {
      read(bytes);
    } catch (const ced::io::io_error&) {
    } catch (const std::invalid_argument&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << "unexpected exception: " << e.what();
    } catch (...) {
      ADD_FAILURE() << "unexpected non-standard exception";
    }
  }
}

}  // namespace

TEST(fuzz_regressions, ply) {
  replay("ply", [](std::string_view bytes) {
    std::istringstream in{std::string(bytes)};
    (void)ced::io::read_ply(in, "fuzz.ply").size();
  });
}

TEST(fuzz_regressions, pcd) {
  replay("pcd", [](std::string_view bytes) { (void)ced::io::read_pcd_buffer(bytes, "fuzz.pcd").size(); });
  // The LZF decoder on its own, as fuzz_pcd drives it.
  replay("pcd", [](std::string_view bytes) {
    if (bytes.size() < 2) return;
    const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
    std::size_t out_size = (std::size_t(d[0]) << 8 | std::size_t(d[1])) * 16;
    out_size = std::min(out_size, std::size_t(1) << 20);
    (void)ced::io::lzf_decompress(bytes.substr(2), out_size, "fuzz.lzf").size();
  });
}

TEST(fuzz_regressions, las) {
  replay("las", [](std::string_view bytes) {
    ced::io::las_read_info info;
    (void)ced::io::read_las_buffer(bytes, "fuzz.las", &info).size();
  });
}

TEST(fuzz_regressions, csv) {
  replay("csv", [](std::string_view bytes) { (void)ced::io::read_csv_buffer(bytes, "fuzz.csv").size(); });
}

TEST(fuzz_regressions, spec) {
  ced::point_cloud cloud;
  for (int i = 0; i < 20; ++i) cloud.push_back(0.01f * float(i % 5), 0.01f * float(i / 5), 0.0f);
  std::vector<double> v(20);
  for (int i = 0; i < 20; ++i) v[std::size_t(i)] = i * 7 % 256;
  for (const char* name : {"red", "green", "blue", "intensity", "nir", "a"})
    cloud.add_field(name, ced::scalar_type::uint8, v);
  replay("spec", [&](std::string_view bytes) {
    const auto m = ced::make_modality(bytes);
    ced::detect_params p;
    p.threads = 1;
    (void)ced::detect(cloud, p, {m});
  });
}

// Inputs too large to keep as files: headers naming more fields than the
// readers accept (each would cost quadratic time to turn into cloud fields).
TEST(fuzz_regressions, field_count_limits) {
  std::string ply = "ply\nformat ascii 1.0\nelement vertex 0\n";
  for (int i = 0; i < 5000; ++i) ply += "property uchar p" + std::to_string(i) + "\n";
  ply += "property float x\nproperty float y\nproperty float z\nend_header\n";
  std::istringstream ply_in(ply);
  EXPECT_THROW(ced::io::read_ply(ply_in, "props.ply"), ced::io::io_error);

  std::string elements = "ply\nformat ascii 1.0\n";
  for (int i = 0; i < 5000; ++i) elements += "element e" + std::to_string(i) + " 0\n";
  elements += "element vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  std::istringstream elements_in(elements);
  EXPECT_THROW(ced::io::read_ply(elements_in, "elements.ply"), ced::io::io_error);

  const std::string pcd = "FIELDS x y z a\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 4094\nPOINTS 0\nDATA binary\n";
  EXPECT_THROW(ced::io::read_pcd_buffer(pcd, "count.pcd"), ced::io::io_error);

  std::string csv = "x,y,z";
  for (int i = 0; i < 5000; ++i) csv += ",c" + std::to_string(i);
  csv += "\n";
  EXPECT_THROW(ced::io::read_csv_buffer(csv, "wide.csv"), ced::io::io_error);
}
