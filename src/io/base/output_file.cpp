// SPDX-License-Identifier: MIT
#include "ced/io/output_file.hpp"

#include "io/base/scalar_io.hpp"

#ifdef _WIN32
#include <process.h>
#else
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>
#endif

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

namespace ced::io {

namespace fs = std::filesystem;

namespace {
std::atomic<unsigned long> g_temp_counter{0};

// Temporary files open right now, for the signal handler: fixed storage, so
// that the handler only reads memory and calls unlink (async-signal-safe).
constexpr std::size_t k_slots = 64, k_path_max = 4096;
char g_temp_paths[k_slots][k_path_max];
std::atomic<bool> g_slot_claimed[k_slots];  // owned by an atomic_output_file
std::atomic<bool> g_slot_ready[k_slots];    // path written: the handler may use it

int register_temporary(const std::string& path) noexcept {
  if (path.size() >= k_path_max) return -1;
  for (std::size_t i = 0; i < k_slots; ++i) {
    bool expected = false;
    if (!g_slot_claimed[i].compare_exchange_strong(expected, true)) continue;
    std::memcpy(g_temp_paths[i], path.c_str(), path.size() + 1);
    g_slot_ready[i].store(true, std::memory_order_release);
    return static_cast<int>(i);
  }
  return -1;  // more than 64 at once: such a file is only removed by its destructor
}

void unregister_temporary(int slot) noexcept {
  if (slot < 0) return;
  g_slot_ready[static_cast<std::size_t>(slot)].store(false);
  g_slot_claimed[static_cast<std::size_t>(slot)].store(false);
}

#ifndef _WIN32
extern "C" void remove_temporaries_and_reraise(int sig) {
  for (std::size_t i = 0; i < k_slots; ++i)
    if (g_slot_ready[i].load(std::memory_order_acquire)) ::unlink(g_temp_paths[i]);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}
#endif

std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

long process_id() {
#ifdef _WIN32
  return static_cast<long>(::_getpid());
#else
  return static_cast<long>(::getpid());
#endif
}
}  // namespace

atomic_output_file::atomic_output_file(const std::string& path) : m_path(path) {
  if (path.empty()) throw io_error("cannot write a file with an empty path");
  const fs::path p(path);
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw io_error("cannot write '" + path + "': it is a directory");
  const fs::file_status st = fs::status(p, ec);
  const std::string abs = fs::absolute(p, ec).lexically_normal().string();
  const bool system_node = abs.rfind("/dev/", 0) == 0 || abs.rfind("/proc/", 0) == 0;
  if ((!ec && fs::exists(st) && !fs::is_regular_file(st)) || system_node) {
    // A device or FIFO (/dev/null, a pipe), or a name under /dev or /proc
    // (/dev/stdout links to whatever fd 1 is, a regular file too): written
    // in place, never renamed over.
    m_direct = true;
    m_stream.open(path, std::ios::binary | std::ios::out);
    if (!m_stream.is_open()) throw io_error("cannot write '" + path + "': " + errno_text(errno));
    return;
  }
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  const fs::path name = p.filename();
  if (name.empty() || name == "." || name == "..") throw io_error("cannot write '" + path + "': it is a directory");
  if (!fs::exists(dir, ec))
    throw io_error("cannot write '" + path + "': directory '" + dir.string() + "' does not exist");
  if (!fs::is_directory(dir, ec))
    throw io_error("cannot write '" + path + "': '" + dir.string() + "' is not a directory");

  m_temp_path = (dir / detail::temporary_name(name.string(), process_id(), g_temp_counter.fetch_add(1))).string();
  errno = 0;
  m_slot = register_temporary(m_temp_path);
  m_stream.open(m_temp_path, std::ios::binary | std::ios::out | std::ios::trunc);
  if (!m_stream.is_open()) {
    const int err = errno;
    unregister_temporary(m_slot);
    throw io_error("cannot write '" + path + "': cannot create a file in directory '" + dir.string() + "'" +
                   (err ? " (" + errno_text(err) + ")" : std::string()));
  }
}

atomic_output_file::~atomic_output_file() {
  unregister_temporary(m_slot);
  if (m_committed) return;
  if (m_stream.is_open()) m_stream.close();
  if (!m_temp_path.empty()) std::remove(m_temp_path.c_str());
}

void remove_temporaries_on_signals() {
#ifndef _WIN32
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, remove_temporaries_and_reraise);
#endif
}

