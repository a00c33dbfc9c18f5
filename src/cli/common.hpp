// SPDX-License-Identifier: MIT
// What the `ced` subcommands share: exit codes, usage errors, the --config
// reader, the progress bar, the input options and reading.
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "../core/timing.hpp"
#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/catalogue.hpp"
#include "ced/io/io.hpp"
#include "ced/io/output_file.hpp"
#include "ced/params.hpp"

namespace ced_cli {

// Exit codes (documented in docs/CLI.md).
constexpr int exit_ok = 0;
constexpr int exit_failure = 1;  // bad input data, I/O error
constexpr int exit_usage = 2;    // bad command line or parameters

struct usage_error : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// The library's clock of stage times (milliseconds since a time point).
using ced::detail::clock_type;
using ced::detail::ms_since;

/// Reads `--config FILE.json`: a JSON object whose keys are the long option
/// names (without --), values numbers, strings, booleans or arrays.
class json_config : public CLI::Config {
 public:
  std::string to_config(const CLI::App*, bool, bool, std::string) const override { return {}; }
  std::vector<CLI::ConfigItem> from_config(std::istream& in) const override;
};

/// Replaces `detect ... --config FILE ...` by the file's options, inserted
/// right after `detect`; options also given on the command line win (the
/// file's value is dropped).
std::vector<std::string> expand_config(const std::vector<std::string>& args, CLI::App& det);

/// Parses the command line (argc, argv) with `app`, after expand_config()
/// for its subcommand `detect`. Nothing when the parsed command is to be
/// run; else the exit code: --help and --version (0), a usage error (2),
/// shown on stderr unless `!report` (the message of an error that CLI11 does
/// not report itself prefixed with "`name`: error: ").
std::optional<int> parse_command_line(CLI::App& app, CLI::App& detect, int argc, char** argv, const std::string& name,
                                      bool report = true);

/// The check of every command before its work: no output is an input (the
/// same file however spelled) and no two outputs are one file; a usage
/// error naming both otherwise (ced::io::check_outputs_distinct).
void check_paths(const std::vector<ced::io::named_path>& inputs, const std::vector<ced::io::named_path>& outputs);

/// Flushes stdout and throws when what went there (indices, tables) did not
/// arrive: a full disk or a closed pipe is an error, not a silent loss.
void check_stdout();

/// A repeatable option takes one value an occurrence (`-m A -m B`), so that
/// it never takes the input that follows it (`-m xyz:0.2 in.ply`, or an
/// input after a --config key); returns it.
CLI::Option* one_value_each(CLI::Option* opt);
/// `--plugin FILE.so` (repeatable) on a subcommand.
void add_plugin_option(CLI::App* app, std::vector<std::string>& plugins);
/// Loads the plugins (ced::load_plugin); a plugin that cannot be loaded is a
/// ced::plugin_error (exit code 1) naming the file and why.
void load_plugins(const std::vector<std::string>& plugins);

/// A comma-separated list of numbers (OPTION 'TEXT'): every value between
/// commas, the empty ones too, parsed with ced::parse_number, then passed to
/// `check`, which throws std::invalid_argument for a value out of range.
/// usage_error on the first problem.
std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::function<void(double)>& check);
/// Sets params.neighborhood and params.search from the texts of
/// --neighborhood (ced::parse_neighborhood) and --search (grid or cgal);
/// usage_error naming the option otherwise.
void set_neighborhood(ced::detect_params& params, const std::string& neighborhood, const std::string& search);
/// Throws usage_error naming `option` unless `v` is a finite number >= 0;
/// `zero`, when given, says what 0 means (for the message).
void check_length(double v, const std::string& option, const std::string& zero = {});
/// The evaluations' -k,--min-neighbors and -j,--threads: usage_error unless >= 0.
void check_counts(int min_neighbors, int threads);

/// A keypoint share (detect_params::keypoint_share) from `text`: a number
/// from 0 to 1, else std::invalid_argument saying `bad`.
double parse_share(const std::string& text, const std::string& bad);

/// ", the 100 strongest", ", the strongest 5% of the candidates" (both when
/// both are set), or nothing: the keypoint limit of `params`, for messages.
std::string keypoint_limit_text(const ced::detect_params& params);

/// Warns on stderr when positions, stored as floats relative to the cloud's
/// origin, lie so far from it that they keep less than a centimetre (more
/// than 167 km away): one point far from the others, such as a stray
/// (0, 0, 0) in georeferenced data, moves the origin and costs every point
/// its precision. Says how much is kept.
void warn_float_precision(const ced::point_cloud& cloud, const std::string& input);

/// Asks glibc's malloc to keep freed memory for reuse instead of returning it
/// to the system (large blocks from the heap, no trimming): a run allocates
/// and frees large arrays stage after stage, chunk after chunk, tile after
/// tile, and fresh pages cost a fault each (on the VMs measured, a third of
/// a whole LAS run: docs/SCALE.md). The peak stays what the run holds at
/// once. A no-op elsewhere than glibc.
void keep_freed_memory() noexcept;

