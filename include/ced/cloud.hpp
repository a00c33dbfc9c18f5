// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

namespace ced {

/// Storage type of a per-point field: the type it had in its file, which it
/// keeps in memory (a LAS intensity stays 2 bytes a point). Integers are
/// normalised by their type's range, and fields are written back as they were.
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

/// The scalar_type that stores C++ type `T`.
template <class T>
constexpr scalar_type scalar_type_of() noexcept {
  if constexpr (std::is_same_v<T, std::int8_t>)
    return scalar_type::int8;
  else if constexpr (std::is_same_v<T, std::uint8_t>)
    return scalar_type::uint8;
  else if constexpr (std::is_same_v<T, std::int16_t>)
    return scalar_type::int16;
  else if constexpr (std::is_same_v<T, std::uint16_t>)
    return scalar_type::uint16;
  else if constexpr (std::is_same_v<T, std::int32_t>)
    return scalar_type::int32;
  else if constexpr (std::is_same_v<T, std::uint32_t>)
    return scalar_type::uint32;
  else if constexpr (std::is_same_v<T, std::int64_t>)
    return scalar_type::int64;
  else if constexpr (std::is_same_v<T, std::uint64_t>)
    return scalar_type::uint64;
  else if constexpr (std::is_same_v<T, float>)
    return scalar_type::float32;
  else {
    static_assert(std::is_same_v<T, double>, "not a storage type of a field");
    return scalar_type::float64;
  }
}

/// The storage type that keeps values of any arithmetic type T: T itself
/// when it is one; else the <cstdint> integer of T's size and signedness
/// (long long, char, ...), uint8 for bool, double for other floating types.
/// What the C++ adaptors (ced/eigen.hpp, ced/pcl.hpp) store a channel in.
template <class T>
using storage_type_t = std::conditional_t<
    std::is_same_v<T, bool>, std::uint8_t,
    std::conditional_t<
        std::is_floating_point_v<T>, std::conditional_t<std::is_same_v<T, float>, float, double>,
        std::conditional_t<
            sizeof(T) == 1, std::conditional_t<std::is_signed_v<T>, std::int8_t, std::uint8_t>,
            std::conditional_t<
                sizeof(T) == 2, std::conditional_t<std::is_signed_v<T>, std::int16_t, std::uint16_t>,
                std::conditional_t<sizeof(T) == 4, std::conditional_t<std::is_signed_v<T>, std::int32_t, std::uint32_t>,
                                   std::conditional_t<std::is_signed_v<T>, std::int64_t, std::uint64_t>>>>>>;

/// Calls `f(tag)` with `tag` a value of the C++ type that stores `t`
/// (`decltype(tag)` is std::uint8_t for uint8, ...).
template <class F>
decltype(auto) visit_type(scalar_type t, F&& f) {
  switch (t) {
    case scalar_type::int8:
      return f(std::int8_t{});
    case scalar_type::uint8:
      return f(std::uint8_t{});
    case scalar_type::int16:
      return f(std::int16_t{});
    case scalar_type::uint16:
      return f(std::uint16_t{});
    case scalar_type::int32:
      return f(std::int32_t{});
    case scalar_type::uint32:
      return f(std::uint32_t{});
    case scalar_type::int64:
      return f(std::int64_t{});
    case scalar_type::uint64:
      return f(std::uint64_t{});
    case scalar_type::float32:
      return f(float{});
    case scalar_type::float64:
      break;
  }
  return f(double{});
}

/// `v` converted to storage type T, as fields store values given as double
/// and as writers encode them: integers rounded to nearest and clamped to
/// T's range, NaN to 0; floats by a cast (beyond the float range: ±inf).
/// Never undefined behaviour.
template <class T>
T convert_value(double v) noexcept {
  if constexpr (std::is_floating_point_v<T>) {
    if (std::is_same_v<T, float> && v - v == 0 &&
        (v > double(std::numeric_limits<float>::max()) || v < -double(std::numeric_limits<float>::max())))
      return v > 0 ? std::numeric_limits<T>::infinity() : -std::numeric_limits<T>::infinity();
    return static_cast<T>(v);
  } else {
    if (!(v == v)) return T(0);
    constexpr double lo = double(std::numeric_limits<T>::min()), hi = double(std::numeric_limits<T>::max());
    v = std::round(v);
    if (v <= lo) return std::numeric_limits<T>::min();
    if (v >= hi) return std::numeric_limits<T>::max();
    return static_cast<T>(v);
  }
}

namespace detail {
/// Asks the system to back the `bytes` bytes at `p` with huge pages where it
/// can (Linux transparent huge pages): faulting in a large new block then
/// costs one fault per 2 MiB, not one per 4 KiB page. Only a hint.
void advise_huge_pages(void* p, std::size_t bytes) noexcept;

/// Grows `v`'s capacity to `n` values first, with huge pages, when that is
/// at least 4 MiB: resize() then zeroes memory faulted in 2 MiB at a time.
template <class Vector>
void reserve_large(Vector& v, std::size_t n) {
  constexpr std::size_t large = std::size_t(4) << 20;
  if (n <= v.capacity() || n * sizeof(typename Vector::value_type) < large) return;
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(typename Vector::value_type));
}

/// At least `bytes` bytes in whole 2 MiB pages, 2 MiB-aligned and advised
/// to be huge (advise_huge_pages()); nullptr when there is no memory.
/// Released with std::free.
void* allocate_huge_pages(std::size_t bytes) noexcept;

/// The memory of a column: operator new's, or from 1 MiB on,
/// allocate_huge_pages()'.
void* allocate_column(std::size_t bytes);
void deallocate_column(void* p, std::size_t bytes) noexcept;

/// The allocator of a column's bytes (allocate_column()).
template <class T>
struct column_allocator {
  using value_type = T;
  column_allocator() = default;
  template <class U>
  column_allocator(const column_allocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(allocate_column(n * sizeof(T))); }
  void deallocate(T* p, std::size_t n) noexcept { deallocate_column(p, n * sizeof(T)); }
  friend bool operator==(const column_allocator&, const column_allocator&) noexcept { return true; }
  friend bool operator!=(const column_allocator&, const column_allocator&) noexcept { return false; }
};
}  // namespace detail

