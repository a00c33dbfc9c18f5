// SPDX-License-Identifier: MIT
// Private to src/io: the encoder of LAZ's layered compression (LAS 1.4
// point formats 6-8; items point14, rgb14, rgbnir14 and byte14, version 3),
// the inverse of layered.hpp, step for step: the same contexts and
// models, each field coded into its own layer. A layer whose field is the
// same in every point of the chunk is written as 0 bytes (the decoder then
// keeps the first point's value), as LASzip does.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "io/laz/layered.hpp"

namespace ced::io::detail::laz {

/// Whether bytes [at, at + n) differ between any record of a chunk and its first.
inline bool field_varies(const unsigned char* records, std::size_t stride, std::uint64_t points, std::size_t at,
                         std::size_t n, unsigned char mask = 0xFF) {
  for (std::uint64_t i = 1; i < points; ++i)
    for (std::size_t b = 0; b < n; ++b)
      if ((records[i * stride + at + b] ^ records[at + b]) & mask) return true;
  return false;
}

/// point14 v3's encoder: codes each record after the first into 9 layers.
class point14_v3_encoder {
  using context = point14_context;

 public:
  enum { xy, z, classification, flags, intensity, scan_angle, user_data, source, gps, layer_count };

  /// `first`: the chunk's first record; `varies`: which layers are coded.
  point14_v3_encoder(const unsigned char* first, const std::array<bool, layer_count>& varies) : m_varies(varies) {
    point14_fields f;
    f.read(first);
    m_current = f.channel;
    m_ctx[m_current] = std::make_unique<context>(f);
    for (int i = 0; i < layer_count; ++i) m_enc[i] = std::make_unique<encoder>(m_bytes[i]);
  }
  unsigned channel() const noexcept { return m_current; }

  void encode(const unsigned char* record) {
    point14_fields p;
    p.read(record);
    context* c = m_ctx[m_current].get();
    const point14_fields& last = c->last;
    const unsigned lpr =
        (last.ret == 1 ? 1u : 0u) + (last.ret >= last.returns ? 2u : 0u) + (last.gps_changed ? 4u : 0u);
    symbol_model& changed_model = c->changed[lpr];
    const bool switched = p.channel != m_current;
    context* t = c;
    if (switched) {
      if (!m_ctx[p.channel]) m_ctx[p.channel] = std::make_unique<context>(c->last);
      t = m_ctx[p.channel].get();
      t->last.channel = p.channel;
    }
    const point14_fields& l = t->last;
    std::uint32_t changed = (switched ? 64u : 0u) | (p.source != l.source ? 32u : 0u) | (p.gps != l.gps ? 16u : 0u) |
                            (p.scan_angle != l.scan_angle ? 8u : 0u) | (p.returns != l.returns ? 4u : 0u);
    if (p.ret == l.ret)
      changed |= 0;
    else if (p.ret == (l.ret + 1) % 16)
      changed |= 1;
    else if (p.ret == (l.ret + 15) % 16)
      changed |= 2;
    else
      changed |= 3;
    m_enc[xy]->symbol(changed_model, changed);
    if (switched) {
      m_enc[xy]->symbol(c->scanner, (p.channel + 3 - m_current) % 4);
      m_current = p.channel;
    }
    encode_fields(*t, changed, p);
  }

  /// Ends the layers: the bytes of each (empty for a layer not coded).
  std::array<std::string, layer_count>& finish() {
    for (int i = 0; i < layer_count; ++i)
      if (i == xy || m_varies[i])
        m_enc[i]->done();
      else
        m_bytes[i].clear();
    return m_bytes;
  }

