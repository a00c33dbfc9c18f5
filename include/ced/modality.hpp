// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "ced/centroid_distance.hpp"
#include "ced/cloud.hpp"
#include "ced/neighborhood.hpp"
#include "ced/params.hpp"

namespace ced {

// ---------------------------------------------------------------------------
// The Modality concept (docs/MODALITIES.md has the full contract)
//
// A modality is a small value type `M` with
//   std::string name() const;                       // e.g. "rgb", "bands(nir,red)"
//   double threshold(const detect_params&) const;   // absolute, in saliency units
//   E bind(const point_cloud&, const detect_params&) const;
// where the evaluator E returned by bind() owns whatever per-point data it
// prepared, must be safe to call concurrently, and is one of two kinds:
//
// (a) Sums of channels, the fast path (SumsEvaluator):
//       channel_source channels() const;   // N×dims floats the pass sums
//       float from_sums(const double* sums, std::uint32_t n) const;
//     The detector sums Σ_{j ∈ N(i)} (v_j − v_i) of the channels in its own
//     vectorised neighbour pass, for all such modalities at once, and calls
//     from_sums(sums, |N(i)|) per point. centroid_distance<D> is the model
//     the built-ins return. A saliency that needs the point's own values
//     (the neighbours' mean is v_i + sums/n) takes the point's index:
//       float from_sums(const double* sums, std::uint32_t n, std::uint32_t i) const;
// (b) Neighbour lists (ListEvaluator), for any other measure (a circular
//     mean, a median, a covariance...):
//       float operator()(const neighborhood&) const;   // one point's saliency
//     It is given the point and the indices of its neighbours.
// (c) Whole blocks (BlockEvaluator), for measures that work in batches (a
//     call into Python, a vectorised library, a GPU):
//       void evaluate(const block_view&, float* out) const;
//     writes out[k] for the block's k-th point, k < block.size(); block[k]
//     is its neighbour list. Points with fewer than min_neighbors
//     neighbours get 0 whatever it writes.
// An evaluator that offers several kinds is run as the first of (a), (c), (b).
//
// Optionally, M declares the fields bind() reads (names matched ignoring
// case), so that the CLI reads only those from a file:
//   std::vector<std::string> fields() const;        // {} for positions only
// Without it, every field is read.
//
// Optionally, M declares that bind() makes a point's channel from that
// point's own neighbourhood under detect_params::neighborhood (as the
// normals modality's estimate under knn or adaptive):
//   bool channels_from_neighborhoods() const;
// A neighbour's channel then depends on the neighbour's neighbourhood, one
// hop farther, and tiles grow their halo and their reach check for it
// (tile_halo_params, tile_check_extra). Without it: false, a channel that
// depends on the point alone or on a fixed ball within the detection radius.
//
// To be usable from strings (CLI, config, plugins), M also provides
//   static constexpr const char* spec_name = "rgb";
//   static M from_spec(modality_spec&);
// and is registered once with register_modality<M>().
// ---------------------------------------------------------------------------

template <class M>
using evaluator_t =
    decltype(std::declval<const M&>().bind(std::declval<const point_cloud&>(), std::declval<const detect_params&>()));

namespace detail {
template <class E, class = void>
struct sums_neighbors : std::false_type {};
template <class E>
struct sums_neighbors<
    E, std::void_t<decltype(channel_source(std::declval<const E&>().channels())),
                   decltype(float(std::declval<const E&>().from_sums(std::declval<const double*>(), std::uint32_t{})))>>
    : std::true_type {};
// (a) with the point: from_sums(sums, n, point), for a saliency that needs the
// point's own channel values (the mean is v_point + sums / n).
template <class E, class = void>
struct sums_at_point : std::false_type {};
template <class E>
struct sums_at_point<E, std::void_t<decltype(channel_source(std::declval<const E&>().channels())),
                                    decltype(float(std::declval<const E&>().from_sums(
                                        std::declval<const double*>(), std::uint32_t{}, std::uint32_t{})))>>
    : std::true_type {};

template <class E, class = void>
struct reads_neighbors : std::false_type {};
template <class E>
struct reads_neighbors<E, std::void_t<decltype(float(std::declval<const E&>()(std::declval<const neighborhood&>())))>>
    : std::true_type {};

template <class E, class = void>
struct evaluates_blocks : std::false_type {};
template <class E>
struct evaluates_blocks<E, std::void_t<decltype(std::declval<const E&>().evaluate(
                               std::declval<const block_view&>(), std::declval<float*>()))>> : std::true_type {};

template <class M, class = void>
struct declares_fields : std::false_type {};
template <class M>
struct declares_fields<M, std::void_t<decltype(std::vector<std::string>(std::declval<const M&>().fields()))>>
    : std::true_type {};

template <class M, class = void>
struct declares_neighborhood_channels : std::false_type {};
template <class M>
struct declares_neighborhood_channels<
    M, std::void_t<decltype(bool(std::declval<const M&>().channels_from_neighborhoods()))>> : std::true_type {};

template <class M, class = void>
struct declares_whole_cloud_fields : std::false_type {};
template <class M>
struct declares_whole_cloud_fields<
    M, std::void_t<decltype(std::vector<std::string>(std::declval<const M&>().whole_cloud_fields()))>>
    : std::true_type {};

template <class M, class = void>
struct is_modality : std::false_type {};
template <class M>
struct is_modality<
    M, std::void_t<decltype(std::string(std::declval<const M&>().name())),
                   decltype(double(std::declval<const M&>().threshold(std::declval<const detect_params&>()))),
                   evaluator_t<M>>>
    : std::bool_constant<sums_neighbors<evaluator_t<M>>::value || sums_at_point<evaluator_t<M>>::value ||
                         reads_neighbors<evaluator_t<M>>::value || evaluates_blocks<evaluator_t<M>>::value> {};
}  // namespace detail

/// True for evaluators (like centroid_distance) whose saliency the detector
/// computes from neighbourhood sums of their channels in its own pass: (a).
template <class E>
inline constexpr bool sums_neighbors_v = detail::sums_neighbors<E>::value || detail::sums_at_point<E>::value;

/// True for evaluators that compute a point's saliency from its neighbour
/// list: (b).
template <class E>
inline constexpr bool reads_neighbors_v = detail::reads_neighbors<E>::value;

/// True for evaluators that compute the saliencies of a whole block of
/// points at once: (c).
template <class E>
inline constexpr bool evaluates_blocks_v = detail::evaluates_blocks<E>::value;

/// The fields modality `m` reads (matched ignoring case), or nullopt when it
/// does not say (then it may read any).
template <class M>
std::optional<std::vector<std::string>> fields_of(const M& m) {
  if constexpr (detail::declares_fields<M>::value)
    return std::vector<std::string>(m.fields());
  else
    return std::nullopt;
}

/// The fields whose whole-cloud sample modality `m` needs (its
/// whole_cloud_fields(): fields or globs, as fields() names them; none when
/// it does not say): a tiled run's plan gathers it, so that every tile
/// decides what the whole cloud would (field::whole_sample).
template <class M>
std::vector<std::string> whole_cloud_fields_of(const M& m) {
  if constexpr (detail::declares_whole_cloud_fields<M>::value)
    return std::vector<std::string>(m.whole_cloud_fields());
  else
    return {};
}

/// Whether modality `m` makes a point's channel from the point's own
/// neighbourhood (its channels_from_neighborhoods(); false when it does not say).
template <class M>
bool channels_from_neighborhoods_of(const M& m) {
  if constexpr (detail::declares_neighborhood_channels<M>::value)
    return bool(m.channels_from_neighborhoods());
  else
    return false;
}

/// True when M models the Modality concept above.
template <class M>
inline constexpr bool is_modality_v = detail::is_modality<M>::value;

#ifdef __cpp_concepts
template <class E>
concept SumsEvaluator = sums_neighbors_v<E>;
template <class E>
concept ListEvaluator = reads_neighbors_v<E>;
template <class E>
concept BlockEvaluator = evaluates_blocks_v<E>;
template <class M>
concept Modality = is_modality_v<M>;
#endif

/// The channels the neighbour pass sums for evaluator `e` (none for an
/// evaluator that reads neighbour lists).
template <class E>
channel_source channels_of(const E& e) {
  if constexpr (sums_neighbors_v<E>)
    return e.channels();
  else
    return {};
}

/// Saliency of every point of a block into column[point] (0 for points with
/// fewer than `min_neighbors` neighbours). `slot` is the modality's channel
/// slot in the block. Shared by both composition paths.
template <class Evaluator>
void evaluate_block(const Evaluator& e, const block_view& block, std::size_t slot, std::uint32_t min_neighbors,
                    float* column) {
  if constexpr (!sums_neighbors_v<Evaluator> && evaluates_blocks_v<Evaluator>) {
    thread_local std::vector<float> out;  // per worker, reused from block to block
    out.assign(block.size(), 0.0f);
    e.evaluate(block, out.data());
    for (std::size_t k = 0; k < block.size(); ++k)
      column[block.point(k)] = block.count(k) >= min_neighbors ? out[k] : 0.0f;
  } else {
    for (std::size_t k = 0; k < block.size(); ++k) {
      const std::uint32_t n = block.count(k);
      float s = 0.0f;
      if (n >= min_neighbors) {
        if constexpr (detail::sums_at_point<Evaluator>::value)
          s = e.from_sums(block.sums(k, slot), n, block.point(k));
        else if constexpr (sums_neighbors_v<Evaluator>)
          s = e.from_sums(block.sums(k, slot), n);
        else
          s = static_cast<float>(e(block[k]));
      }
      column[block.point(k)] = s;
    }
  }
}

// ---------------------------------------------------------------------------
// Runtime composition: type erasure
// ---------------------------------------------------------------------------

/// A modality bound to a cloud, behind one virtual call per block.
class bound_modality {
 public:
  virtual ~bound_modality() = default;
  virtual channel_source channels() const = 0;
  virtual void evaluate(const block_view& block, std::size_t slot, std::uint32_t min_neighbors,
                        float* column) const = 0;
};

/// Any modality, type-erased (value semantics, like std::function).
class any_modality {
 public:
  any_modality() = default;
  template <class M,
            class = std::enable_if_t<is_modality_v<std::decay_t<M>> && !std::is_same_v<std::decay_t<M>, any_modality>>>
  any_modality(M m)  // NOLINT(google-explicit-constructor): like std::function
      : m_self(std::make_shared<model<std::decay_t<M>>>(std::move(m))) {}