void atomic_output_file::finish() {
  if (m_finished) return;
  if (m_committed) throw io_error("'" + m_path + "' was already committed");
  m_stream.flush();
  if (!m_stream) throw io_error("error writing '" + m_path + "' (disk full?)");
  m_stream.close();
  if (m_stream.fail()) throw io_error("error closing '" + m_path + "' (disk full?)");
  m_finished = true;
}

void atomic_output_file::commit() {
  if (m_committed) throw io_error("'" + m_path + "' was already committed");
  finish();
  if (m_direct) {
    m_committed = true;
    return;
  }
  unregister_temporary(m_slot);
  m_slot = -1;
  if (std::rename(m_temp_path.c_str(), m_path.c_str()) != 0) {
    const int err = errno;
    throw io_error("cannot rename the temporary file onto '" + m_path + "': " + errno_text(err));
  }
  m_committed = true;
  remove_stale_temporaries();
}

void atomic_output_file::remove_stale_temporaries() const noexcept {
#ifndef _WIN32
  // Temporaries of this file beside it, of a process that no longer runs.
  const fs::path p(m_path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  fs::directory_iterator it(dir, ec), end;
  for (; !ec && it != end; it.increment(ec)) {
    std::string of;
    long pid = 0;
    if (!detail::parse_temporary_name(it->path().filename().string(), of, pid) || of != p.filename().string()) continue;
    if (pid <= 0 || pid == process_id()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    std::error_code rm;
    if (fs::is_regular_file(it->symlink_status(rm))) fs::remove(it->path(), rm);
  }
#endif
}

namespace detail {
std::string temporary_name(const std::string& name, long pid, unsigned long n) {
  return "." + name + ".tmp." + std::to_string(pid) + "." + std::to_string(n);
}

bool parse_temporary_name(const std::string& file_name, std::string& name, long& pid) {
  const std::size_t tmp = file_name.rfind(".tmp.");
  if (file_name.size() < 2 || file_name[0] != '.' || tmp == std::string::npos || tmp < 2) return false;
  const std::string rest = file_name.substr(tmp + 5);  // <pid>.<n>
  const std::size_t dot = rest.find('.');
  if (dot == 0 || dot == std::string::npos || dot + 1 == rest.size() ||
      rest.find_first_not_of("0123456789.") != std::string::npos || rest.find('.', dot + 1) != std::string::npos)
    return false;
  name = file_name.substr(1, tmp - 1);
  pid = std::strtol(rest.substr(0, dot).c_str(), nullptr, 10);
  return true;
}

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw io_error("cannot read '" + path + "': it is a directory");
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw io_error("cannot open '" + path + "': " + errno_text(errno));
  std::string data;
  const auto size = fs::file_size(path, ec);
  if (!ec) {
    data.resize(static_cast<std::size_t>(size));
    data.resize(std::fread(data.data(), 1, data.size(), f.get()));
  }
  char buf[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(buf, 1, sizeof(buf), f.get())) > 0) data.append(buf, got);
  if (std::ferror(f.get())) throw io_error("error reading '" + path + "'");
  return data;
}
}  // namespace detail

void write_text_file_atomic(const std::string& path, const std::string& content) {
  atomic_output_file out(path);
  out.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  out.commit();
}

bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  std::error_code ec;
  const bool same = fs::equivalent(a, b, ec);
  return !ec && same;
}

namespace {
/// An output's path for comparing outputs that may not exist yet: absolute,
/// symbolic links of its existing part resolved, "." and ".." folded.
std::string comparable(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path, ec).lexically_normal();
  return p.string();
}
bool special_node(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  return !ec && fs::exists(st) && !fs::is_regular_file(st);
}
std::string quoted(const named_path& p) { return p.what + " '" + p.path + "'"; }
}  // namespace

void check_outputs_distinct(const std::vector<named_path>& inputs, const std::vector<named_path>& outputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const named_path& o = outputs[i];
    if (o.path.empty()) continue;
    for (const named_path& in : inputs)
      if (same_file(o.path, in.path))
        throw std::invalid_argument(quoted(o) + " is " + quoted(in) +
                                    ": ced never writes over a file it reads; choose another output path");
    if (special_node(o.path)) continue;
    for (std::size_t j = 0; j < i; ++j) {
      const named_path& e = outputs[j];
      if (e.path.empty() || special_node(e.path)) continue;
      if (same_file(o.path, e.path) || comparable(o.path) == comparable(e.path))
        throw std::invalid_argument(quoted(o) + " and " + quoted(e) +
                                    " are one file: each output needs a path of its own");
    }
  }
}

}  // namespace ced::io
