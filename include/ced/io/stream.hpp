// SPDX-License-Identifier: MIT
// Reading a cloud file in chunks of points, for clouds larger than memory
// (`ced detect --tile-size`, `ced plan`).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/io.hpp"

namespace ced::io {

/// A cloud file read chunk by chunk, in file order.
///
/// The first pass (read() until it returns 0) learns what depends on the
/// whole file: the origin read_cloud() would choose, the bounding box, and,
/// for some formats, which fields there are (LAS flags that only some points
/// set) or their types (CSV columns, typed by all their values). After rewind(), every chunk has exactly the fields,
/// names, types and positions (relative to the same origin) that read_cloud() gives for the whole file, point for
/// point; before it, a chunk's fields may differ from the next one's.
///
/// Non-finite points are kept (read_cloud() keeps them too, but for the
/// non-finite points of PCD files, which a stream also keeps: the caller
/// counts file points and finite points itself).
///
/// LAS, binary PLY, binary PCD and CSV stream: memory holds a chunk and small
/// buffers (and the file's header). `streaming()` is false for the encodings
/// read whole and then served in chunks (memory is then not bounded by the
/// chunk size): PLY ascii, PCD ascii and binary_compressed, and anything that
/// is not a regular file; these drop the non-finite points of PCD files as
/// read_cloud() does.
class point_stream {
 public:
  virtual ~point_stream() = default;
  /// Replaces `out` with up to `max` next points, positions relative to
  /// `origin`; returns how many (0 at the end).
  virtual std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) = 0;
  /// Back to the first point. After a complete pass, the chunks that follow
  /// have the whole file's fields.
  virtual void rewind() = 0;
  /// After a complete pass: the origin read_cloud() chooses for this file.
  virtual std::array<double, 3> origin() const = 0;
  /// After a complete pass: the bounding box of the finite points, absolute.
  virtual void bounds(double lo[3], double hi[3]) const = 0;
  /// The format's description, as read_report::details ("LAS 1.2, point format 3").
  virtual std::string details() const = 0;
  virtual bool streaming() const noexcept = 0;
  /// Points in the file when its header says (LAS, streamed PLY and PCD); else 0.
  virtual std::uint64_t declared_points() const noexcept { return 0; }

