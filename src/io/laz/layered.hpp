// SPDX-License-Identifier: MIT
// Private to src/io: LAZ's layered compression of LAS 1.4 point formats 6-8
// (items point14, rgb14, rgbnir14 and byte14, version 3; chunks.cpp). A chunk
// holds its first record as it is, its point count, the byte size of every
// layer, then the layers: each field group (x/y with returns and channel,
// z, classification, flags, intensity, scan angle, user data, point source,
// GPS time, colour, NIR, each extra byte) is its own arithmetic-coded
// stream, and a layer of 0 bytes means the field does not change in the
// chunk. The state and models are kept per scanner channel (4 contexts).
#pragma once

#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "io/laz/types.hpp"
#include "io/laz/coder.hpp"
#include "io/laz/items.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io::detail::laz {

/// One arithmetic-coded layer of a chunk: its bytes, and a decoder over them
/// when it has any.
struct layer {
  const unsigned char* begin = nullptr;
  const unsigned char* end = nullptr;
  decoder dec;
  bool changes() const noexcept { return end != begin; }
  void start() {
    if (changes()) dec.start(begin, end);
  }
  /// The decoder must have read exactly the layer (what its encoder wrote).
  void check_end(const char* name) const {
    if (changes() && dec.position() != end)
      throw corrupt(std::string("the ") + name + " layer has " + std::to_string(end - dec.position()) +
                    " bytes after its last point");
  }
};

/// The fields of a point14 record that are coded (LAS 1.4 point formats 6-10).
struct point14_fields {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint16_t intensity = 0;
  unsigned ret = 0, returns = 0;  ///< return number and number of returns, 4 bits each
  unsigned class_flags = 0, channel = 0, scan_direction = 0, edge = 0;
  unsigned classification = 0, user_data = 0;
  std::int16_t scan_angle = 0;
  std::uint16_t source = 0;
  std::int64_t gps = 0;  ///< the double's bits
  bool gps_changed = false;

  void read(const unsigned char* r) {
    x = load_le<std::int32_t>(r);
    y = load_le<std::int32_t>(r + 4);
    z = load_le<std::int32_t>(r + 8);
    intensity = load_le<std::uint16_t>(r + 12);
    ret = r[14] & 15u;
    returns = r[14] >> 4;
    class_flags = r[15] & 15u;
    channel = (r[15] >> 4) & 3u;
    scan_direction = (r[15] >> 6) & 1u;
    edge = r[15] >> 7;
    classification = r[16];
    user_data = r[17];
    scan_angle = load_le<std::int16_t>(r + 18);
    source = load_le<std::uint16_t>(r + 20);
    gps = load_le<std::int64_t>(r + 22);
  }
  void write(unsigned char* r) const {
    store_le<std::int32_t>(r, x);
    store_le<std::int32_t>(r + 4, y);
    store_le<std::int32_t>(r + 8, z);
    store_le<std::uint16_t>(r + 12, intensity);
    r[14] = static_cast<unsigned char>(ret | returns << 4);
    r[15] = static_cast<unsigned char>(class_flags | channel << 4 | scan_direction << 6 | edge << 7);
    r[16] = static_cast<unsigned char>(classification);
    r[17] = static_cast<unsigned char>(user_data);
    store_le<std::int16_t>(r + 18, scan_angle);
    store_le<std::uint16_t>(r + 20, source);
    store_le<std::int64_t>(r + 22, gps);
  }
};

/// A model per index, made when first needed.
template <std::size_t N>
class lazy_models {
 public:
  explicit lazy_models(std::uint32_t symbols) : m_symbols(symbols) {}
  symbol_model& operator[](std::size_t i) {
    if (!m[i]) m[i] = std::make_unique<symbol_model>(m_symbols);
    return *m[i];
  }

 private:
  std::uint32_t m_symbols;
  std::unique_ptr<symbol_model> m[N];
};

