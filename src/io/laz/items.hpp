// SPDX-License-Identifier: MIT
// Private to src/io: the decoders of LAZ's pointwise items, version 2
// (point10, gpstime11, rgb12, byte): each predicts a record's item from the
// record before it in the chunk and decodes the correction (chunks.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "io/laz/types.hpp"
#include "io/laz/coder.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io::detail::laz {

/// The median of the last five values added (all 0 at first), kept sorted;
/// each new value evicts the oldest end alternately, as the format does.
class median5 {
 public:
  std::int32_t get() const noexcept { return m_v[2]; }
  void add(std::int32_t v) noexcept {
    if (m_high) {
      if (v < m_v[2]) {
        m_v[4] = m_v[3];
        m_v[3] = m_v[2];
        if (v < m_v[0]) {
          m_v[2] = m_v[1];
          m_v[1] = m_v[0];
          m_v[0] = v;
        } else if (v < m_v[1]) {
          m_v[2] = m_v[1];
          m_v[1] = v;
        } else {
          m_v[2] = v;
        }
      } else {
        if (v < m_v[3]) {
          m_v[4] = m_v[3];
          m_v[3] = v;
        } else {
          m_v[4] = v;
        }
        m_high = false;
      }
    } else {
      if (m_v[2] < v) {
        m_v[0] = m_v[1];
        m_v[1] = m_v[2];
        if (m_v[4] < v) {
          m_v[2] = m_v[3];
          m_v[3] = m_v[4];
          m_v[4] = v;
        } else if (m_v[3] < v) {
          m_v[2] = m_v[3];
          m_v[3] = v;
        } else {
          m_v[2] = v;
        }
      } else {
        if (m_v[1] < v) {
          m_v[0] = m_v[1];
          m_v[1] = v;
        } else {
          m_v[0] = v;
        }
        m_high = true;
      }
    }
  }

 private:
  std::int32_t m_v[5] = {0, 0, 0, 0, 0};
  bool m_high = true;
};

inline std::int32_t wrap_add(std::int32_t a, std::int32_t b) noexcept {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) + static_cast<std::uint32_t>(b));
}
inline std::int32_t wrap_mul(std::int32_t a, std::int32_t b) noexcept {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) * static_cast<std::uint32_t>(b));
}
inline std::int32_t wrap_sub(std::int32_t a, std::int32_t b) noexcept {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) - static_cast<std::uint32_t>(b));
}
inline std::int64_t wrap_add64(std::int64_t a, std::int32_t b) noexcept {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(a) + static_cast<std::uint64_t>(std::int64_t(b)));
}
inline int clamp_u8(int v) noexcept { return v < 0 ? 0 : (v > 255 ? 255 : v); }

/// A model for each value of a context byte, made when first needed.
class models_by_byte {
 public:
  symbol_model& operator[](unsigned b) {
    if (!m[b]) m[b] = std::make_unique<symbol_model>(256);
    return *m[b];
  }

 private:
  std::unique_ptr<symbol_model> m[256];
};

/// point10 v2: the 20 bytes of LAS point formats 0-5 (x, y, z, intensity,
/// return bits, classification, scan angle, user data, point source).
class point10_v2 {
 public:
  explicit point10_v2(const unsigned char* first) {
    std::memcpy(m_last, first, 20);
    m_last[12] = m_last[13] = 0;  // the intensity is predicted from 0
  }

