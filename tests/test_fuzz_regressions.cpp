// SPDX-License-Identifier: MIT
// Replays the fuzzing seed corpora (tests/fuzz/corpus/<target>/) and the
// inputs that once crashed a fuzzer (tests/fuzz/regressions/<target>/)
// through the same entry points as the libFuzzer targets in tests/fuzz: each
// input must be read or rejected with io_error / std::invalid_argument. A
// crash, a sanitizer report or any other exception fails the test.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
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
#include "fuzz/lzf_entry.hpp"
#include "fuzz/rgbd_entry.hpp"

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

TEST(fuzz_regressions, laz) {
  replay("laz", [](std::string_view bytes) {
    ced::io::las_read_info info;
    (void)ced::io::read_las_buffer(bytes, "fuzz.laz", &info).size();
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

TEST(fuzz_regressions, rgbd) { replay("rgbd", ced_fuzz::rgbd_one); }

TEST(fuzz_regressions, lzf) {
  replay("lzf", [](std::string_view bytes) { EXPECT_EQ(ced_fuzz::lzf_one(bytes), ""); });
}

// Inputs too large to keep as files: headers naming more fields than the
// readers accept (each would cost quadratic time to turn into cloud fields).
TEST(fuzz_regressions, field_count_limits) {
  // Thousands of fields are read (the cloud's name index keeps this linear:
  // these once took seconds to minutes, or were refused above 4 096);
  // more than 65 536 are refused.
  auto ply_props = [](int n) {
    std::string ply = "ply\nformat ascii 1.0\nelement vertex 1\n";
    for (int i = 0; i < n; ++i) ply += "property uchar p" + std::to_string(i) + "\n";
    ply += "property float x\nproperty float y\nproperty float z\nend_header\n";
    for (int i = 0; i < n; ++i) ply += "1 ";
    return ply + "0 0 0\n";
  };
  std::istringstream ply_in(ply_props(20000));
  EXPECT_EQ(ced::io::read_ply(ply_in, "props.ply").fields().size(), 20000u);
  std::istringstream ply_big(ply_props(70000));
  EXPECT_THROW(ced::io::read_ply(ply_big, "props.ply"), ced::io::io_error);

  auto ply_elements = [](int n) {
    std::string e = "ply\nformat ascii 1.0\n";
    for (int i = 0; i < n; ++i) e += "element e" + std::to_string(i) + " 0\n";
    return e + "element vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  };
  std::istringstream elements_in(ply_elements(20000));
  EXPECT_NO_THROW(ced::io::read_ply(elements_in, "elements.ply"));
  std::istringstream elements_big(ply_elements(70000));
  EXPECT_THROW(ced::io::read_ply(elements_big, "elements.ply"), ced::io::io_error);

  // The stored regression input (COUNT 65533 on one field) reads at once.
  const auto pcd = [](int count) {
    return "FIELDS x y z a\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 " + std::to_string(count) +
           "\nPOINTS 0\nDATA binary\n";
  };
  EXPECT_EQ(ced::io::read_pcd_buffer(pcd(65533), "count.pcd").fields().size(), 65533u);
  EXPECT_THROW(ced::io::read_pcd_buffer(pcd(65534), "count.pcd"), ced::io::io_error);
  // As many fields by name: their duplicate check is linear too (#25: it
  // compared each name with all before it, 7 s for 65 533 names).
  const auto pcd_names = [](int n, const std::string& extra) {
    std::string names = "FIELDS x y z", sizes = "SIZE 4 4 4", types = "TYPE F F F";
    for (int i = 0; i < n; ++i) {
      names += " f" + std::to_string(i);
      sizes += " 1";
      types += " U";
    }
    return names + extra + "\n" + sizes + (extra.empty() ? "" : " 1") + "\n" + types + (extra.empty() ? "" : " U") +
           "\nPOINTS 0\nDATA binary\n";
  };
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(ced::io::read_pcd_buffer(pcd_names(65533, ""), "names.pcd").fields().size(), 65533u);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  EXPECT_THROW(ced::io::read_pcd_buffer(pcd_names(20000, " f17"), "dup.pcd"), ced::io::io_error);

  auto csv = [](int n) {
    std::string c = "x,y,z";
    for (int i = 0; i < n; ++i) c += ",c" + std::to_string(i);
    c += "\n0,0,0";
    for (int i = 0; i < n; ++i) c += ",1";
    return c + "\n";
  };
  EXPECT_EQ(ced::io::read_csv_buffer(csv(20000), "wide.csv").fields().size(), 20000u);
  EXPECT_THROW(ced::io::read_csv_buffer(csv(70000), "wide.csv"), ced::io::io_error);
  // Duplicates are still found among many.
  std::string dup = "x,y,z";
  for (int i = 0; i < 20000; ++i) dup += ",c" + std::to_string(i);
  dup += ",c17\n";
  EXPECT_THROW(ced::io::read_csv_buffer(dup, "dup.csv"), ced::io::io_error);
}