  explicit operator bool() const noexcept { return m_self != nullptr; }
  std::string name() const { return m_self->name(); }
  double threshold(const detect_params& p) const { return m_self->threshold(p); }
  /// The fields it reads (matched ignoring case), or nullopt: any.
  std::optional<std::vector<std::string>> fields() const { return m_self->fields(); }
  /// Whether it makes a point's channel from the point's own neighbourhood.
  bool channels_from_neighborhoods() const { return m_self->channels_from_neighborhoods(); }
  /// The fields whose whole-cloud sample it needs (whole_cloud_fields_of()).
  std::vector<std::string> whole_cloud_fields() const { return m_self->whole_cloud_fields(); }
  std::unique_ptr<bound_modality> bind(const point_cloud& c, const detect_params& p) const {
    return m_self->bind(c, p);
  }
  /// The same modality with its threshold replaced by `t` (in the units
  /// threshold() returns, after the ratio: metres for xyz). With 0 every
  /// point is a candidate, so the NMS ranks all maxima: the top-N protocol
  /// of `ced eval --counts`.
  any_modality with_threshold(double t) const {
    any_modality out;
    if (m_self) out.m_self = std::make_shared<const fixed_threshold>(m_self, t);
    return out;
  }

 private:
  struct concept_t {
    virtual ~concept_t() = default;
    virtual std::string name() const = 0;
    virtual double threshold(const detect_params&) const = 0;
    virtual std::optional<std::vector<std::string>> fields() const = 0;
    virtual bool channels_from_neighborhoods() const = 0;
    virtual std::vector<std::string> whole_cloud_fields() const = 0;
    virtual std::unique_ptr<bound_modality> bind(const point_cloud&, const detect_params&) const = 0;
  };
  template <class M>
  struct model final : concept_t {
    explicit model(M m) : modality(std::move(m)) {}
    struct bound final : bound_modality {
      explicit bound(evaluator_t<M> e) : evaluator(std::move(e)) {}
      channel_source channels() const override { return channels_of(evaluator); }
      void evaluate(const block_view& b, std::size_t slot, std::uint32_t k, float* column) const override {
        ced::evaluate_block(evaluator, b, slot, k, column);
      }
      evaluator_t<M> evaluator;
    };
    std::string name() const override { return std::string(modality.name()); }
    double threshold(const detect_params& p) const override { return modality.threshold(p); }
    std::optional<std::vector<std::string>> fields() const override { return fields_of(modality); }
    bool channels_from_neighborhoods() const override { return channels_from_neighborhoods_of(modality); }
    std::vector<std::string> whole_cloud_fields() const override { return whole_cloud_fields_of(modality); }
    std::unique_ptr<bound_modality> bind(const point_cloud& c, const detect_params& p) const override {
      return std::make_unique<bound>(modality.bind(c, p));
    }
    M modality;
  };
  struct fixed_threshold final : concept_t {
    fixed_threshold(std::shared_ptr<const concept_t> m, double t) : inner(std::move(m)), value(t) {}
    std::string name() const override { return inner->name(); }
    double threshold(const detect_params&) const override { return value; }
    std::optional<std::vector<std::string>> fields() const override { return inner->fields(); }
    bool channels_from_neighborhoods() const override { return inner->channels_from_neighborhoods(); }
    std::vector<std::string> whole_cloud_fields() const override { return inner->whole_cloud_fields(); }
    std::unique_ptr<bound_modality> bind(const point_cloud& c, const detect_params& p) const override {
      return inner->bind(c, p);
    }
    std::shared_ptr<const concept_t> inner;
    double value;
  };
  std::shared_ptr<const concept_t> m_self;  // immutable, so sharing is safe
};

// ---------------------------------------------------------------------------
// Modality specs and the registry
// ---------------------------------------------------------------------------

/// A parsed modality spec: `name[(arg,...)][:threshold][,key=value...]`, e.g.
/// `xyz:0.2`, `rgb`, `bands(nir,red_edge):0.1,range=0..255`, `intensity(amplitude),range=auto`.
class modality_spec {
 public:
  /// Throws std::invalid_argument with the spec and the position of the problem.
  static modality_spec parse(std::string_view text);