  void decode(decoder& d, unsigned char* out) {
    const std::uint32_t changed = d.symbol(m_changed);
    unsigned r, n, m, l;
    if (changed) {
      if (changed & 32) m_last[14] = static_cast<unsigned char>(d.symbol(m_flags[m_last[14]]));
      returns(r, n, m, l);
      if (changed & 16) {
        m_intensity[m] = static_cast<std::uint16_t>(m_ic_intensity.decode(d, m_intensity[m], m < 3 ? m : 3));
      }
      store_le<std::uint16_t>(m_last + 12, m_intensity[m]);
      if (changed & 8) m_last[15] = static_cast<unsigned char>(d.symbol(m_class[m_last[15]]));
      if (changed & 4) {
        const std::uint32_t v = d.symbol(m_scan_angle[(m_last[14] >> 6) & 1]);
        m_last[16] = static_cast<unsigned char>((v + m_last[16]) & 0xFF);
      }
      if (changed & 2) m_last[17] = static_cast<unsigned char>(d.symbol(m_user[m_last[17]]));
      if (changed & 1) {
        const auto id = load_le<std::uint16_t>(m_last + 18);
        store_le<std::uint16_t>(m_last + 18, static_cast<std::uint16_t>(m_ic_source.decode(d, id, 0)));
      }
    } else {
      returns(r, n, m, l);
    }
    const unsigned single = n == 1 ? 1 : 0;
    std::int32_t diff = m_ic_dx.decode(d, m_x[m].get(), single);
    store_le<std::int32_t>(m_last, wrap_add(load_le<std::int32_t>(m_last), diff));
    m_x[m].add(diff);
    std::uint32_t k = m_ic_dx.k();
    diff = m_ic_dy.decode(d, m_y[m].get(), single + (k < 20 ? (k & ~1u) : 20));
    store_le<std::int32_t>(m_last + 4, wrap_add(load_le<std::int32_t>(m_last + 4), diff));
    m_y[m].add(diff);
    k = (m_ic_dx.k() + m_ic_dy.k()) / 2;
    m_height[l] = m_ic_z.decode(d, m_height[l], single + (k < 18 ? (k & ~1u) : 18));
    store_le<std::int32_t>(m_last + 8, m_height[l]);
    std::memcpy(out, m_last, 20);
  }

  void encode(encoder& e, const unsigned char* item) {
    unsigned r, n, m, l;
    returns_of(item[14], r, n, m, l);
    const auto intensity = load_le<std::uint16_t>(item + 12);
    const auto id = load_le<std::uint16_t>(item + 18), last_id = load_le<std::uint16_t>(m_last + 18);
    const std::uint32_t changed = (m_last[14] != item[14]) << 5 | (m_intensity[m] != intensity) << 4 |
                                  (m_last[15] != item[15]) << 3 | (m_last[16] != item[16]) << 2 |
                                  (m_last[17] != item[17]) << 1 | (last_id != id);
    e.symbol(m_changed, changed);
    if (changed & 32) e.symbol(m_flags[m_last[14]], item[14]);
    if (changed & 16) {
      m_ic_intensity.encode(e, m_intensity[m], intensity, m < 3 ? m : 3);
      m_intensity[m] = intensity;
    }
    if (changed & 8) e.symbol(m_class[m_last[15]], item[15]);
    if (changed & 4) e.symbol(m_scan_angle[(item[14] >> 6) & 1], (item[16] - m_last[16]) & 0xFFu);
    if (changed & 2) e.symbol(m_user[m_last[17]], item[17]);
    if (changed & 1) m_ic_source.encode(e, last_id, id, 0);
    const unsigned single = n == 1 ? 1 : 0;
    std::int32_t diff = wrap_add(load_le<std::int32_t>(item), -load_le<std::int32_t>(m_last));
    m_ic_dx.encode(e, m_x[m].get(), diff, single);
    m_x[m].add(diff);
    std::uint32_t k = m_ic_dx.k();
    diff = wrap_add(load_le<std::int32_t>(item + 4), -load_le<std::int32_t>(m_last + 4));
    m_ic_dy.encode(e, m_y[m].get(), diff, single + (k < 20 ? (k & ~1u) : 20));
    m_y[m].add(diff);
    k = (m_ic_dx.k() + m_ic_dy.k()) / 2;
    const auto z = load_le<std::int32_t>(item + 8);
    m_ic_z.encode(e, m_height[l], z, single + (k < 18 ? (k & ~1u) : 18));
    m_height[l] = z;
    std::memcpy(m_last, item, 20);
  }