/// The state and models of point14 v3 for one scanner channel (its
/// decoder and encoder share it).
struct point14_context {
  explicit point14_context(const point14_fields& from) : last(from) {
    last.gps_changed = false;
    for (auto& v : last_z) v = from.z;
    for (auto& v : last_intensity) v = from.intensity;
    gps.time[0] = from.gps;
  }
  point14_fields last;
  symbol_model changed[8] = {symbol_model(128), symbol_model(128), symbol_model(128), symbol_model(128),
                             symbol_model(128), symbol_model(128), symbol_model(128), symbol_model(128)};
  symbol_model scanner{3}, return_gps_same{13};
  lazy_models<16> returns_of{16}, return_of{16};
  integer_coder dx{32, 2}, dy{32, 22}, dz{32, 20};
  median5 x_med[12], y_med[12];
  std::int32_t last_z[8];
  lazy_models<64> class_of{256}, flags_of{64}, user_of{256};
  integer_coder ic_intensity{16, 4}, ic_angle{16, 2}, ic_source{16, 1};
  std::uint16_t last_intensity[8];
  // GPS time: the sequences of gpstime11, coded only when the time changed.
  gps_sequences gps;
  symbol_model multi{515}, zero_diff{5};
};

/// Which of 6 and 8 contexts a (number of returns, return number) pair
/// uses for x/y and z; pairs a well-formed file does not have share some.
inline constexpr unsigned char k_point14_map6[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5}};

/// The contexts a point's number of returns n and return number r select:
/// of x/y (m), of z (l, how far r is from n), of intensity and
/// classification (cpr: first, last), and whether it is a single return.
struct return_contexts {
  unsigned m, l, cpr, single;
  return_contexts(unsigned n, unsigned r)
      : m(k_point14_map6[n][r]),
        l(n > r ? (n - r > 7 ? 7 : n - r) : (r - n > 7 ? 7 : r - n)),
        cpr((r == 1 ? 2u : 0u) + (r >= n ? 1u : 0u)),
        single(n == 1 ? 1u : 0u) {}
};

/// point14 v3: x, y and the returns in one layer, each other field in its own.
class point14_v3 {
  using context = point14_context;

 public:
  enum { xy, z, classification, flags, intensity, scan_angle, user_data, source, gps, layer_count };

  /// `first`: the chunk's first record; `layers`: the 9 layers.
  point14_v3(const unsigned char* first, layer* layers) : m_layers(layers) {
    point14_fields f;
    f.read(first);
    m_current = f.channel;
    m_ctx[m_current] = std::make_unique<context>(f);
  }
  /// The scanner channel of the last record: the context of the other items.
  unsigned channel() const noexcept { return m_current; }

  void decode(unsigned char* out) {
    decoder& d = m_layers[xy].dec;
    context* c = m_ctx[m_current].get();
    {
      const point14_fields& last = c->last;
      const unsigned lpr =
          (last.ret == 1 ? 1u : 0u) + (last.ret >= last.returns ? 2u : 0u) + (last.gps_changed ? 4u : 0u);
      const std::uint32_t changed = d.symbol(c->changed[lpr]);
      if (changed & 64) {  // another scanner channel: its own context
        const unsigned channel = (m_current + d.symbol(c->scanner) + 1) % 4;
        if (!m_ctx[channel]) m_ctx[channel] = std::make_unique<context>(c->last);
        m_current = channel;
        c = m_ctx[channel].get();
        c->last.channel = channel;
      }
      decode_fields(*c, changed);
    }
    c->last.write(out);
  }

  void check_ends() const {
    static const char* const names[layer_count] = {"x/y/returns", "z",         "classification", "flags",   "intensity",
                                                   "scan angle",  "user data", "point source",   "GPS time"};
    for (int i = 0; i < layer_count; ++i) m_layers[i].check_end(names[i]);
  }