  const std::string& text() const noexcept { return m_text; }
  const std::string& name() const noexcept { return m_name; }
  /// The field list in parentheses (reading it marks it as used).
  const std::vector<std::string>& args() const noexcept {
    m_args_read = true;
    return m_args;
  }
  /// True when a field list was given but no one read it.
  bool args_unused() const noexcept { return !m_args.empty() && !m_args_read; }
  /// The threshold after ':', or `fallback` when none was given.
  double threshold_or(double fallback) const noexcept { return m_threshold.value_or(fallback); }
  const std::optional<double>& threshold() const noexcept { return m_threshold; }

  /// Returns and consumes option `key` (options never consumed are an error).
  std::optional<std::string> take(const std::string& key);
  /// Options never taken, for the registry's "unknown option" error.
  std::vector<std::string> unused_options() const;

 private:
  std::string m_text, m_name;
  std::vector<std::string> m_args;
  std::optional<double> m_threshold;
  std::map<std::string, std::string> m_options;
  std::map<std::string, bool> m_taken;
  mutable bool m_args_read = false;
};

using modality_factory = std::function<any_modality(modality_spec&)>;

/// Registers (or replaces) a modality under `name`. Thread-safe.
void register_modality(const std::string& name, modality_factory factory, std::string help = {});

/// The factory that builds M from a spec with M::from_spec.
template <class M>
modality_factory factory_of() {
  static_assert(is_modality_v<M>, "M does not model the Modality concept (see ced/modality.hpp)");
  return [](modality_spec& s) { return any_modality(M::from_spec(s)); };
}

/// Registers M under M::spec_name, built with M::from_spec.
template <class M>
void register_modality(std::string help = {}) {
  register_modality(M::spec_name, factory_of<M>(), std::move(help));
}

/// Names and one-line help of all registered modalities (built-ins included), sorted.
std::vector<std::pair<std::string, std::string>> registered_modalities();

/// Modality specs joined by commas, as `ced eval --detector` takes them
/// (`xyz:0.25,rgb:0.12,range=0..255`): split at commas outside parentheses,
/// where a piece of the form key=value (before any ':' or '(') is an option
/// of the spec before it.
std::vector<std::string> split_modality_specs(std::string_view text);

/// Builds a modality from a spec string. Throws std::invalid_argument for an
/// unknown name (listing the known ones), a bad threshold or unknown options.
any_modality make_modality(std::string_view spec);

/// The modalities of a preset: "ced3d" = xyz:0.2; "ced6d" = xyz:0.2 + rgb:0.1;
/// the others as preset_specs() gives them. Throws std::invalid_argument
/// for an unknown name, listing the known ones.
std::vector<any_modality> preset(std::string_view name);
/// The modality specs of a preset (make_modality() of each gives preset(name)).
std::vector<std::string> preset_specs(std::string_view name);
/// The presets' names.
std::vector<std::string> preset_names();
/// Whether a preset refines its keypoints (detect_params::refine): the
/// robust presets and corner3d do, the paper's (ced3d, ced6d) do not.
bool preset_refines(std::string_view name);
/// The share of the candidates a preset keeps as keypoints at most
/// (detect_params::keypoint_share): 0.01 for robust3d and robust6d, whose
/// counts would otherwise grow with noise; 0 (no limit) for the others.
double preset_keypoint_share(std::string_view name);

/// Parses a number; throws std::invalid_argument naming `what` on failure.
double parse_number(std::string_view text, const std::string& what);

}  // namespace ced