/// One column of per-point values kept in their storage type (1 to 8 bytes a
/// value), read as doubles or through a typed pointer.
///
///     double v = column[i];                       // any type, as double
///     if (column.type() == ced::scalar_type::uint16) {
///       const std::uint16_t* p = column.data<std::uint16_t>();  // no copy
///     }
///     column.visit([](const auto* p, std::size_t n) { ... });  // p typed
///
/// Threading: const member functions may be called concurrently.
class column {
 public:
  column() = default;
  /// `n` zeros of `type`.
  explicit column(scalar_type type, std::size_t n = 0) : m_type(type) { resize(n); }
  /// `values` converted to `type` (see convert_value()).
  column(scalar_type type, const std::vector<double>& values);
  /// A column that reads `n` values of `type` at `data` without copying
  /// them; `owner` keeps that memory alive (copies of the column share it).
  /// `data` must be aligned for `type`. The first write (set(), resize(),
  /// a non-const data() or bytes()) copies the values into the column's
  /// own storage first.
  static column view(scalar_type type, const void* data, std::size_t n, std::shared_ptr<const void> owner) {
    column c(type);
    c.m_view = static_cast<const unsigned char*>(data);
    c.m_owner = std::move(owner);
    c.m_size = n;
    return c;
  }
  /// True while the column reads memory it does not own (see view()).
  bool is_view() const noexcept { return m_view != nullptr; }

  scalar_type type() const noexcept { return m_type; }
  std::size_t size() const noexcept { return m_size; }
  bool empty() const noexcept { return m_size == 0; }

  /// Value i as a double (exact for every type but 64-bit integers beyond 2^53).
  double operator[](std::size_t i) const noexcept {
    return visit_type(m_type, [&](auto tag) { return static_cast<double>(data<decltype(tag)>()[i]); });
  }
  /// Sets value i, converted to the column's type (see convert_value()).
  void set(std::size_t i, double v) {
    visit_type(m_type, [&](auto tag) { data<decltype(tag)>()[i] = convert_value<decltype(tag)>(v); });
  }