 private:
  void decode_fields(context& c, std::uint32_t changed) {
    decoder& d = m_layers[xy].dec;
    point14_fields& p = c.last;
    const bool source_changed = (changed & 32) != 0, gps_changed = (changed & 16) != 0,
               angle_changed = (changed & 8) != 0;
    const unsigned last_n = p.returns, last_r = p.ret;
    if (changed & 4) p.returns = d.symbol(c.returns_of[last_n]);
    switch (changed & 3) {
      case 1:
        p.ret = (last_r + 1) % 16;
        break;
      case 2:
        p.ret = (last_r + 15) % 16;
        break;
      case 3:
        p.ret = gps_changed ? d.symbol(c.return_of[last_r]) : (last_r + d.symbol(c.return_gps_same) + 2) % 16;
        break;
      default:
        break;
    }
    const return_contexts rc(p.returns, p.ret);
    const unsigned l = rc.l, cpr = rc.cpr, single = rc.single;
    const unsigned xy_ctx = (rc.m << 1) | (gps_changed ? 1u : 0u);
    std::int32_t diff = c.dx.decode(d, c.x_med[xy_ctx].get(), single);
    p.x = wrap_add(p.x, diff);
    c.x_med[xy_ctx].add(diff);
    std::uint32_t k = c.dx.k();
    diff = c.dy.decode(d, c.y_med[xy_ctx].get(), single + (k < 20 ? (k & ~1u) : 20));
    p.y = wrap_add(p.y, diff);
    c.y_med[xy_ctx].add(diff);
    if (m_layers[z].changes()) {
      k = (c.dx.k() + c.dy.k()) / 2;
      p.z = c.dz.decode(m_layers[z].dec, c.last_z[l], single + (k < 18 ? (k & ~1u) : 18));
      c.last_z[l] = p.z;
    }
    if (m_layers[classification].changes()) {
      const unsigned ccc = ((p.classification & 0x1Fu) << 1) + (cpr == 3 ? 1u : 0u);
      p.classification = m_layers[classification].dec.symbol(c.class_of[ccc]);
    }
    if (m_layers[flags].changes()) {
      const unsigned last_flags = p.edge << 5 | p.scan_direction << 4 | p.class_flags;
      const std::uint32_t f = m_layers[flags].dec.symbol(c.flags_of[last_flags]);
      p.edge = (f >> 5) & 1u;
      p.scan_direction = (f >> 4) & 1u;
      p.class_flags = f & 15u;
    }
    if (m_layers[intensity].changes()) {
      const unsigned at = (cpr << 1) | (gps_changed ? 1u : 0u);
      p.intensity =
          static_cast<std::uint16_t>(c.ic_intensity.decode(m_layers[intensity].dec, c.last_intensity[at], cpr));
      c.last_intensity[at] = p.intensity;
    }
    if (m_layers[scan_angle].changes() && angle_changed)
      p.scan_angle = static_cast<std::int16_t>(static_cast<std::uint16_t>(
          c.ic_angle.decode(m_layers[scan_angle].dec, p.scan_angle, gps_changed ? 1 : 0) & 0xFFFF));
    if (m_layers[user_data].changes()) p.user_data = m_layers[user_data].dec.symbol(c.user_of[p.user_data / 4]);
    if (m_layers[source].changes() && source_changed)
      p.source = static_cast<std::uint16_t>(c.ic_source.decode(m_layers[source].dec, p.source, 0));
    if (m_layers[gps].changes() && gps_changed) {
      decode_gps(c, m_layers[gps].dec);
      p.gps = c.gps.time[c.gps.last];
    }
    p.gps_changed = gps_changed;
  }