 private:
  void encode_fields(context& c, std::uint32_t changed, const point14_fields& p) {
    encoder& e = *m_enc[xy];
    point14_fields& last = c.last;
    const bool gps_changed = (changed & 16) != 0;
    if (changed & 4) e.symbol(c.returns_of[last.returns], p.returns);
    if ((changed & 3) == 3) {
      if (gps_changed)
        e.symbol(c.return_of[last.ret], p.ret);
      else
        e.symbol(c.return_gps_same, (p.ret + 14 - last.ret) % 16);
    }
    const return_contexts rc(p.returns, p.ret);
    const unsigned l = rc.l, cpr = rc.cpr, single = rc.single;
    const unsigned xy_ctx = (rc.m << 1) | (gps_changed ? 1u : 0u);
    std::int32_t diff = wrap_sub(p.x, last.x);
    c.dx.encode(e, c.x_med[xy_ctx].get(), diff, single);
    c.x_med[xy_ctx].add(diff);
    std::uint32_t k = c.dx.k();
    diff = wrap_sub(p.y, last.y);
    c.dy.encode(e, c.y_med[xy_ctx].get(), diff, single + (k < 20 ? (k & ~1u) : 20));
    c.y_med[xy_ctx].add(diff);
    if (m_varies[z]) {
      k = (c.dx.k() + c.dy.k()) / 2;
      c.dz.encode(*m_enc[z], c.last_z[l], p.z, single + (k < 18 ? (k & ~1u) : 18));
      c.last_z[l] = p.z;
    }
    if (m_varies[classification])
      m_enc[classification]->symbol(c.class_of[((last.classification & 0x1Fu) << 1) + (cpr == 3 ? 1u : 0u)],
                                    p.classification);
    if (m_varies[flags])
      m_enc[flags]->symbol(c.flags_of[last.edge << 5 | last.scan_direction << 4 | last.class_flags],
                           p.edge << 5 | p.scan_direction << 4 | p.class_flags);
    if (m_varies[intensity]) {
      const unsigned at = (cpr << 1) | (gps_changed ? 1u : 0u);
      c.ic_intensity.encode(*m_enc[intensity], c.last_intensity[at], p.intensity, cpr);
      c.last_intensity[at] = p.intensity;
    }
    if (m_varies[scan_angle] && (changed & 8))
      c.ic_angle.encode(*m_enc[scan_angle], last.scan_angle, p.scan_angle, gps_changed ? 1 : 0);
    if (m_varies[user_data]) m_enc[user_data]->symbol(c.user_of[last.user_data / 4], p.user_data);
    if (m_varies[source] && (changed & 32)) c.ic_source.encode(*m_enc[source], last.source, p.source, 0);
    if (m_varies[gps] && gps_changed) encode_gps(c, *m_enc[gps], p.gps);
    const unsigned channel = last.channel;
    last = p;
    last.channel = channel;
    last.gps_changed = gps_changed;
  }

  /// As gpstime11_v2::encode, without the symbols for "unchanged" (a time
  /// that did not change is not coded): the inverse of point14_v3::decode_gps.
  static void encode_gps(context& c, encoder& e, std::int64_t t) {
    gps_sequences& g = c.gps;
    constexpr std::uint32_t code_full = gps_sequences::multi_max - gps_sequences::multi_minus + 1;
    const auto diff_to = [&](unsigned seq, std::int32_t& d) {
      const auto d64 =
          static_cast<std::int64_t>(static_cast<std::uint64_t>(t) - static_cast<std::uint64_t>(g.time[seq]));
      d = static_cast<std::int32_t>(d64);
      return d64 == std::int64_t(d);
    };
    const auto other_sequence = [&]() -> unsigned {
      std::int32_t d;
      for (unsigned i = 1; i < 4; ++i)
        if (diff_to((g.last + i) & 3, d)) return i;
      return 0;
    };
    for (int switches = 0;; ++switches) {
      std::int32_t d;
      const bool small = diff_to(g.last, d);
      if (g.diff[g.last] == 0) {
        if (small) {
          e.symbol(c.zero_diff, 0);
          g.ic.encode(e, 0, d, 0);
          g.diff[g.last] = d;
          g.extreme[g.last] = 0;
          g.time[g.last] = t;
          return;
        }
        if (const unsigned i = switches < 3 ? other_sequence() : 0) {
          e.symbol(c.zero_diff, i + 1);
          g.last = (g.last + i) & 3;
          continue;
        }
        e.symbol(c.zero_diff, 1);
        return g.encode_full(e, t);
      }
      if (!small) {
        if (const unsigned i = switches < 3 ? other_sequence() : 0) {
          e.symbol(c.multi, code_full + i);
          g.last = (g.last + i) & 3;
          continue;
        }
        e.symbol(c.multi, code_full);
        return g.encode_full(e, t);
      }
      return g.encode_multiple(e, c.multi, d, t);
    }
  }

