// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <fstream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/io/error.hpp"

namespace ced::io {

/// Writes a file atomically: the data goes to a temporary file in the same
/// directory (".<name>.tmp.<pid>.<n>"), which commit() renames onto the final
/// path. Until commit() succeeds the final path is untouched, and a file that
/// is destroyed without a successful commit() removes its temporary file, so
/// a failed run leaves neither a partial file nor a clobbered old one. A
/// successful commit() also removes the temporaries of `path` that a killed
/// process of this machine left (its process id no longer runs).
///
/// A path that exists and is not a regular file (a character device such as
/// /dev/null, a FIFO), and any path under /dev or /proc (/dev/stdout), is
/// written directly: such a node is never renamed over or removed.
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
  /// Flushes, checks that every write succeeded and closes the file, without
  /// renaming it yet (a device or FIFO has then had all its bytes). Throws
  /// io_error on failure. For several files that land together: finish()
  /// each, then commit() each, so that a write that fails leaves every final
  /// path untouched. Calling it again does nothing.
  void finish();
  /// finish(), then renames the temporary file onto the final path. Throws
  /// io_error on any failure (the temporary file is then removed by the
  /// destructor). Call at most once.
  void commit();

  const std::string& path() const noexcept { return m_path; }
  const std::string& temp_path() const noexcept { return m_temp_path; }

 private:
  void remove_stale_temporaries() const noexcept;

  std::string m_path;
  std::string m_temp_path;
  std::ofstream m_stream;
  bool m_direct = false;  // a device or FIFO, written in place
  bool m_finished = false;
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

/// Runs `write(file.stream())`. An io_error it throws, or a stream that
/// failed (a full disk), becomes an io_error that names the file.
template <class F>
void write_named(atomic_output_file& file, F&& write) {
  try {
    write(file.stream());
  } catch (const io_error& e) {
    throw io_error("cannot write '" + file.path() + "': " + e.what());
  }
  if (!file.stream()) throw io_error("error writing '" + file.path() + "' (disk full?)");
}

namespace detail {
/// The name of an atomic_output_file's temporary for the file `name`:
/// ".<name>.tmp.<pid>.<n>".
std::string temporary_name(const std::string& name, long pid, unsigned long n);
/// The file and process id of such a temporary's name; false for any other
/// name. Who cleans temporaries (commit(), a tiled run's work directory)
/// recognises them by this, and only by this.
bool parse_temporary_name(const std::string& file_name, std::string& name, long& pid);
}  // namespace detail

/// True when `a` and `b` are one existing file, however they are spelled
/// ("sub/../x", symbolic links, hard links): the same device and inode.
bool same_file(const std::string& a, const std::string& b);

/// A file a command reads or writes, and what names it ("-o", "the input").
struct named_path {
  std::string what, path;
};

/// The check every command makes before any work: throws
/// std::invalid_argument naming both when an output is one of the inputs
/// (same_file()), or when two outputs are one file (the same file or, for
/// files yet to be written, the same absolute path once symbolic links are
/// resolved). Empty paths are skipped; outputs that are devices or FIFOs
/// (/dev/null) may repeat. ced never writes over what it reads.
void check_outputs_distinct(const std::vector<named_path>& inputs, const std::vector<named_path>& outputs);

}  // namespace ced::io