  /// As gpstime11_v2::decode, but a time that did not change is not coded:
  /// the symbols for "unchanged" are gone (the zero-difference model has 5,
  /// the multiplier model 515).
  static void decode_gps(context& c, decoder& d) {
    gps_sequences& g = c.gps;
    constexpr std::uint32_t code_full = gps_sequences::multi_max - gps_sequences::multi_minus + 1;
    for (int switches = 0;; ++switches) {
      if (switches > 4) throw corrupt("GPS time: too many sequence switches");
      if (g.diff[g.last] == 0) {
        const std::uint32_t multi = d.symbol(c.zero_diff);
        if (multi == 0) {
          g.diff[g.last] = g.ic.decode(d, 0, 0);
          g.time[g.last] = wrap_add64(g.time[g.last], g.diff[g.last]);
          g.extreme[g.last] = 0;
        } else if (multi == 1) {
          g.decode_full(d);
        } else {
          g.last = (g.last + multi - 1) & 3;
          continue;
        }
        return;
      }
      const std::uint32_t multi = d.symbol(c.multi);
      if (multi == 1) {
        g.time[g.last] = wrap_add64(g.time[g.last], g.ic.decode(d, g.diff[g.last], 1));
        g.extreme[g.last] = 0;
      } else if (multi < code_full) {
        g.add_multiple(d, multi);
      } else if (multi == code_full) {
        g.decode_full(d);
      } else {
        g.last = (g.last + multi - code_full) & 3;
        continue;
      }
      return;
    }
  }

  layer* m_layers;
  unsigned m_current = 0;
  std::unique_ptr<context> m_ctx[4];
};

/// How the items after point14 follow the scanner channel. Version 4 uses
/// the channel of the last point. Version 3 uses the channel the point
/// switched to, else channel 0, and on a switch to a channel it has seen it
/// codes that point from the last values of the channel it left (LASzip's
/// version 3 behaviour, which version 4 mended: files of either version
/// decode as they were written).
struct channel_rule {
  bool v3 = false;  ///< of point14: which context the other items are given
  /// The context the other items use for a point (point14's channel after
  /// it, and whether it switched there on this point).
  unsigned context(unsigned channel, bool switched) const noexcept { return v3 && !switched ? 0u : channel; }
};

/// The contexts of an item after point14, one a scanner channel (made when
/// first used, from the last values), and which one's last values the
/// current point is coded from (see channel_rule).
template <class Context>
class channel_contexts {
 public:
  channel_contexts(std::unique_ptr<Context> first, unsigned channel, bool stale_last)
      : m_stale_last(stale_last), m_current(channel) {
    m_ctx[channel] = std::move(first);
    m_last = m_ctx[channel].get();
  }
  /// The context whose models code a point of `channel` (`make(last)` makes
  /// a new one); last() is then the one whose values it is coded from.
  template <class Make>
  Context& follow(unsigned channel, Make&& make) {
    m_last = m_ctx[m_current].get();
    if (channel != m_current) {
      m_current = channel;
      if (!m_ctx[m_current]) {
        m_ctx[m_current] = make(*m_last);
        m_last = m_ctx[m_current].get();
      } else if (!m_stale_last) {
        m_last = m_ctx[m_current].get();
      }
    }
    return *m_ctx[m_current];
  }
  Context& last() noexcept { return *m_last; }

 private:
  bool m_stale_last;
  unsigned m_current;
  std::unique_ptr<Context> m_ctx[4];
  Context* m_last;
};

/// The last colour and NIR and their models, of one scanner channel.
struct rgbnir14_context {
  rgbnir14_context(const unsigned char* from, bool nir) {
    for (int c = 0; c < 3; ++c) rgb_last[c] = load_le<std::uint16_t>(from + 2 * c);
    if (nir) nir_last = load_le<std::uint16_t>(from + 6);
  }
  /// The last values as a record's bytes (a new context starts from them).
  const unsigned char* bytes() {
    for (int c = 0; c < 3; ++c) store_le<std::uint16_t>(last_bytes + 2 * c, rgb_last[c]);
    store_le<std::uint16_t>(last_bytes + 6, nir_last);
    return last_bytes;
  }
  std::uint16_t rgb_last[3] = {0, 0, 0};
  std::uint16_t nir_last = 0;
  unsigned char last_bytes[8] = {};
  rgb12_v2::models rgb;
  symbol_model nir_used{4};
  symbol_model nir_diff[2] = {symbol_model(256), symbol_model(256)};
};