 private:
  /// The return number r and count n of the last point, and the contexts
  /// they select: m (of 16) for x, y and intensity, l = |n - r| for z.
  void returns(unsigned& r, unsigned& n, unsigned& m, unsigned& l) const noexcept {
    returns_of(m_last[14], r, n, m, l);
  }
  static void returns_of(unsigned char flags, unsigned& r, unsigned& n, unsigned& m, unsigned& l) noexcept {
    // Which of 16 contexts a (number of returns, return number) pair uses;
    // pairs that a well-formed file does not have share the spare ones.
    static constexpr unsigned char map[8][8] = {{15, 14, 13, 12, 11, 10, 9, 8},  {14, 0, 1, 3, 6, 10, 10, 9},
                                                {13, 1, 2, 4, 7, 11, 11, 10},    {12, 3, 4, 5, 8, 12, 12, 11},
                                                {11, 6, 7, 8, 9, 13, 13, 12},    {10, 10, 11, 12, 13, 14, 14, 13},
                                                {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15}};
    r = flags & 7u;
    n = (flags >> 3) & 7u;
    m = map[n][r];
    l = n > r ? n - r : r - n;
  }

  unsigned char m_last[20];
  symbol_model m_changed{64};
  models_by_byte m_flags, m_class, m_user;
  symbol_model m_scan_angle[2] = {symbol_model(256), symbol_model(256)};
  integer_coder m_ic_intensity{16, 4}, m_ic_source{16, 1};
  integer_coder m_ic_dx{32, 2}, m_ic_dy{32, 22}, m_ic_z{32, 20};
  median5 m_x[16], m_y[16];
  std::uint16_t m_intensity[16] = {};
  std::int32_t m_height[8] = {};
};

/// GPS times as up to four interleaved sequences (flight lines, scanners),
/// each with its last time and integer difference, multiples of which are
/// predicted. gpstime11 v2 and point14 v3 code them alike.
struct gps_sequences {
  static constexpr std::int32_t multi_max = 500, multi_minus = -10;
  unsigned last = 0, next = 0;
  std::int64_t time[4] = {0, 0, 0, 0};
  std::int32_t diff[4] = {0, 0, 0, 0};
  std::int32_t extreme[4] = {0, 0, 0, 0};
  integer_coder ic{32, 9};

  /// A difference far from the prediction: after more than three in a row
  /// it becomes the sequence's difference.
  void far_diff(std::int32_t d) noexcept {
    if (++extreme[last] > 3) {
      diff[last] = d;
      extreme[last] = 0;
    }
  }
  /// Adds to the sequence's time the difference coded under multiplier
  /// symbol `multi`: 0 (none), 2 to multi_max (that many times the last
  /// difference) or past it (minus multi - multi_max times, at most
  /// -multi_minus). Symbol 1 (the last difference itself) is the caller's.
  void add_multiple(decoder& d, std::uint32_t multi) {
    std::int32_t got;
    if (multi == 0) {
      got = ic.decode(d, 0, 7);
      far_diff(got);
    } else if (multi < std::uint32_t(multi_max)) {
      got = ic.decode(d, wrap_mul(std::int32_t(multi), diff[last]), multi < 10 ? 2 : 3);
    } else if (multi == std::uint32_t(multi_max)) {
      got = ic.decode(d, wrap_mul(multi_max, diff[last]), 4);
      far_diff(got);
    } else {
      const std::int32_t back = multi_max - std::int32_t(multi);
      if (back > multi_minus) {
        got = ic.decode(d, wrap_mul(back, diff[last]), 5);
      } else {
        got = ic.decode(d, wrap_mul(multi_minus, diff[last]), 6);
        far_diff(got);
      }
    }
    time[last] = wrap_add64(time[last], got);
  }
  /// A new sequence, its time coded whole: the high 32 bits predicted from
  /// the current sequence's, the low 32 bits raw.
  void decode_full(decoder& d) {
    next = (next + 1) & 3;
    const auto high = static_cast<std::uint32_t>(
        ic.decode(d, static_cast<std::int32_t>(static_cast<std::uint64_t>(time[last]) >> 32), 8));
    time[next] = static_cast<std::int64_t>((std::uint64_t(high) << 32) | d.u32());
    last = next;
    diff[last] = 0;
    extreme[last] = 0;
  }
  /// Codes time t, d (small) after the current sequence's time, whose
  /// difference is not 0: the multiplier symbol under `multi` (1: the last
  /// difference; others as add_multiple() reads them), then the correction.
  void encode_multiple(encoder& e, symbol_model& multi, std::int32_t d, std::int64_t t) {
    const std::int32_t was = diff[last];
    const double ratio = std::clamp(double(d) / double(was), -1e6, 1e6);
    const auto m = static_cast<std::int32_t>(ratio >= 0 ? ratio + 0.5 : ratio - 0.5);
    if (m == 1) {
      e.symbol(multi, 1);
      ic.encode(e, was, d, 1);
      extreme[last] = 0;
    } else if (m > 0 && m < multi_max) {
      e.symbol(multi, std::uint32_t(m));
      ic.encode(e, wrap_mul(m, was), d, m < 10 ? 2 : 3);
    } else if (m >= multi_max) {
      e.symbol(multi, std::uint32_t(multi_max));
      ic.encode(e, wrap_mul(multi_max, was), d, 4);
      far_diff(d);
    } else if (m < 0 && m > multi_minus) {
      e.symbol(multi, std::uint32_t(multi_max - m));
      ic.encode(e, wrap_mul(m, was), d, 5);
    } else if (m < 0) {
      e.symbol(multi, std::uint32_t(multi_max - multi_minus));
      ic.encode(e, wrap_mul(multi_minus, was), d, 6);
      far_diff(d);
    } else {
      e.symbol(multi, 0);
      ic.encode(e, 0, d, 7);
      far_diff(d);
    }
    time[last] = t;
  }
  void encode_full(encoder& e, std::int64_t t) {
    ic.encode(e, static_cast<std::int32_t>(static_cast<std::uint64_t>(time[last]) >> 32),
              static_cast<std::int32_t>(static_cast<std::uint64_t>(t) >> 32), 8);
    e.u32(static_cast<std::uint32_t>(t));
    next = (next + 1) & 3;
    last = next;
    diff[last] = 0;
    extreme[last] = 0;
    time[last] = t;
  }
};

