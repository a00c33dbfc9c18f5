// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace ced {

/// Storage type a per-point field had in its file. Values are kept as double
/// in memory; the type is remembered to normalise integers by their range and
/// to write the field back as it was.
enum class scalar_type : std::uint8_t { int8, uint8, int16, uint16, int32, uint32, int64, uint64, float32, float64 };

/// Size in bytes of one value of `t`.
std::size_t size_of(scalar_type t) noexcept;
/// Canonical name ("uint8", "float32", ...).
std::string_view name_of(scalar_type t) noexcept;
/// True for the integer types.
bool is_integer(scalar_type t) noexcept;
/// The full range of an integer type ([0,255] for uint8, ...). For floating
/// types, [0,1]: float fields are taken to be already normalised.
std::array<double, 2> natural_range(scalar_type t) noexcept;

/// One named per-point field (a "channel"): intensity, red, nir, ...
struct field {
  std::string name;
  scalar_type type = scalar_type::float32;
  std::vector<double> values;  ///< one value per point, as stored in the file
};

/// A point cloud: N positions (float, struct of rows: x0 y0 z0 x1 y1 z1 ...)
/// plus any number of named per-point fields.
///
/// Positions are stored relative to `origin` (double), so georeferenced
/// coordinates such as (500000, 4000000, 100) keep their precision:
/// the absolute position of point i is origin + position(i).
///
/// Threading: const member functions may be called concurrently.
class point_cloud {
 public:
  point_cloud() = default;

  /// Number of points.
  std::size_t size() const noexcept { return m_xyz.size() / 3; }
  bool empty() const noexcept { return m_xyz.empty(); }

  /// N×3 row-major positions relative to origin(), in metres (or the file's unit).
  const std::vector<float>& positions() const noexcept { return m_xyz; }
  std::vector<float>& positions() noexcept { return m_xyz; }
  const float* position(std::size_t i) const noexcept { return m_xyz.data() + 3 * i; }

  /// Appends a point (relative to origin()).
  void push_back(float x, float y, float z) {
    m_xyz.push_back(x);
    m_xyz.push_back(y);
    m_xyz.push_back(z);
  }
  void reserve(std::size_t n) { m_xyz.reserve(3 * n); }
  void resize(std::size_t n) { m_xyz.resize(3 * n); }

  const std::array<double, 3>& origin() const noexcept { return m_origin; }
  void set_origin(const std::array<double, 3>& o) noexcept { m_origin = o; }

  /// Per-point fields, in file order.
  const std::vector<field>& fields() const noexcept { return m_fields; }
  std::vector<field>& fields() noexcept { return m_fields; }

  /// Field by exact name, or nullptr.
  const field* find_field(std::string_view name) const noexcept;
  /// Field by name, ignoring ASCII case, or nullptr.
  const field* find_field_icase(std::string_view name) const noexcept;
  /// Field by exact name; throws std::invalid_argument naming it and listing
  /// the fields present when it is missing.
  const field& get_field(std::string_view name) const;

  /// Adds (or replaces) a field. `values.size()` must equal size().
  field& add_field(std::string name, scalar_type type, std::vector<double> values);

  /// Convenience: adds uchar red/green/blue fields from N×3 bytes.
  void add_rgb(const std::vector<std::array<std::uint8_t, 3>>& rgb);

  /// True when the cloud has red, green and blue fields (any case, or r/g/b).
  bool has_rgb() const noexcept;

  /// Keeps only the points whose `keep[i]` is non-zero, in order (positions and fields).
  void filter(const std::vector<std::uint8_t>& keep);

 private:
  std::vector<float> m_xyz;
  std::array<double, 3> m_origin{0.0, 0.0, 0.0};
  std::vector<field> m_fields;
};

/// The origin every reader uses, per axis: the centre of the finite bounding
/// box [lo, hi] rounded to whole units when that centre lies beyond ±1e4 and
/// beyond the box's extent (georeferenced data), else 0. Positions are then
/// stored as float offsets from it and keep their precision.
std::array<double, 3> choose_origin(const double lo[3], const double hi[3]) noexcept;
/// The same from per-axis coordinate arrays of n points (non-finite skipped).
std::array<double, 3> choose_origin(const double* x, const double* y, const double* z, std::size_t n) noexcept;

/// The red, green and blue fields of a cloud: exact names red/green/blue, then
/// r/g/b, any case. Returns nullptrs when absent.
std::array<const field*, 3> find_rgb_fields(const point_cloud& cloud) noexcept;

}  // namespace ced