/// rgb14 and rgbnir14 (v3, v4): the colour as rgb12, and the NIR's two
/// bytes, in their own layers, with models per scanner channel.
class rgbnir14_v3 {
  using context = rgbnir14_context;

 public:
  /// `stale_last`: version 3 (its own), see channel_rule.
  rgbnir14_v3(const unsigned char* first, unsigned channel, bool nir, bool stale_last, layer* layers)
      : m_nir(nir), m_layers(layers), m_ctx(std::make_unique<context>(first, nir), channel, stale_last) {}

  void decode(unsigned char* out, unsigned context_of_point) {
    context& models =
        m_ctx.follow(context_of_point, [&](context& from) { return std::make_unique<context>(from.bytes(), m_nir); });
    context& last = m_ctx.last();
    if (m_layers[0].changes()) rgb12_v2::decode_with(m_layers[0].dec, models.rgb, last.rgb_last);
    for (int c = 0; c < 3; ++c) store_le<std::uint16_t>(out + 2 * c, last.rgb_last[c]);
    if (!m_nir) return;
    if (m_layers[1].changes()) {
      decoder& d = m_layers[1].dec;
      const std::uint32_t used = d.symbol(models.nir_used);
      unsigned v = last.nir_last;
      if (used & 1) v = (v & 0xFF00u) | ((d.symbol(models.nir_diff[0]) + (v & 0xFFu)) & 0xFFu);
      if (used & 2) v = (v & 0x00FFu) | (((d.symbol(models.nir_diff[1]) + (v >> 8)) & 0xFFu) << 8);
      last.nir_last = static_cast<std::uint16_t>(v);
    }
    store_le<std::uint16_t>(out + 6, last.nir_last);
  }

  void check_ends() const {
    m_layers[0].check_end("colour");
    if (m_nir) m_layers[1].check_end("NIR");
  }

 private:
  bool m_nir;
  layer* m_layers;
  channel_contexts<context> m_ctx;
};

/// The last extra bytes and their models, of one scanner channel.
struct byte14_context {
  byte14_context(const unsigned char* from, std::size_t n) : last(from, from + n), models(n, symbol_model(256)) {}
  std::vector<unsigned char> last;
  std::vector<symbol_model> models;
};

/// byte14 (v3, v4): each extra byte in its own layer, its difference to the
/// last point's coded under a model per byte and scanner channel.
class byte14_v3 {
  using context = byte14_context;

 public:
  /// `stale_last`: version 3 (its own), see channel_rule.
  byte14_v3(const unsigned char* first, std::size_t n, unsigned channel, bool stale_last, layer* layers)
      : m_n(n), m_layers(layers), m_ctx(std::make_unique<context>(first, n), channel, stale_last) {}

  void decode(unsigned char* out, unsigned context_of_point) {
    context& models =
        m_ctx.follow(context_of_point, [&](context& from) { return std::make_unique<context>(from.last.data(), m_n); });
    std::vector<unsigned char>& last = m_ctx.last().last;
    for (std::size_t i = 0; i < m_n; ++i) {
      if (m_layers[i].changes())
        last[i] = static_cast<unsigned char>((last[i] + m_layers[i].dec.symbol(models.models[i])) & 0xFFu);
      out[i] = last[i];
    }
  }

  void check_ends() const {
    for (std::size_t i = 0; i < m_n; ++i) m_layers[i].check_end("extra byte");
  }

 private:
  std::size_t m_n;
  layer* m_layers;
  channel_contexts<context> m_ctx;
};