/// gpstime11 v2: a double's bits, coded as integer differences in up to four
/// interleaved sequences (several flight lines or scanners), with multiples
/// of the last difference predicted.
class gpstime11_v2 {
 public:
  explicit gpstime11_v2(const unsigned char* first) { m_seq.time[0] = load_le<std::int64_t>(first); }

  void decode(decoder& d, unsigned char* out) {
    constexpr std::int32_t multi_max = gps_sequences::multi_max, multi_minus = gps_sequences::multi_minus;
    constexpr std::uint32_t unchanged = multi_max - multi_minus + 1, code_full = unchanged + 1;
    // A switch to another sequence is followed by the value in it; more than
    // a few switches in a row do not occur in a valid stream.
    for (int switches = 0;; ++switches) {
      if (switches > 4) throw corrupt("gpstime: too many sequence switches");
      if (m_seq.diff[m_seq.last] == 0) {
        const std::uint32_t multi = d.symbol(m_zero_diff);
        if (multi == 0) break;  // the same time
        if (multi == 1) {
          m_seq.diff[m_seq.last] = m_seq.ic.decode(d, 0, 0);
          m_seq.time[m_seq.last] = wrap_add64(m_seq.time[m_seq.last], m_seq.diff[m_seq.last]);
          m_seq.extreme[m_seq.last] = 0;
          break;
        }
        if (multi == 2) {
          m_seq.decode_full(d);
          break;
        }
        m_seq.last = (m_seq.last + multi - 2) & 3;
        continue;
      }
      const std::uint32_t multi = d.symbol(m_multi);
      if (multi == 1) {
        m_seq.time[m_seq.last] = wrap_add64(m_seq.time[m_seq.last], m_seq.ic.decode(d, m_seq.diff[m_seq.last], 1));
        m_seq.extreme[m_seq.last] = 0;
        break;
      }
      if (multi < unchanged) {
        m_seq.add_multiple(d, multi);
        break;
      }
      if (multi == unchanged) break;
      if (multi == code_full) {
        m_seq.decode_full(d);
        break;
      }
      m_seq.last = (m_seq.last + multi - code_full) & 3;
    }
    store_le<std::int64_t>(out, m_seq.time[m_seq.last]);
  }