  /// The values as `T`, which must be the storage type (throws
  /// std::logic_error naming both types otherwise).
  template <class T>
  const T* data() const {
    check_type(scalar_type_of<T>());
    return reinterpret_cast<const T*>(bytes());
  }
  template <class T>
  T* data() {
    check_type(scalar_type_of<T>());
    return reinterpret_cast<T*>(bytes());
  }
  /// Calls `f(const T* values, std::size_t n)` with the column's own type T.
  template <class F>
  decltype(auto) visit(F&& f) const {
    return visit_type(m_type, [&](auto tag) { return f(data<decltype(tag)>(), m_size); });
  }
  template <class F>
  decltype(auto) visit(F&& f) {
    return visit_type(m_type, [&](auto tag) { return f(data<decltype(tag)>(), m_size); });
  }
  /// The raw bytes: size() × size_of(type()).
  const unsigned char* bytes() const noexcept { return m_view ? m_view : m_bytes.data(); }
  unsigned char* bytes() {
    own();
    return m_bytes.data();
  }

  /// Resizes; new values are 0.
  void resize(std::size_t n) {
    own();
    m_bytes.resize(n * size_of(m_type));
    m_size = n;
  }
  /// All values as doubles (a copy).
  std::vector<double> to_doubles() const;

  /// Iterates over the values as doubles.
  class const_iterator {
   public:
    using iterator_category = std::random_access_iterator_tag;
    using value_type = double;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = double;
    const_iterator(const column* c, std::size_t i) noexcept : m_c(c), m_i(i) {}
    double operator*() const noexcept { return (*m_c)[m_i]; }
    double operator[](difference_type k) const noexcept { return (*m_c)[m_i + std::size_t(k)]; }
    const_iterator& operator++() noexcept { return ++m_i, *this; }
    const_iterator operator++(int) noexcept { return {m_c, m_i++}; }
    const_iterator& operator--() noexcept { return --m_i, *this; }
    const_iterator& operator+=(difference_type k) noexcept { return m_i += std::size_t(k), *this; }
    const_iterator operator+(difference_type k) const noexcept { return {m_c, m_i + std::size_t(k)}; }
    const_iterator operator-(difference_type k) const noexcept { return {m_c, m_i - std::size_t(k)}; }
    difference_type operator-(const const_iterator& o) const noexcept { return difference_type(m_i - o.m_i); }
    bool operator==(const const_iterator& o) const noexcept { return m_i == o.m_i; }
    bool operator!=(const const_iterator& o) const noexcept { return m_i != o.m_i; }
    bool operator<(const const_iterator& o) const noexcept { return m_i < o.m_i; }

   private:
    const column* m_c;
    std::size_t m_i;
  };
  const_iterator begin() const noexcept { return {this, 0}; }
  const_iterator end() const noexcept { return {this, m_size}; }

  /// Value by value, as doubles (the types may differ; NaN equals nothing).
  friend bool operator==(const column& a, const column& b) noexcept { return a.equals(b.begin(), b.size()); }
  friend bool operator==(const column& a, const std::vector<double>& b) noexcept {
    return a.equals(b.begin(), b.size());
  }
  friend bool operator==(const std::vector<double>& a, const column& b) noexcept { return b == a; }
  friend bool operator!=(const column& a, const column& b) noexcept { return !(a == b); }
  friend bool operator!=(const column& a, const std::vector<double>& b) noexcept { return !(a == b); }
  friend bool operator!=(const std::vector<double>& a, const column& b) noexcept { return !(b == a); }

 private:
  void check_type(scalar_type t) const {
    if (t != m_type)
      throw std::logic_error("column of " + std::string(name_of(m_type)) + " read as " + std::string(name_of(t)));
  }
  template <class It>
  bool equals(It b, std::size_t n) const noexcept {
    if (n != m_size) return false;
    for (std::size_t i = 0; i < n; ++i, ++b)
      if (!((*this)[i] == *b)) return false;
    return true;
  }