/// Progress of a long run on stderr (--progress): `bar`, one line redrawn
/// in place with the stage, its share done, the points done and their rate,
/// and the time left; `lines`, the same as a line of its own every 5 s (a
/// log, a batch job); `json`, one JSON object a line when a stage starts,
/// at most every second, and at the end; `none`. `auto` (the default) is
/// `bar` on a terminal and `lines` elsewhere; -q is `none`. A run shorter
/// than 5 s prints nothing under `lines`.
class progress_bar {
 public:
  enum class mode { none, bar, lines, json };
  /// The mode of --progress `option` ("auto", "bar", "lines", "json",
  /// "none") and -q; usage_error for another option.
  static mode mode_of(const std::string& option, bool quiet);
  explicit progress_bar(mode m);
  ~progress_bar() { done(); }
  /// A new stage; `points`, when known, the points it goes through.
  void stage(const std::string& name, std::uint64_t points = 0);
  std::function<void(double)> callback();
  /// Clears the bar's line before other output (the run goes on).
  void pause();
  /// A tiled run's tiles: `done` of `total` after `ms`: a line (about twenty
  /// a run, one at least every ten seconds), or a JSON "tiles" event.
  void tiles(std::size_t done, std::size_t total, double ms);
  /// The end: clears the bar; json: the "done" event.
  void done();

 private:
  using clock = std::chrono::steady_clock;
  void update(double f, bool forced);
  mode m_mode;
  std::string m_stage;
  std::uint64_t m_points = 0;
  clock::time_point m_start, m_stage_start, m_last;
  bool m_printed = false, m_finished = false;
  double m_last_tiles_ms = -1e9;
  std::mutex m_mutex;
};

/// What `eval repeatability` and `eval registration` both read besides
/// INPUT: a given pair (--source, --target, --transform), or RGB-D frames
/// (--rgbd, --intrinsics, --depth-max), and the neighbourhood of ced's
/// detectors (--neighborhood, --search). Their option structs derive from it.
struct pair_options {
  std::string source, target, transform;  // a user-supplied pair instead of INPUT
  std::string rgbd, intrinsics;           // or an Open3D RGB-D folder
  double depth_max = 3.0;
  std::string neighborhood = "radius", search = "grid";  // for ced's detectors
};

/// Adds the options of pair_options to `cmd`; `rgbd_pairs` says which frames
/// --rgbd pairs. Returns --depth-max (to tell whether it was given).
CLI::Option* add_pair_options(CLI::App* cmd, pair_options& o, const std::string& rgbd_pairs);

/// The input options of a subcommand: the positional INPUT (`what` is its
/// help), --format and --columns. Returns INPUT's option (to require it).
CLI::Option* add_input_options(CLI::App* cmd, std::string& input, const std::string& what, std::string& format,
                               std::string& columns);
/// The same with several inputs (ced detect: a catalogue).
CLI::Option* add_input_options(CLI::App* cmd, std::vector<std::string>& inputs, const std::string& what,
                               std::string& format, std::string& columns);
/// Whether `inputs` name a catalogue: several files, a folder or @LIST.
bool names_catalogue(const std::vector<std::string>& inputs);
/// Reads one input file, or a catalogue as one cloud (`report` then
/// describes all of them; `catalogue`, when given, gets their numbering).
ced::point_cloud read_inputs(const std::vector<std::string>& inputs, const ced::io::read_options& options,
                             ced::io::read_report& report, ced::io::catalogue_report* catalogue = nullptr);
/// The read options of --format and --columns; a usage error for an unknown format.
ced::io::read_options make_read_options(const std::string& format, const std::string& columns);

/// `e` (a modality needs a field that the cloud read from `path` with
/// `read_opts` lacks) naming the file's fields rather than those read: ced
/// reads only the fields its modalities need. This costs one more pass over
/// the file, chunk by chunk; `e` itself when every field was read or the file
/// cannot be read again.
ced::missing_field_error with_file_fields(const ced::missing_field_error& e, const std::string& path,
                                          ced::io::read_options read_opts);

/// The frames of an Open3D RGB-D folder: color/NNNNN.jpg, depth/NNNNN.png,
/// odometry.log (camera-to-world poses) and the intrinsics (`intrinsics`,
/// default DIR/camera_primesense.json); depths beyond `depth_max` dropped (0:
/// none), each voxelised to `voxel` (0: as they are). io_error for fewer
/// than two frames.
struct rgbd_frames {
  std::vector<ced::point_cloud> clouds;
  std::vector<ced::eval::rigid_transform> poses;  ///< camera-to-world
  /// Camera i to camera j (absolute frames; the camera centre is each frame's (0,0,0)).
  ced::eval::rigid_transform source_to_target(std::size_t i, std::size_t j) const;
};
rgbd_frames load_rgbd_frames(const std::string& dir, const std::string& intrinsics, double depth_max, double voxel);
/// What the two `ced eval` commands read, for check_paths(): INPUT,
/// --source, --target, --transform, --intrinsics and, with --rgbd DIR, what
/// load_rgbd_frames() reads: odometry.log, the intrinsics file (given or the
/// default), and every file in color/ and depth/.
std::vector<ced::io::named_path> eval_input_paths(const std::string& input, const std::string& source,
                                                  const std::string& target, const std::string& transform,
                                                  const std::string& rgbd, const std::string& intrinsics);

/// Reads a cloud, drops its non-finite points, then voxel down-samples it when `voxel` > 0.
ced::point_cloud read_finite(const std::string& path, const std::string& format, const std::string& columns,
                             double voxel = 0);

}  // namespace ced_cli
