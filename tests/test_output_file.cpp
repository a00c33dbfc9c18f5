// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "ced/io/output_file.hpp"

namespace fs = std::filesystem;
using ced::io::atomic_output_file;
using ced::io::io_error;

namespace {

fs::path base_dir() { return fs::path(::testing::TempDir()) / ("ced_test_output_file_" + std::to_string(::getpid())); }

struct remove_base_dir : ::testing::Environment {
  void TearDown() override { fs::remove_all(base_dir()); }
};
const auto* const g_cleanup = ::testing::AddGlobalTestEnvironment(new remove_base_dir);

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = base_dir() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::size_t count_entries(const fs::path& dir) {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const io_error& e) {
    return e.what();
  }
  return "<no io_error thrown>";
}

}  // namespace

TEST(AtomicOutputFile, CommitWritesTheFileAndLeavesNoTemporary) {
  const fs::path dir = fresh_dir("commit");
  const std::string path = (dir / "out.txt").string();
  {
    atomic_output_file f(path);
    EXPECT_EQ(fs::path(f.temp_path()).parent_path(), dir);
    EXPECT_EQ(fs::path(f.temp_path()).filename().string().rfind(".out.txt.tmp.", 0), 0u) << f.temp_path();
    f.stream() << "hello\n";
    EXPECT_FALSE(fs::exists(path));
    f.commit();
  }
  EXPECT_EQ(slurp(path), "hello\n");
  EXPECT_EQ(count_entries(dir), 1u);
}

TEST(AtomicOutputFile, WithoutCommitNothingIsLeft) {
  const fs::path dir = fresh_dir("nocommit");
  {
    atomic_output_file f((dir / "out.txt").string());
    f.stream() << "partial";
  }
  EXPECT_EQ(count_entries(dir), 0u);
}

TEST(AtomicOutputFile, FailureBeforeCommitKeepsTheExistingFile) {
  const fs::path dir = fresh_dir("keep");
  const std::string path = (dir / "out.txt").string();
  ced::io::write_text_file_atomic(path, "old contents");
  EXPECT_THROW(
      {
        atomic_output_file f(path);
        f.stream() << "new partial contents";
        throw std::runtime_error("simulated failure");
      },
      std::runtime_error);
  EXPECT_EQ(slurp(path), "old contents");
  EXPECT_EQ(count_entries(dir), 1u);
}

TEST(AtomicOutputFile, CommitReplacesTheExistingFile) {
  const fs::path dir = fresh_dir("replace");
  const std::string path = (dir / "out.bin").string();
  ced::io::write_text_file_atomic(path, "old");
  const std::string binary("a\0b\r\nc", 6);
  ced::io::write_text_file_atomic(path, binary);
  EXPECT_EQ(slurp(path), binary);
  EXPECT_EQ(count_entries(dir), 1u);
}

TEST(AtomicOutputFile, MissingDirectoryIsAnError) {
  const fs::path dir = fresh_dir("missing");
  const std::string path = (dir / "no_such_dir" / "out.txt").string();
  const std::string msg = error_of([&] { atomic_output_file f(path); });
  EXPECT_NE(msg.find("does not exist"), std::string::npos) << msg;
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
}

TEST(AtomicOutputFile, DirectoryPathIsAnError) {
  const fs::path dir = fresh_dir("isdir");
  const std::string msg = error_of([&] { atomic_output_file f(dir.string()); });
  EXPECT_NE(msg.find("is a directory"), std::string::npos) << msg;
  const std::string empty = error_of([&] { atomic_output_file f(""); });
  EXPECT_NE(empty.find("empty path"), std::string::npos) << empty;
}

TEST(AtomicOutputFile, ParentThatIsAFileIsAnError) {
  const fs::path dir = fresh_dir("parentfile");
  ced::io::write_text_file_atomic((dir / "file").string(), "x");
  const std::string msg = error_of([&] { atomic_output_file f((dir / "file" / "out.txt").string()); });
  EXPECT_NE(msg.find("is not a directory"), std::string::npos) << msg;
}

TEST(AtomicOutputFile, UnwritableDirectoryIsAnError) {
  if (::geteuid() == 0) GTEST_SKIP() << "running as root: permissions are not enforced";
  const fs::path dir = fresh_dir("readonly");
  ASSERT_EQ(::chmod(dir.c_str(), 0555), 0);
  const std::string path = (dir / "out.txt").string();
  const std::string msg = error_of([&] { atomic_output_file f(path); });
  ::chmod(dir.c_str(), 0755);
  EXPECT_NE(msg.find("cannot create a file"), std::string::npos) << msg;
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
}

TEST(AtomicOutputFile, CommitTwiceIsAnError) {
  const fs::path dir = fresh_dir("twice");
  atomic_output_file f((dir / "out.txt").string());
  f.commit();
  EXPECT_THROW(f.commit(), io_error);
}