  /// A view becomes a column of its own: the values are copied.
  void own() {
    if (!m_view) return;
    m_bytes.assign(m_view, m_view + m_size * size_of(m_type));
    m_view = nullptr;
    m_owner.reset();
  }

  scalar_type m_type = scalar_type::float64;
  std::size_t m_size = 0;
  std::vector<unsigned char, detail::column_allocator<unsigned char>> m_bytes;  // aligned for any type
  const unsigned char* m_view = nullptr;                                        // see view()
  std::shared_ptr<const void> m_owner;
};

/// Prints a column as its values (for test failures).
std::ostream& operator<<(std::ostream& out, const column& c);

/// One named per-point field (a "channel"): intensity, red, nir, ...
/// A value range [lo, hi] that a channel is normalised by: v' = (v - lo) / (hi - lo).
struct value_range {
  double lo = 0.0;
  double hi = 1.0;
};

struct field {
  std::string name;
  column values;  ///< one value per point, in the type it had in its file
  /// Set when the cloud is a part of a larger one (a tile, see ced/tile_geometry.hpp):
  /// the min and max of this field over the whole cloud. What a modality
  /// decides from the data (`range=auto`, 8-bit colour kept in 16-bit
  /// fields) is then decided from it, so that every part decides alike.
  /// A modality of your own that looks at the data should do the same.
  std::optional<value_range> whole_range;
  /// Set when the cloud is a part of a larger one and a modality needs
  /// statistics of the whole cloud (range=zscore, range=pLO..HI, pca=): the
  /// whole cloud's values at its sample points (whole_sample_index() in
  /// ced/channels.hpp), as field_sample() would take them from it.
  std::shared_ptr<const std::vector<double>> whole_sample;

  field() = default;
  field(std::string n, column v) : name(std::move(n)), values(std::move(v)) {}
  field(std::string n, scalar_type t, const std::vector<double>& v) : name(std::move(n)), values(t, v) {}
  /// The storage type (the file's).
  scalar_type type() const noexcept { return values.type(); }
};

/// Which fields a reader keeps: every field (the default), or those named
/// (matched ignoring ASCII case). A reader skips the others while reading
/// where its format allows (LAS), or drops them right after.
struct field_selection {
  bool all = true;
  std::vector<std::string> names;

  /// Only the fields named in `names`.
  static field_selection only(std::vector<std::string> names) { return {false, std::move(names)}; }
  /// True when the field `name` is kept.
  bool wants(std::string_view name) const noexcept;
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
  void reserve(std::size_t n) {
    detail::reserve_large(m_xyz, 3 * n);
    m_xyz.reserve(3 * n);
  }
  void resize(std::size_t n) {
    detail::reserve_large(m_xyz, 3 * n);
    m_xyz.resize(3 * n);
  }

  const std::array<double, 3>& origin() const noexcept { return m_origin; }
  void set_origin(const std::array<double, 3>& o) noexcept { m_origin = o; }

  /// Per-point fields, in file order.
  const std::vector<field>& fields() const noexcept { return m_fields; }
  /// The same, to change: values, ranges, or fields removed or added at
  /// once. add_field() finds names through an index that this call marks
  /// for rebuilding; names changed through a reference kept past the next
  /// add_field() are not seen by it (call fields() again to change names).
  std::vector<field>& fields() noexcept {
    m_index_stale = true;
    return m_fields;
  }

  /// Field by exact name, or nullptr.
  const field* find_field(std::string_view name) const noexcept;
  /// Field by name, ignoring ASCII case, or nullptr.
  const field* find_field_icase(std::string_view name) const noexcept;
  /// Field by exact name; throws std::invalid_argument naming it and listing
  /// the fields present when it is missing.
  const field& get_field(std::string_view name) const;

  /// Adds (or replaces) a field. `values.size()` must equal size(); the
  /// values are converted to `type` (see convert_value()).
  field& add_field(std::string name, scalar_type type, const std::vector<double>& values);
  /// Adds (or replaces) a field that keeps `values` as they are.
  field& add_field(std::string name, column values);