/// Decodes records 1 to points - 1 of a layered chunk into out (record 0,
/// the first, is already there) from the bytes [p, end) after the first
/// record: the point count, the layers' sizes, the layers.
inline void decode_layered(const std::vector<laz_item>& items, const unsigned char* p, const unsigned char* end,
                           unsigned char* out, std::size_t stride, std::uint64_t points, const laz_wanted& wanted) {
  const auto take_u32 = [&]() {
    if (end - p < 4) throw corrupt("the layer sizes run past the chunk's end");
    const auto v = load_le<std::uint32_t>(p);
    p += 4;
    return v;
  };
  if (take_u32() != points) throw corrupt("its point count differs from the chunk table's");
  // The layers of each item, in item order: point14 9, rgb14 1, rgbnir14 2, byte14 one a byte.
  std::vector<std::uint32_t> sizes;
  std::vector<std::size_t> first_layer;
  for (const laz_item& it : items) {
    first_layer.push_back(sizes.size());
    const std::size_t n = it.type == laz_item::point14    ? point14_v3::layer_count
                          : it.type == laz_item::rgb14    ? 1
                          : it.type == laz_item::rgbnir14 ? 2
                                                          : it.size;
    for (std::size_t i = 0; i < n; ++i) sizes.push_back(take_u32());
  }
  std::vector<layer> layers(sizes.size());
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    if (static_cast<std::size_t>(end - p) < sizes[i]) throw corrupt("its layers run past the chunk's end");
    layers[i].begin = p;
    layers[i].end = p += sizes[i];
  }
  if (p != end) throw corrupt(std::to_string(end - p) + " bytes after its layers");
  // The layers of fields not wanted are skipped: as if their field did not change.
  const bool point_layer_wanted[point14_v3::layer_count] = {true,
                                                            true,
                                                            wanted.classification,
                                                            wanted.flags,
                                                            wanted.intensity,
                                                            wanted.scan_angle,
                                                            wanted.user_data,
                                                            wanted.point_source,
                                                            wanted.gps_time};
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::size_t next = i + 1 < items.size() ? first_layer[i + 1] : layers.size();
    for (std::size_t k = first_layer[i]; k < next; ++k) {
      const std::size_t in_item = k - first_layer[i];
      const bool keep = items[i].type == laz_item::point14  ? point_layer_wanted[in_item]
                        : items[i].type == laz_item::byte14 ? wanted.extra
                                                            : (in_item == 0 ? wanted.rgb : wanted.nir);
      if (!keep) layers[k].end = layers[k].begin;
    }
  }
  for (layer& l : layers) l.start();
  if (layers[point14_v3::xy].begin == layers[point14_v3::xy].end) throw corrupt("its x/y layer is empty");
  // The items after point14 follow its scanner channel.
  const channel_rule rule{items[0].version == 3};
  point14_v3 point(out, layers.data());
  std::unique_ptr<rgbnir14_v3> colour;
  std::unique_ptr<byte14_v3> extra;
  std::size_t colour_at = 0, extra_at = 0, at = items[0].size;
  for (std::size_t i = 1; i < items.size(); ++i) {
    layer* l = layers.data() + first_layer[i];
    if (items[i].type == laz_item::byte14)
      extra =
          std::make_unique<byte14_v3>(out + (extra_at = at), items[i].size, point.channel(), items[i].version == 3, l);
    else
      colour = std::make_unique<rgbnir14_v3>(out + (colour_at = at), point.channel(),
                                             items[i].type == laz_item::rgbnir14, items[i].version == 3, l);
    at += items[i].size;
  }
  for (std::uint64_t i = 1; i < points; ++i) {
    unsigned char* r = out + i * stride;
    const unsigned before = point.channel();
    point.decode(r);
    const unsigned context = rule.context(point.channel(), point.channel() != before);
    if (colour) colour->decode(r + colour_at, context);
    if (extra) extra->decode(r + extra_at, context);
  }
  point.check_ends();
  if (colour) colour->check_ends();
  if (extra) extra->check_ends();
}

}  // namespace ced::io::detail::laz