  /// Consecutive points of the file: [first, first + count).
  struct point_run {
    std::uint64_t first = 0, count = 0;
  };
  /// A node of a file's spatial index: its box (absolute, {x0, y0, z0, x1,
  /// y1, z1}), which holds its points, and the points themselves.
  struct index_node {
    std::array<double, 6> box{};
    point_run run;
    /// A run of a file without an index, in a catalogue: its box is the
    /// file's header bounds (las_header_box(), one scale step wider).
    bool whole_file = false;
  };
  /// Files with a spatial index (COPC): every node of it that holds points,
  /// read from the index alone. Catalogues (ced/io/catalogue.hpp) of LAS,
  /// LAZ and COPC files: their COPC files' nodes, and each other file's runs
  /// (chunk_runs()) as nodes of its header's box (whole_file). Other files:
  /// none (std::nullopt). io_error for an index that is damaged or does not
  /// match the file's chunks.
  virtual std::optional<std::vector<index_node>> index_nodes() { return std::nullopt; }
  /// Files with a spatial index: the runs of points, ascending and apart,
  /// of the nodes that meet the absolute box [lo, hi] (and so hold every
  /// point within it, and others near it). Other files: none.
  std::optional<std::vector<point_run>> runs_within(const double lo[3], const double hi[3]);
  /// The nodes among `nodes` whose box meets [lo, hi] (closed, grown by
  /// index_margin()), in the file's order.
  static std::vector<index_node> nodes_within(const std::vector<index_node>& nodes, const double lo[3],
                                              const double hi[3]);
  /// How far a point may lie outside its node's box: a millionth of the
  /// largest node's edge (points on a face belong to either side).
  static double index_margin(const std::vector<index_node>& nodes) noexcept;
  /// LAS, LAZ, binary PCD and binary PLY of fixed-size vertex records: the
  /// file's points as consecutive runs, each of which read_run() reads alone
  /// at little cost (LAZ: its chunks; the others: blocks of
  /// fixed_run_points), in order and covering every point: a tile plan
  /// records each run's box, so that a tile reads only the runs near it.
  /// Other streams: none.
  virtual std::vector<point_run> chunk_runs() const { return {}; }
  /// LAS, after a complete pass: the flag fields some point sets (a read of
  /// every field has them). Other formats: none.
  virtual std::vector<std::string> flags_set() const { return {}; }
  /// LAS: the header's bounds as written, when they are finite and ordered
  /// (they may be wrong: header_box() tells how far to trust them); false
  /// for other formats.
  virtual bool header_bounds(double lo[3], double hi[3]) const {
    (void)lo;
    (void)hi;
    return false;
  }
  /// LAS: the box the header's bounds vouch for, grown on each axis by
  /// `growth` times the largest extent and one scale step (las_header_box);
  /// false when they are not finite and ordered, and for other formats.
  virtual bool header_box(double growth, double box[6]) const {
    (void)growth;
    (void)box;
    return false;
  }
  /// Reads run `r` (one of runs_within()'s or chunk_runs()'s; LAS: any run
  /// of the file's points) into `out`, positions relative to `origin`, with
  /// the fields a complete pass would give: `fields` names the flags among them (a tile
  /// plan records them), as no pass learns them here. The stream's pass is
  /// then spent: origin(), bounds() and flags_set() no longer hold.
  /// LAS, LAZ, binary PCD and binary PLY of fixed-size vertex records: the
  /// points at file indices `at` (ascending, each below declared_points();
  /// else std::logic_error) into `out`, with the fields a complete pass
  /// gives (`fields` names the LAS flags among them, as read_run()), reading
  /// only their records (LAZ: decoding only the chunks that hold them).
  /// Returns false, reading nothing, for the other streams. The stream's
  /// pass is then spent, as after read_run().
  virtual bool read_points(const std::vector<std::uint64_t>& at, const std::vector<std::string>& fields,
                           const std::array<double, 3>& origin, point_cloud& out) {
    (void)at;
    (void)fields;
    (void)origin;
    (void)out;
    return false;
  }
  /// LAS and LAZ: from now on read() gives the fields `fields` names (the
  /// LAS flags among them, as a tile plan records them) without a first
  /// pass to learn them; the pass is then spent, as after read_run().
  /// Returns false for the other streams, which need no such pass.
  virtual bool take_fields(const std::vector<std::string>& fields) {
    (void)fields;
    return false;
  }
  virtual void read_run(const point_run& r, const std::vector<std::string>& fields, const std::array<double, 3>& origin,
                        point_cloud& out) {
    (void)r;
    (void)fields;
    (void)origin;
    (void)out;
    throw std::logic_error("point_stream::read_run: this stream has no spatial index");
  }

  /// Points in a run of chunk_runs() for files of fixed-size records: 2 MiB
  /// or more of records, a read of its own for a tile.
  static constexpr std::uint64_t fixed_run_points = 65536;

 protected:
  /// chunk_runs() of a file of `n` fixed-size records: blocks of fixed_run_points.
  static std::vector<point_run> fixed_runs(std::uint64_t n);
  /// Throws std::logic_error unless `r` is a run of a file of `n` points
  /// whose stream reads runs (`runs`).
  static void check_run(const point_run& r, std::uint64_t n, bool runs);
};

/// Opens `path` for reading in chunks (format and fields as in read_options).
/// Throws io_error naming the file for anything read_cloud() would reject
/// in its header.
std::unique_ptr<point_stream> open_point_stream(const std::string& path, const read_options& options = {});

/// LAS only, streaming (read_las()'s semantics, chunk by chunk).
std::unique_ptr<point_stream> open_las_stream(const std::string& path, const field_selection& fields = {});

}  // namespace ced::io