  /// Convenience: adds uchar red/green/blue fields from N×3 bytes.
  void add_rgb(const std::vector<std::array<std::uint8_t, 3>>& rgb);

  /// True when the cloud has red, green and blue fields (any case, or r/g/b).
  bool has_rgb() const noexcept;

  /// Removes the fields that `selection` does not want.
  void keep_fields(const field_selection& selection);

  /// Keeps only the points whose `keep[i]` is non-zero, in order (positions and fields).
  void filter(const std::vector<std::uint8_t>& keep);

 private:
  std::vector<float> m_xyz;
  std::array<double, 3> m_origin{0.0, 0.0, 0.0};
  std::vector<field> m_fields;
  // add_field's name -> position, so that adding k fields costs O(k), not
  // O(k^2) (readers add one field a column: 65 536 columns are fine).
  std::unordered_map<std::string, std::size_t> m_index;
  bool m_index_stale = false;
};

/// The origin every reader uses, per axis: the centre of the finite bounding
/// box [lo, hi] rounded to whole units when that centre lies beyond ±1e4 and
/// beyond the box's extent (georeferenced data), else 0. Positions are then
/// stored as float offsets from it and keep their precision.
std::array<double, 3> choose_origin(const double lo[3], const double hi[3]) noexcept;
/// The same from per-axis coordinate arrays of n points (non-finite skipped).
std::array<double, 3> choose_origin(const double* x, const double* y, const double* z, std::size_t n) noexcept;

namespace detail {
/// While alive, choose_origin() on this thread gives `origin` whatever the
/// points: how io::read_options::origin reaches the readers. Nests.
class scoped_origin {
 public:
  explicit scoped_origin(const std::array<double, 3>& origin) noexcept;
  ~scoped_origin();
  scoped_origin(const scoped_origin&) = delete;
  scoped_origin& operator=(const scoped_origin&) = delete;

 private:
  const std::array<double, 3>* m_before;
  std::array<double, 3> m_origin;
};
}  // namespace detail

/// Building a cloud from arrays (the Python module, ced/eigen.hpp, ced/pcl.hpp).
///
/// Sets `cloud`'s positions to `n` points read from three coordinate arrays
/// of `type` (float32 or float64), `stride` bytes from one point to the
/// next: float offsets from the origin the file readers choose
/// (choose_origin(); 0 for float input). Throws std::invalid_argument,
/// naming `what` and the point, for a NaN or infinite coordinate, for 2^32 − 1
/// points or more, and for another type.
void set_positions(point_cloud& cloud, scalar_type type, const void* x, const void* y, const void* z,
                   std::ptrdiff_t stride, std::size_t n, std::string_view what = "points");
/// `n` values of `type` starting at `data`, `stride` bytes apart, copied
/// into a column (no alignment needed).
column copy_strided(scalar_type type, const void* data, std::ptrdiff_t stride, std::size_t n);
/// The field names of an N×k channel called `name`, as ced's Python module
/// names them: "a,b,c" names each column; "rgb", "color(s)" or "colour(s)"
/// (any case) with k = 3 give red, green, blue; k = 1 keeps `name`; else
/// name_0 … name_{k−1}. Throws std::invalid_argument naming `what` when a
/// list names another number of columns or a name is empty.
std::vector<std::string> channel_field_names(const std::string& name, std::size_t k,
                                             std::string_view what = "channels");
/// The same names for a channel added to `into`: also std::invalid_argument
/// when `into` has a field of one of them already ("the field 'red' is given
/// twice (by another channel or the cloud)"), so that no value is dropped.
std::vector<std::string> channel_field_names(const point_cloud& into, const std::string& name, std::size_t k,
                                             std::string_view what = "channels");

/// The red, green and blue fields of a cloud: exact names red/green/blue, then
/// r/g/b, any case. Returns nullptrs when absent.
std::array<const field*, 3> find_rgb_fields(const point_cloud& cloud) noexcept;
/// The names find_rgb_fields() looks for, in its order: red, green, blue, r, g, b
/// (for a modality's fields() or a field_selection that must keep colour).
const std::vector<std::string>& rgb_field_names();

}  // namespace ced