  void encode(encoder& e, const unsigned char* item) {
    constexpr std::int32_t multi_max = gps_sequences::multi_max, multi_minus = gps_sequences::multi_minus;
    constexpr std::uint32_t unchanged = multi_max - multi_minus + 1, code_full = unchanged + 1;
    const auto t = load_le<std::int64_t>(item);
    const auto diff_to = [&](unsigned seq, std::int32_t& d) {
      const auto d64 =
          static_cast<std::int64_t>(static_cast<std::uint64_t>(t) - static_cast<std::uint64_t>(m_seq.time[seq]));
      d = static_cast<std::int32_t>(d64);
      return d64 == std::int64_t(d);
    };
    const auto other_sequence = [&]() -> unsigned {
      std::int32_t d;
      for (unsigned i = 1; i < 4; ++i)
        if (diff_to((m_seq.last + i) & 3, d)) return i;
      return 0;
    };
    for (;;) {
      std::int32_t d;
      const bool small = diff_to(m_seq.last, d);
      if (m_seq.diff[m_seq.last] == 0) {
        if (t == m_seq.time[m_seq.last]) return e.symbol(m_zero_diff, 0);
        if (small) {
          e.symbol(m_zero_diff, 1);
          m_seq.ic.encode(e, 0, d, 0);
          m_seq.diff[m_seq.last] = d;
          m_seq.extreme[m_seq.last] = 0;
          m_seq.time[m_seq.last] = t;
          return;
        }
        if (const unsigned i = other_sequence()) {
          e.symbol(m_zero_diff, i + 2);
          m_seq.last = (m_seq.last + i) & 3;
          continue;
        }
        e.symbol(m_zero_diff, 2);
        return m_seq.encode_full(e, t);
      }
      if (t == m_seq.time[m_seq.last]) return e.symbol(m_multi, unchanged);
      if (!small) {
        if (const unsigned i = other_sequence()) {
          e.symbol(m_multi, code_full + i);
          m_seq.last = (m_seq.last + i) & 3;
          continue;
        }
        e.symbol(m_multi, code_full);
        return m_seq.encode_full(e, t);
      }
      return m_seq.encode_multiple(e, m_multi, d, t);
    }
  }

 private:
  gps_sequences m_seq;
  symbol_model m_multi{516}, m_zero_diff{6};
};

/// rgb12 v2: three 16-bit colours, each byte coded when it changed, green
/// and blue predicted from red's change.
class rgb12_v2 {
 public:
  explicit rgb12_v2(const unsigned char* first) {
    for (int c = 0; c < 3; ++c) m_last[c] = load_le<std::uint16_t>(first + 2 * c);
  }

  /// The models of the colour's coding.
  struct models {
    symbol_model used{128};
    symbol_model diff[6] = {symbol_model(256), symbol_model(256), symbol_model(256),
                            symbol_model(256), symbol_model(256), symbol_model(256)};
  };

  /// Decodes a colour from `last` (updated to it) under models `m`.
  static void decode_with(decoder& d, models& m, std::uint16_t last[3]) {
    const std::uint32_t used = d.symbol(m.used);
    unsigned v[3];
    const auto byte = [&](int model, int base) { return (d.symbol(m.diff[model]) + unsigned(base)) & 0xFFu; };
    v[0] = (used & 1) ? byte(0, last[0] & 0xFF) : (last[0] & 0xFFu);
    v[0] |= ((used & 2) ? byte(1, last[0] >> 8) : (last[0] >> 8)) << 8;
    if (used & 64) {
      int diff = int(v[0] & 0xFF) - int(last[0] & 0xFF);
      v[1] = (used & 4) ? byte(2, clamp_u8(diff + (last[1] & 0xFF))) : (last[1] & 0xFFu);
      if (used & 16) {
        diff = (diff + (int(v[1] & 0xFF) - int(last[1] & 0xFF))) / 2;
        v[2] = byte(4, clamp_u8(diff + (last[2] & 0xFF)));
      } else {
        v[2] = last[2] & 0xFFu;
      }
      diff = int(v[0] >> 8) - int(last[0] >> 8);
      v[1] |= ((used & 8) ? byte(3, clamp_u8(diff + (last[1] >> 8))) : (last[1] >> 8)) << 8;
      if (used & 32) {
        diff = (diff + (int(v[1] >> 8) - int(last[1] >> 8))) / 2;
        v[2] |= byte(5, clamp_u8(diff + (last[2] >> 8))) << 8;
      } else {
        v[2] |= last[2] & 0xFF00u;
      }
    } else {
      v[1] = v[2] = v[0];
    }
    for (int c = 0; c < 3; ++c) last[c] = static_cast<std::uint16_t>(v[c]);
  }

