// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/params.hpp"

namespace ced {

/// How a modality normalises a field: its type's natural range (integers:
/// [0, 255] for uint8 ...; floats: used as they are), a fixed range, the
/// data's own min..max ("auto"), its standard deviation ("zscore": a band's
/// differences in units of its σ), or the span between two of its
/// percentiles ("pLO..HI", "quantile" = p2..98: a scale that a few outliers
/// do not set). Only differences are measured, so a range sets a scale: 1 /
/// (hi − lo).
struct range_policy {
  enum class kind { natural, fixed, data, zscore, percentiles } how = kind::natural;
  value_range fixed;  ///< fixed: the range; percentiles: the two percentiles (0..100)

  /// Parses "LO..HI" (e.g. "0..255", "-1..1"), "auto", "zscore", "quantile"
  /// or "pLO..HI" (e.g. "p2..98", 0 ≤ LO < HI ≤ 100); throws
  /// std::invalid_argument naming `option` otherwise.
  static range_policy parse(std::string_view text, const std::string& option = "range");
  /// zscore and percentiles: statistics of the whole cloud (its sample), which
  /// a tiled run's plan gathers once for every tile.
  bool needs_whole_cloud() const noexcept { return how == kind::zscore || how == kind::percentiles; }
};

/// The whole-cloud statistics (range=zscore, range=pLO..HI, pca=) come from a
/// sample of up to this many points, spread evenly through the cloud: all
/// of them in smaller clouds.
inline constexpr std::size_t whole_sample_size = 20000;

/// The sample's size for a cloud of n points: min(n, whole_sample_size).
inline std::size_t whole_sample_count(std::uint64_t n) noexcept {
  return n < whole_sample_size ? static_cast<std::size_t>(n) : whole_sample_size;
}

/// The index of the sample's j-th point in a cloud of n points: ⌊j·n/m⌋ with
/// m = whole_sample_count(n), ascending.
inline std::uint64_t whole_sample_index(std::size_t j, std::uint64_t n) noexcept {
  return std::uint64_t(j) * n / whole_sample_count(n);
}

/// f's values at the sample points (whole_sample_index()): f.whole_sample
/// when it is set (a tile of a larger cloud), else taken from f's values.
/// Throws std::invalid_argument, naming the field, for a tile without one.
std::vector<double> field_sample(const field& f);

/// The range `policy` gives for `f` (a degenerate data range becomes [lo, lo+1]).
/// The data's range is `f.whole_range` when it is set (a tile of a larger
/// cloud), else the min..max of `f`'s values. zscore: [mean, mean + σ];
/// percentiles: the two percentiles (linear between the sorted values);
/// both of the whole cloud's sample (field_sample()).
value_range resolve_range(const field& f, const range_policy& policy);

/// The min and max of f's values: f.whole_range when it is set (a tile of a
/// larger cloud), else over its values; {0, 0} when it has none. (range=auto
/// is this, with a degenerate range widened to [lo, lo+1].)
value_range data_range(const field& f);

/// True when `f` is a 16-bit integer field whose values all lie in [0, 255]
/// (its whole_range when set, as in a tile): 8-bit data stored in 16 bits,
/// common in LAS files, which rgb and intensity then scale by 255.
bool holds_8bit_in_16(const field& f);

/// For integer fields wider than 16 bits (numpy's default int64, PLY's int):
/// [0, 255] when every value (its whole_range when set, as in a tile) lies
/// in it, else [0, 65535] when every value does, else nothing. rgb, lab and
/// intensity then scale them as 8- or 16-bit data: by their type's own
/// range (2^32 or 2^64 wide) the colours would all but vanish.
std::optional<value_range> narrow_integer_range(const field& f);

/// N×D floats, row-major: the raw values of `fields` (D = fields.size()).
/// Throws std::invalid_argument naming the field and point when a value is
/// NaN, infinite or beyond the float range (it would become infinite).
std::vector<float> interleave(const std::vector<const field*>& fields);
/// The same on up to `threads` threads (0 = all cores); the result does not
/// depend on the thread count.
std::vector<float> interleave(const std::vector<const field*>& fields, unsigned threads);

/// The first `k` principal components of the fields (each value times its
/// `scale` first), N×k floats: every point's values less their means,
/// projected on the k eigenvectors of the largest eigenvalues of their
/// covariance. The means and covariance come from up to 20,000 points spread
/// evenly through the cloud (all of them in smaller clouds), in double; the
/// eigenvectors from orthogonal iteration and a Jacobi step, with a fixed
/// start and each vector's largest component made positive: the same bits
/// for any thread count and on any CPU. `eigenvalues`, when given, receives
/// all k eigenvalues, largest first. The sample is field_sample()'s, so a
/// tile whose fields carry the whole cloud's sample gets the whole cloud's
/// components. Throws std::invalid_argument unless 1 ≤ k ≤ fields.size(),
/// or for a tile without the sample.
std::vector<float> principal_components(const std::vector<const field*>& fields, const std::vector<double>& scale,
                                        std::size_t k, unsigned threads, std::vector<double>* eigenvalues = nullptr);

/// What require_fields() throws when the cloud lacks a field: the message
/// names the modality, the field and the fields present; the members keep
/// the first two (a caller that read only some of a file's fields can then
/// name the file's own).
struct missing_field_error : std::invalid_argument {
  missing_field_error(std::string modality, std::string field, const std::string& message)
      : std::invalid_argument(message), modality_name(std::move(modality)), field_name(std::move(field)) {}
  std::string modality_name, field_name;
};

/// The end of a missing field's message when one of `present` is `field`
/// with a prefix, as CloudCompare writes scalar fields ("scalar_intensity"):
/// "; did you mean 'scalar_intensity'?", and for a modality named as the
/// field, how to name it in the spec; otherwise empty.
std::string missing_field_hint(const std::vector<std::string>& present, const std::string& field,
                               const std::string& modality);

/// The fields of `cloud` named in `names` (exact name first, then any case);
/// throws missing_field_error naming `modality`, the missing field and the
/// fields present (and missing_field_hint()), or std::invalid_argument when
/// a value is NaN or infinite.
std::vector<const field*> require_fields(const point_cloud& cloud, const std::vector<std::string>& names,
                                         const std::string& modality);

/// Field names with ranges expanded, for modalities that take many fields
/// (bands): `b000..b191` is b000, b001, ..., b191. Both ends end in digits
/// after the same text; the names are zero-padded to the first end's width
/// when its digits start with 0 or both ends have as many digits
/// (`b08..b12`: b08 ... b12; `b1..b12`: b1 ... b12). Other names, globs
/// included, are kept. Throws std::invalid_argument for a malformed range,
/// one that runs backwards, or one of more than 65,536 names.
std::vector<std::string> expand_field_ranges(const std::vector<std::string>& names);
/// True when field `name` matches `pattern`, ignoring case: `*` stands for
/// any run of characters and `?` for any one; without them, equality.
bool field_name_matches(std::string_view pattern, std::string_view name) noexcept;
/// require_fields() for names that may be ranges or globs: ranges are
/// expanded (expand_field_ranges), a glob stands for every field of the
/// cloud it matches, in the cloud's order, and must match at least one
/// (missing_field_error otherwise). A field named twice, by any of them, is
/// an error naming it.
std::vector<const field*> require_field_patterns(const point_cloud& cloud, const std::vector<std::string>& names,
                                                 const std::string& modality);

/// Throws std::invalid_argument naming `modality`, the field and the first
/// point whose value is NaN, infinite or beyond the float range (channels are
/// computed in float).
void require_finite(const field& f, const std::string& modality);

/// sRGB in [0,1] to CIELAB (D65 white): L in [0,100], a and b about [-128,127].
std::array<float, 3> srgb_to_lab(float r, float g, float b) noexcept;
/// The two steps of srgb_to_lab: an sRGB component in [0,1] to linear light,
/// and linear sRGB to CIELAB. srgb_to_lab(r,g,b) ==
/// linear_srgb_to_lab(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b)).
double srgb_to_linear(float c) noexcept;
std::array<float, 3> linear_srgb_to_lab(double r, double g, double b) noexcept;
/// linear_srgb_to_lab of n colours (r[i], g[i], b[i]) into lab[3i .. 3i+2],
/// several at a time: the same values, at about half the cost.
void linear_srgb_to_lab(const double* r, const double* g, const double* b, std::size_t n, float* lab) noexcept;
/// N×3 floats, row-major: the CIELAB colour of every point, from its red,
/// green and blue fields `f` scaled into [0,1] by `scale` (sRGB), on up to
/// `threads` threads (0 = all cores; the result does not depend on it).
std::vector<float> lab_values(const std::array<const field*, 3>& f, const std::array<double, 3>& scale,
                              unsigned threads);

/// Unit normals by local PCA: for every point, the eigenvector of the
/// smallest eigenvalue of the covariance of its neighbours within `radius`
/// (itself included), N×3 floats, row-major. The sign is not oriented (the
/// largest component is made positive). Points with fewer than 3 neighbours,
/// or all at one place, get (0, 0, 0). The moments Σ d and Σ d dᵀ of the
/// offsets d = p_j − p_i are summed by the neighbour pass itself, in float
/// vector lanes in an order fixed by the grid's sub-cells, and the
/// eigenvector found by Jacobi rotations in double: the result is the same
/// for any thread count and instruction set and in any tile that holds the
/// neighbours. `threads`: 0 = all cores. Throws std::invalid_argument unless
/// radius > 0.
std::vector<float> estimate_normals(const point_cloud& cloud, double radius, unsigned threads = 0);
/// The same over each point's neighbourhood under `params` (its radius,
/// neighbourhood, search and threads), scaled by `factor` in (0, 1]: under
/// the fixed radius the ball of factor × radius, as above; under knn:K the
/// K nearest (factor 1) or the ball of factor × the K-th distance; under
/// adaptive the ball of factor × each point's own radius. Under knn,
/// adaptive and search = cgal the moments are summed in double over the
/// neighbours in index order (normal_from_neighbors). Throws
/// std::invalid_argument for bad parameters.
std::vector<float> estimate_normals(const point_cloud& cloud, const detect_params& params, double factor = 1.0);
/// One point's normal from its `n` neighbours (indices into `xyz`, N×3
/// floats), the moments summed in double in the given order: bitwise
/// estimate_normals' under knn, adaptive and search = cgal (neighbours by
/// index), and within float rounding of it under the grid's fixed radius.
void normal_from_neighbors(const float* xyz, std::uint32_t point, const std::uint32_t* neighbors, std::uint32_t n,
                           float out[3]) noexcept;
/// N×6 floats: the orientation tensor n nᵀ of every normal (N×3, made unit
/// length; zero stays zero) as (xx, yy, zz, xy, xz, yz). It is the same for n
/// and −n, so normals of any orientation compare. Throws
/// std::invalid_argument naming the point when a normal is not finite.
std::vector<float> normal_tensors(const std::vector<float>& normals);

}  // namespace ced
