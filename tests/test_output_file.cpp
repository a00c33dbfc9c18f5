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

// ---------------------------------------------------------------- what ced may write (issue #25)

namespace {
void write_file(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }
std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(SameFile, EverySpellingOfOneFile) {
  const fs::path dir = fresh_dir("same_file");
  fs::create_directories(dir / "sub");
  write_file(dir / "in.ply", "cloud");
  fs::create_symlink(dir / "in.ply", dir / "link.ply");
  fs::create_hard_link(dir / "in.ply", dir / "hard.ply");
  write_file(dir / "other.ply", "cloud");
  const std::string in = (dir / "in.ply").string();
  EXPECT_TRUE(ced::io::same_file(in, in));
  EXPECT_TRUE(ced::io::same_file(in, (dir / "sub" / ".." / "in.ply").string()));
  EXPECT_TRUE(ced::io::same_file(in, (dir / "link.ply").string()));
  EXPECT_TRUE(ced::io::same_file(in, (dir / "hard.ply").string()));
  EXPECT_FALSE(ced::io::same_file(in, (dir / "other.ply").string()));  // equal bytes, another file
  EXPECT_FALSE(ced::io::same_file(in, (dir / "missing.ply").string()));
  EXPECT_FALSE(ced::io::same_file(in, ""));
}

TEST(CheckOutputsDistinct, AnOutputThatIsAnInputIsRefusedNamingBoth) {
  const fs::path dir = fresh_dir("distinct");
  write_file(dir / "in.ply", "cloud");
  fs::create_symlink(dir / "in.ply", dir / "link.ply");
  fs::create_hard_link(dir / "in.ply", dir / "hard.ply");
  const std::string in = (dir / "in.ply").string();
  for (const fs::path& out : {dir / "in.ply", dir / "." / "in.ply", dir / "link.ply", dir / "hard.ply"}) {
    try {
      ced::io::check_outputs_distinct({{"the input", in}}, {{"--indices", ""}, {"-o", out.string()}});
      ADD_FAILURE() << out << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("-o '" + out.string() + "' is the input"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(ced::io::check_outputs_distinct({{"the input", in}}, {{"-o", (dir / "k.ply").string()}}));
  EXPECT_EQ(read_file(dir / "in.ply"), "cloud");
}

TEST(CheckOutputsDistinct, TwoOutputsOfOnePathAreRefused) {
  const fs::path dir = fresh_dir("two_outputs");
  fs::create_directories(dir / "sub");
  const std::string k = (dir / "k.ply").string();
  EXPECT_THROW(ced::io::check_outputs_distinct({}, {{"-o", k}, {"--viewer", k}}), std::invalid_argument);
  EXPECT_THROW(ced::io::check_outputs_distinct({}, {{"-o", k}, {"--viewer", (dir / "sub" / ".." / "k.ply").string()}}),
               std::invalid_argument);
  write_file(dir / "k.ply", "old");
  fs::create_symlink(dir / "k.ply", dir / "alias.ply");
  EXPECT_THROW(ced::io::check_outputs_distinct({}, {{"-o", k}, {"--viewer", (dir / "alias.ply").string()}}),
               std::invalid_argument);
  EXPECT_NO_THROW(ced::io::check_outputs_distinct({}, {{"-o", k}, {"--viewer", (dir / "v.ply").string()}}));
  // Devices may take several outputs.
  EXPECT_NO_THROW(ced::io::check_outputs_distinct({}, {{"-o", "/dev/null"}, {"--viewer", "/dev/null"}}));
}

TEST(AtomicOutputFile, ADeviceIsWrittenInPlaceNeverRenamedOver) {
  {
    atomic_output_file f("/dev/null");
    EXPECT_TRUE(f.temp_path().empty());
    f.stream() << "discarded";
    f.commit();
  }
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  // /dev/stdout names whatever fd 1 is (a regular file under ctest): written
  // through, not replaced by a renamed temporary.
  struct stat link {};
  if (::lstat("/dev/stdout", &link) == 0) {
    atomic_output_file f("/dev/stdout");
    EXPECT_TRUE(f.temp_path().empty());
    f.commit();
    struct stat after {};
    ASSERT_EQ(::lstat("/dev/stdout", &after), 0);
    EXPECT_EQ(after.st_mode, link.st_mode);
    EXPECT_EQ(after.st_ino, link.st_ino);
  }
}

TEST(AtomicOutputFile, ACommitRemovesTheTemporariesOfKilledProcesses) {
  const fs::path dir = fresh_dir("stale");
  // A process id that runs no process: past the kernel's pid_max.
  long dead = 4194304 + 17;
  if (std::ifstream max("/proc/sys/kernel/pid_max"); max) max >> dead, dead += 17;
  const fs::path stale = dir / (".k.txt.tmp." + std::to_string(dead) + ".0");
  const fs::path live = dir / (".k.txt.tmp." + std::to_string(::getppid()) + ".3");  // a process that runs
  const fs::path other = dir / (".j.txt.tmp." + std::to_string(dead) + ".0");        // another output's
  const fs::path user = dir / (".k.txt.tmp." + std::to_string(dead) + ".0.mine");    // not ced's name
  for (const auto& p : {stale, live, other, user}) write_file(p, "partial");
  atomic_output_file f((dir / "k.txt").string());
  f.stream() << "1\n";
  f.commit();
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_TRUE(fs::exists(user));
  EXPECT_EQ(read_file(dir / "k.txt"), "1\n");
}

TEST(WriteNamed, AFailedWriteNamesTheFile) {
  const fs::path dir = fresh_dir("named");
  atomic_output_file f((dir / "k.las").string());
  try {
    ced::io::write_named(f, [](std::ostream&) { throw io_error("error writing LAS data to the output stream"); });
    ADD_FAILURE();
  } catch (const io_error& e) {
    EXPECT_NE(std::string(e.what()).find("k.las"), std::string::npos) << e.what();
  }
  if (fs::exists("/dev/full")) {
    atomic_output_file full("/dev/full");
    try {
      ced::io::write_named(full, [](std::ostream& s) {
        const std::string block(1 << 20, 'x');
        s.write(block.data(), static_cast<std::streamsize>(block.size()));
        s.flush();
      });
      ADD_FAILURE() << "a write to /dev/full succeeded";
    } catch (const io_error& e) {
      EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
    }
  }
}