  void decode(decoder& d, unsigned char* out) {
    decode_with(d, m_models, m_last);
    for (int c = 0; c < 3; ++c) store_le<std::uint16_t>(out + 2 * c, m_last[c]);
  }

  void encode(encoder& e, const unsigned char* item) { encode_with(e, m_models, m_last, item); }

  /// Codes the colour of `item` from `last` (updated to it) under models `m`.
  static void encode_with(encoder& e, models& m, std::uint16_t last[3], const unsigned char* item) {
    unsigned v[3];
    for (int c = 0; c < 3; ++c) v[c] = load_le<std::uint16_t>(item + 2 * c);
    const auto lo = [](unsigned x) { return int(x & 0xFF); };
    const auto hi = [](unsigned x) { return int(x >> 8); };
    std::uint32_t used = 0;
    for (int c = 0; c < 3; ++c) {
      used |= std::uint32_t(lo(v[c]) != lo(last[c])) << (2 * c);
      used |= std::uint32_t(hi(v[c]) != hi(last[c])) << (2 * c + 1);
    }
    used |= std::uint32_t(v[0] != v[1] || v[0] != v[2]) << 6;
    e.symbol(m.used, used);
    const auto put = [&](int model, int value) { e.symbol(m.diff[model], std::uint32_t(value) & 0xFFu); };
    int diff_l = 0, diff_h = 0;
    if (used & 1) put(0, diff_l = lo(v[0]) - lo(last[0]));
    if (used & 2) put(1, diff_h = hi(v[0]) - hi(last[0]));
    if (used & 64) {
      if (used & 4) put(2, lo(v[1]) - clamp_u8(diff_l + lo(last[1])));
      if (used & 16) {
        diff_l = (diff_l + lo(v[1]) - lo(last[1])) / 2;
        put(4, lo(v[2]) - clamp_u8(diff_l + lo(last[2])));
      }
      if (used & 8) put(3, hi(v[1]) - clamp_u8(diff_h + hi(last[1])));
      if (used & 32) {
        diff_h = (diff_h + hi(v[1]) - hi(last[1])) / 2;
        put(5, hi(v[2]) - clamp_u8(diff_h + hi(last[2])));
      }
    }
    for (int c = 0; c < 3; ++c) last[c] = static_cast<std::uint16_t>(v[c]);
  }

 private:
  std::uint16_t m_last[3];
  models m_models;
};

/// byte v2 (extra bytes): each byte's difference to the last point's, a model per byte.
class bytes_v2 {
 public:
  bytes_v2(const unsigned char* first, std::size_t n) : m_last(first, first + n), m_models(n, symbol_model(256)) {}

  void decode(decoder& d, unsigned char* out) {
    for (std::size_t i = 0; i < m_last.size(); ++i) {
      m_last[i] = static_cast<unsigned char>((m_last[i] + d.symbol(m_models[i])) & 0xFF);
      out[i] = m_last[i];
    }
  }

  void encode(encoder& e, const unsigned char* item) {
    for (std::size_t i = 0; i < m_last.size(); ++i) {
      e.symbol(m_models[i], (item[i] - m_last[i]) & 0xFFu);
      m_last[i] = item[i];
    }
  }

 private:
  std::vector<unsigned char> m_last;
  std::vector<symbol_model> m_models;
};

}  // namespace ced::io::detail::laz
