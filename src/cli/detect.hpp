// SPDX-License-Identifier: MIT
// `ced detect`, shared by its two files: detect.cpp (options, checks,
// reading, detection) and detect_write.cpp (the outputs and the report).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/catalogue.hpp"
#include "ced/io/io.hpp"
#include "ced/render.hpp"
#include "ced/tiled.hpp"
#include "common.hpp"

namespace ced_cli {

struct detect_options {
  std::string input, format = "auto", columns;
  /// ced detect's positional inputs: one file, or several, a folder or
  /// @LIST, read as one cloud (a catalogue). `input` names them in messages.
  std::vector<std::string> inputs;
  std::string origin;  // --origin X,Y,Z: positions relative to it (empty: the readers' choice)
  std::string preset;
  std::vector<std::string> modalities;
  std::vector<std::string> plugins;
  std::string radius = "";  // a number or "auto"; empty = default
  double nms_radius = std::nan("");
  double radius_factor = 5.0;
  double voxel = 0;
  int min_neighbors = 5;
  int threads = 0;
  long long max_keypoints = 0;  // 0: no limit
  std::string keypoint_share;   // empty: the preset's (none without a preset)
  std::string neighborhood = "radius", search = "grid";
  std::string indices, indices_original, indices_global, indices_per_file, output, viewer, png, summary, html;
  long long html_max_points = 2000000;
  std::string view = "iso", png_size = "1280x960", png_color = "rgb";
  bool png_top = false;
  bool refine = false, no_refine = false;  // default: the preset's (robust3d/6d refine)
  bool quiet = false;
  std::string progress = "auto";  // --progress: auto, bar, lines, json, none
  // Tiles (tiled_commands.cpp): one process with a tile cache, or one tile of a plan.
  std::string tile_size, memory_limit, work_dir, plan;
  bool resume = false;
  long long tile = -1;
  std::string config;  // --config: expand_config() has already replaced it by the file's options
  /// Options given on the command line that a --plan fixes (a usage error with --plan).
  std::vector<std::string> given_plan_options;
  /// Given on the command line or in --config: --radius-factor (only for --radius auto) and
  /// the options that shape the --png picture (only with --png).
  bool radius_factor_given = false;
  std::vector<std::string> given_png_options;
};

/// The detector's options of `ced detect` and `ced plan`: --preset,
/// -m/--modality, --plugin, -r/--radius (`radius_help`: its help),
/// --nms-radius, -k/--min-neighbors, --refine, --no-refine and --max-keypoints.
void add_detector_options(CLI::App* cmd, detect_options& o, const std::string& radius_help);

/// What the options ask for, checked before any file is read.
struct detect_plan {
  ced::detect_params params;
  bool auto_radius = false;
  double resolution = 0;  // estimated on the input for --radius auto
  std::vector<ced::any_modality> modalities;
  ced::render_options view;
  ced::io::file_format out_format = ced::io::file_format::automatic;
  ced::io::read_options read_opts;
};

/// Every output, opened first (temporary files beside the targets), so that a
/// bad output path fails before the work and no output is half-written.
/// First a usage error when an output is one of `inputs` or two outputs are
/// one file (check_paths).
struct detect_outputs {
  std::vector<std::unique_ptr<ced::io::atomic_output_file>> files;
  ced::io::atomic_output_file *indices = nullptr, *original = nullptr, *global = nullptr, *keypoints = nullptr,
                              *viewer = nullptr, *png = nullptr, *summary = nullptr, *html = nullptr;

  /// --indices-per-file: the path of each input file's indices (empty without).
  std::vector<std::string> per_file;

  detect_outputs(const detect_options& o, const std::vector<ced::io::named_path>& inputs);
  ced::io::atomic_output_file* open(const std::string& path);
  /// Writes --indices-per-file (`found`: each keypoint's file and index in
  /// it, in order), each file finished, to be committed with the others.
  void write_per_file(const std::vector<std::pair<std::size_t, std::uint64_t>>& found);
};

/// The cloud the detector sees: finite points, voxel down-sampled with --voxel.
struct detect_input {
  ced::io::read_report report;
  /// Several inputs: their files and where each begins in the cloud's numbering.
  std::optional<ced::io::catalogue_report> catalogue;
  ced::point_cloud cloud;
  std::vector<std::uint32_t> original;  // original[i]: index in the input file's (finite) points of point i
                                        // (only with --indices-original)
  std::size_t n_file = 0, n_finite = 0, n_dropped = 0;
  double load_ms = 0, voxel_ms = 0;
};

/// Whether the inputs are a catalogue (several files, a folder or @LIST).
bool is_catalogue(const detect_options& o);
/// The files of a catalogue, in order (catalogue_files()).
std::vector<std::string> catalogue_inputs(const detect_options& o);

/// The options' checks and the modalities, before any file is read (detect.cpp).
detect_plan make_plan(const detect_options& o);

/// The index of the modality that --png-color saliency:NAME names (its name
/// or its column name); throws usage_error listing the names otherwise.
std::size_t png_saliency_index(const std::string& name, const std::vector<std::string>& names);

/// The column of a modality's saliency in output clouds: its name with every
/// character but letters and digits replaced by '_'.
std::string column_name(const std::string& modality);
/// The saliency columns of modalities `names` (column_name() of each), or
/// std::invalid_argument naming two that would give the same column.
std::vector<std::string> saliency_columns(const std::vector<std::string>& names);

/// -o's cloud: `kp` (the keypoints with their fields) plus saliency_<modality>
/// fields, saliency[m][k] for keypoint k.
ced::point_cloud keypoint_cloud(ced::point_cloud kp, const std::vector<std::string>& names,
                                const std::vector<std::vector<float>>& saliency);
void write_keypoint_cloud(std::ostream& out, ced::point_cloud kp, const std::vector<std::string>& names,
                          const std::vector<std::vector<float>>& saliency, ced::io::file_format format);

/// f(); a missing_field_error from it names the input file's fields
/// (with_file_fields), not those read.
template <class F>
auto naming_file_fields(const detect_options& o, const detect_plan& plan, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const ced::missing_field_error& e) {
    throw with_file_fields(e, o.input, plan.read_opts);
  }
}

