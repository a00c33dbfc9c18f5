// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <fstream>
#include <ostream>
#include <stdexcept>
#include <string>

namespace ced::io {

/// Error reading or writing a file. The message names the file and the problem.
struct io_error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Writes a file atomically: the data goes to a temporary file in the same
/// directory (".<name>.tmp.<pid>.<n>"), which commit() renames onto the final
/// path. Until commit() succeeds the final path is untouched, and a file that
/// is destroyed without a successful commit() removes its temporary file, so
/// a failed run leaves neither a partial file nor a clobbered old one.
///
/// Threading: one object per thread; distinct objects may be used concurrently
/// (temporary names are unique per process and object).
class atomic_output_file {
 public:
  /// Opens the temporary file (binary mode). Throws io_error naming `path`
  /// when the path is empty or a directory, when its directory does not exist,
  /// or when the temporary file cannot be created there (e.g. not writable).
  explicit atomic_output_file(const std::string& path);
  /// Removes the temporary file unless commit() succeeded. Never throws.
  ~atomic_output_file();
  atomic_output_file(const atomic_output_file&) = delete;
  atomic_output_file& operator=(const atomic_output_file&) = delete;

  /// The stream to write to (the temporary file).
  std::ostream& stream() noexcept { return m_stream; }
  /// Flushes, checks that every write succeeded, closes and renames the
  /// temporary file onto the final path. Throws io_error on any failure (the
  /// temporary file is then removed by the destructor). Call at most once.
  void commit();

  const std::string& path() const noexcept { return m_path; }
  const std::string& temp_path() const noexcept { return m_temp_path; }

 private:
  std::string m_path;
  std::string m_temp_path;
  std::ofstream m_stream;
  bool m_committed = false;
  int m_slot = -1;  // in the table the signal handler cleans
};

/// Writes `content` (bytes, written verbatim) to `path` through an
/// atomic_output_file. Throws io_error on failure.
/// Installs SIGINT/SIGTERM/SIGHUP handlers that delete the temporary files of
/// every atomic_output_file not yet committed, then let the signal end the
/// process as before. For programs (the CLI calls it); POSIX only.
void remove_temporaries_on_signals();

void write_text_file_atomic(const std::string& path, const std::string& content);

}  // namespace ced::io