  std::array<bool, layer_count> m_varies;
  std::array<std::string, layer_count> m_bytes;
  std::unique_ptr<encoder> m_enc[layer_count];
  unsigned m_current = 0;
  std::unique_ptr<context> m_ctx[4];
};

/// rgb14 / rgbnir14 v3's encoder: the colour layer, and the NIR layer.
class rgbnir14_v3_encoder {
  using context = rgbnir14_context;

 public:
  rgbnir14_v3_encoder(const unsigned char* first, unsigned channel, bool nir, std::array<bool, 2> varies)
      : m_nir(nir), m_varies(varies), m_ctx(std::make_unique<context>(first, nir), channel, true) {
    for (int i = 0; i < 2; ++i) m_enc[i] = std::make_unique<encoder>(m_bytes[i]);
  }

  void encode(const unsigned char* item, unsigned context_of_point) {
    context& models =
        m_ctx.follow(context_of_point, [&](context& from) { return std::make_unique<context>(from.bytes(), m_nir); });
    context& last = m_ctx.last();
    if (m_varies[0]) rgb12_v2::encode_with(*m_enc[0], models.rgb, last.rgb_last, item);
    if (!m_nir || !m_varies[1]) return;
    const unsigned v = load_le<std::uint16_t>(item + 6), before = last.nir_last;
    const std::uint32_t used = ((v & 0xFFu) != (before & 0xFFu) ? 1u : 0u) | ((v >> 8) != (before >> 8) ? 2u : 0u);
    m_enc[1]->symbol(models.nir_used, used);
    if (used & 1) m_enc[1]->symbol(models.nir_diff[0], (v - before) & 0xFFu);
    if (used & 2) m_enc[1]->symbol(models.nir_diff[1], ((v >> 8) - (before >> 8)) & 0xFFu);
    last.nir_last = static_cast<std::uint16_t>(v);
  }

  /// The colour layer, and with NIR its layer.
  std::vector<std::string> finish() {
    std::vector<std::string> out;
    for (int i = 0; i < (m_nir ? 2 : 1); ++i) {
      if (m_varies[i]) m_enc[i]->done();
      out.push_back(m_varies[i] ? std::move(m_bytes[i]) : std::string());
    }
    return out;
  }

 private:
  bool m_nir;
  std::array<bool, 2> m_varies;
  std::string m_bytes[2];
  std::unique_ptr<encoder> m_enc[2];
  channel_contexts<context> m_ctx;
};

/// byte14 v3's encoder: a layer for each extra byte.
class byte14_v3_encoder {
  using context = byte14_context;

 public:
  byte14_v3_encoder(const unsigned char* first, std::size_t n, unsigned channel, std::vector<bool> varies)
      : m_n(n), m_varies(std::move(varies)), m_bytes(n), m_ctx(std::make_unique<context>(first, n), channel, true) {
    for (std::size_t i = 0; i < n; ++i) m_enc.push_back(std::make_unique<encoder>(m_bytes[i]));
  }

  void encode(const unsigned char* item, unsigned context_of_point) {
    context& models =
        m_ctx.follow(context_of_point, [&](context& from) { return std::make_unique<context>(from.last.data(), m_n); });
    std::vector<unsigned char>& last = m_ctx.last().last;
    for (std::size_t i = 0; i < m_n; ++i) {
      if (!m_varies[i]) continue;
      m_enc[i]->symbol(models.models[i], (item[i] - last[i]) & 0xFFu);
      last[i] = item[i];
    }
  }