/// The files `ced detect` reads: the input and the plugins.
std::vector<ced::io::named_path> input_paths(const detect_options& o);

/// `ced detect --tile-size/--memory-limit` and `--plan --tile` (tiled_commands.cpp).
bool wants_tiles(const detect_options& o);
/// The work directory of a tiled run: --work-dir, or default_work_dir().
std::string work_dir_of(const detect_options& o);
/// A usage error when an output lies inside the work directory (ced empties
/// that directory of its own files; outputs belong elsewhere).
void check_outside_work_dir(const detect_options& o);
/// What a tiled detection (`ced detect --tile-size`, ced-mpi) sets up before
/// its work: the checked options (make_plan), its outputs (none inside the
/// work directory) opened, its request, and the run options of its work
/// directory (--work-dir, --resume).
struct tiled_setup {
  detect_plan plan;
  std::unique_ptr<detect_outputs> out;
  ced::tiled_request request;
  ced::tiled_run_options run;
};
tiled_setup setup_tiled(const detect_options& o);
/// The progress bar, for the tiled library's (step, fraction) reports.
ced::tiled_progress bar_progress(progress_bar& bar);
/// `ced detect --tile-size/--memory-limit`: setup_tiled(), run_tiled(), the outputs.
int run_detect_tiled(const detect_options& o);
int run_detect_plan_tile(const detect_options& o);
/// The tiled request of the options; usage errors for what tiles cannot do.
ced::tiled_request request_from(const detect_options& o, detect_plan& plan);
/// A default work directory: in $TMPDIR, named after the input and the
/// outputs, so that --resume finds the same one.
std::string default_work_dir(const detect_options& o);
/// Points read per point owned, and a warning when the halo outweighs the
/// core; a reach of ced's own, and what a short one does (`grows_reach`:
/// run_tiled grows it; a plan's tiles run elsewhere stop).
void report_plan(const ced::tile_plan& p, bool quiet, bool grows_reach);
/// tiled_run_options::reach_grown for `program` ("ced", "ced-mpi"): says
/// on stderr which reach was short for how many tiles, and the next.
std::function<void(double, double, double, std::size_t)> reach_grown_report(const char* program, bool quiet);
/// The outputs of a merged run (indices, original indices, keypoints,
/// summary), written as the merge streams: sink() for the merge, then
/// finish() writes the summary and commits every file. Without output
/// files, the indices go to stdout.
/// Several inputs: each keypoint's file (its number among them) and its
/// index in that file.
using file_places = std::vector<std::pair<std::size_t, std::uint64_t>>;
/// FILE_ID INDEX a line, as --indices writes them for several inputs.
void write_file_places(std::ostream& out, const file_places& at);
/// -o with several inputs: the fields file_id and file_index (in 32 bits
/// when `points`, the inputs' count, allows: PLY has no 64-bit integers).
/// io_error when the inputs have such a field already.
void add_file_fields(ced::point_cloud& kp, const file_places& at, std::uint64_t points);
/// The keypoints as --indices writes them (an index a line; with several
/// inputs, FILE_ID INDEX).
void write_indices(std::ostream& out, const detect_input& in, const ced::detection_result& r);

class merged_writer {
 public:
  /// `request`: the run's input (a folder or @LIST: each keypoint's file
  /// and index in it, as ced detect gives them for several inputs).
  merged_writer(detect_outputs& out, ced::io::file_format format, const ced::tiled_request& request);
  ced::merge_sink sink();
  void finish(const ced::tile_plan& p, const ced::tile_part& totals, double total_ms);
  std::uint64_t keypoints() const noexcept { return m_count; }

 private:
  /// A catalogue: each of the part's keypoints' file and index in it (else none).
  file_places places(const ced::tile_part& c) const;
  /// The keypoints' records, with file_id and file_index for a catalogue
  /// (`at`: their files and indices).
  ced::point_cloud records(const ced::tile_part& c, const file_places& at) const;
  detect_outputs& m_out;
  ced::io::file_format m_format;
  std::vector<std::uint64_t> m_first;  // a catalogue's numbering (catalogue_first()); else empty
  file_places m_per_file;              // --indices-per-file: the keypoints' files
  std::unique_ptr<ced::io::cloud_writer> m_cloud;
  std::uint64_t m_count = 0;
};

/// Writes every output file of `out` and commits them.
void write_outputs(const detect_options& o, const detect_plan& plan, const detect_input& in,
                   const ced::detection_result& r, detect_outputs& out);

/// The run's report on stderr (unless --quiet).
void print_report(const detect_options& o, const detect_plan& plan, const detect_input& in,
                  const ced::detection_result& r, clock_type::time_point t_start);

}  // namespace ced_cli
