// SPDX-License-Identifier: MIT
#include "ced/io/output_file.hpp"

#include "scalar_io.hpp"

#ifdef _WIN32
#include <process.h>
#else
#include <unistd.h>
#endif

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
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
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  const fs::path name = p.filename();
  if (name.empty() || name == "." || name == "..") throw io_error("cannot write '" + path + "': it is a directory");
  if (!fs::exists(dir, ec))
    throw io_error("cannot write '" + path + "': directory '" + dir.string() + "' does not exist");
  if (!fs::is_directory(dir, ec))
    throw io_error("cannot write '" + path + "': '" + dir.string() + "' is not a directory");

  m_temp_path = (dir / ("." + name.string() + ".tmp." + std::to_string(process_id()) + "." +
                        std::to_string(g_temp_counter.fetch_add(1))))
                    .string();
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

void atomic_output_file::commit() {
  if (m_committed) throw io_error("'" + m_path + "' was already committed");
  m_stream.flush();
  if (!m_stream) throw io_error("error writing '" + m_path + "' (disk full?)");
  m_stream.close();
  if (m_stream.fail()) throw io_error("error closing '" + m_path + "' (disk full?)");
  unregister_temporary(m_slot);
  m_slot = -1;
  if (std::rename(m_temp_path.c_str(), m_path.c_str()) != 0) {
    const int err = errno;
    throw io_error("cannot rename the temporary file onto '" + m_path + "': " + errno_text(err));
  }
  m_committed = true;
}

namespace detail {
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

}  // namespace ced::io