  std::vector<std::string> finish() {
    for (std::size_t i = 0; i < m_n; ++i)
      if (m_varies[i])
        m_enc[i]->done();
      else
        m_bytes[i].clear();
    return std::move(m_bytes);
  }

 private:
  std::size_t m_n;
  std::vector<bool> m_varies;
  std::vector<std::string> m_bytes;
  std::vector<std::unique_ptr<encoder>> m_enc;
  channel_contexts<context> m_ctx;
};

/// Codes `points` records (`stride` bytes apart) as one layered chunk of
/// version 3 `items` (point14, then rgb14 or rgbnir14, then byte14),
/// appending to `out`: the first record as it is, the point count, the
/// layers' sizes, the layers (the inverse of decode_layered()).
inline void encode_layered(const std::vector<laz_item>& items, const unsigned char* records, std::size_t stride,
                           std::uint64_t points, std::string& out) {
  if (points == 0) return;
  out.append(reinterpret_cast<const char*>(records), stride);
  const auto varies = [&](std::size_t at, std::size_t n, unsigned char mask = 0xFF) {
    return field_varies(records, stride, points, at, n, mask);
  };
  using p14 = point14_v3_encoder;
  // Layers by record bytes: z 8-11, intensity 12-13, classification 16,
  // flags (all of byte 15 but the channel), user data 17, scan angle
  // 18-19, point source 20-21, GPS time 22-29.
  const std::array<bool, p14::layer_count> point_varies = {
      true,          varies(8, 4),  varies(16, 1), varies(15, 1, 0xCF), varies(12, 2),
      varies(18, 2), varies(17, 1), varies(20, 2), varies(22, 8)};
  p14 point(records, point_varies);
  std::unique_ptr<rgbnir14_v3_encoder> colour;
  std::unique_ptr<byte14_v3_encoder> extra;
  std::size_t colour_at = 0, extra_at = 0, at = items[0].size;
  for (std::size_t i = 1; i < items.size(); ++i) {
    if (items[i].type == laz_item::byte14) {
      std::vector<bool> v(items[i].size);
      for (std::size_t b = 0; b < v.size(); ++b) v[b] = varies(at + b, 1);
      extra = std::make_unique<byte14_v3_encoder>(records + (extra_at = at), items[i].size, point.channel(), v);
    } else {
      colour = std::make_unique<rgbnir14_v3_encoder>(records + (colour_at = at), point.channel(),
                                                     items[i].type == laz_item::rgbnir14,
                                                     std::array<bool, 2>{varies(at, 6), varies(at + 6, 2)});
    }
    at += items[i].size;
  }
  const channel_rule rule{true};
  for (std::uint64_t i = 1; i < points; ++i) {
    const unsigned char* r = records + i * stride;
    const unsigned before = point.channel();
    point.encode(r);
    const unsigned context = rule.context(point.channel(), point.channel() != before);
    if (colour) colour->encode(r + colour_at, context);
    if (extra) extra->encode(r + extra_at, context);
  }
  std::vector<std::string> layers;
  for (std::string& l : point.finish()) layers.push_back(std::move(l));
  if (colour)
    for (std::string& l : colour->finish()) layers.push_back(std::move(l));
  if (extra)
    for (std::string& l : extra->finish()) layers.push_back(std::move(l));
  const auto put_u32 = [&](std::uint64_t v) {
    unsigned char b[4];
    store_le<std::uint32_t>(b, static_cast<std::uint32_t>(v));
    out.append(reinterpret_cast<const char*>(b), 4);
  };
  put_u32(points);
  for (const std::string& l : layers) put_u32(l.size());
  for (const std::string& l : layers) out += l;
}

}  // namespace ced::io::detail::laz
