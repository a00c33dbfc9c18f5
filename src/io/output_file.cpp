// SPDX-License-Identifier: MIT
#include "ced/io/output_file.hpp"

#ifdef _WIN32
#include <process.h>
#else
#include <unistd.h>
#endif

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace ced::io {

namespace fs = std::filesystem;

namespace {
std::atomic<unsigned long> g_temp_counter{0};

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
  m_stream.open(m_temp_path, std::ios::binary | std::ios::out | std::ios::trunc);
  if (!m_stream.is_open()) {
    const int err = errno;
    throw io_error("cannot write '" + path + "': cannot create a file in directory '" + dir.string() + "'" +
                   (err ? " (" + errno_text(err) + ")" : std::string()));
  }
}

atomic_output_file::~atomic_output_file() {
  if (m_committed) return;
  if (m_stream.is_open()) m_stream.close();
  if (!m_temp_path.empty()) std::remove(m_temp_path.c_str());
}

void atomic_output_file::commit() {
  if (m_committed) throw io_error("'" + m_path + "' was already committed");
  m_stream.flush();
  if (!m_stream) throw io_error("error writing '" + m_path + "' (disk full?)");
  m_stream.close();
  if (m_stream.fail()) throw io_error("error closing '" + m_path + "' (disk full?)");
  if (std::rename(m_temp_path.c_str(), m_path.c_str()) != 0) {
    const int err = errno;
    throw io_error("cannot rename the temporary file onto '" + m_path + "': " + errno_text(err));
  }
  m_committed = true;
}

void write_text_file_atomic(const std::string& path, const std::string& content) {
  atomic_output_file out(path);
  out.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  out.commit();
}

}  // namespace ced::io
