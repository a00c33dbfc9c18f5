// SPDX-License-Identifier: MIT
// Private to src/io: the entropy coder LAZ is coded with (chunks.cpp): an
// adaptive arithmetic decoder and encoder with 32-bit interval arithmetic,
// their adaptive bit and symbol models, and the integer coder built on them (a corrector
// coded as its bit length k, then its k bits). Written from the format's
// public description; every number below (the 13- and 15-bit probability
// scales, the update cycles, the halving of counts) is part of the format,
// since the decoder must adapt exactly as the encoder did.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace ced::io::detail::laz {

/// The decoder's steps are inlined into the items' decoders: a call each
/// would cost a third of a symbol's time.
#if defined(__GNUC__)
#define CED_LAZ_INLINE inline __attribute__((always_inline))
#else
#define CED_LAZ_INLINE inline
#endif

/// Thrown when the coded bytes end too early or decode to an impossible
/// value; the chunk decoder turns it into an io_error naming file and chunk.
struct corrupt : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr std::uint32_t min_length = 0x01000000u;  ///< renormalise below this
inline constexpr std::uint32_t bit_shift = 13;            ///< bit models' probability bits
inline constexpr std::uint32_t bit_max_count = 1u << bit_shift;
inline constexpr std::uint32_t symbol_shift = 15;  ///< symbol models' probability bits
inline constexpr std::uint32_t symbol_max_count = 1u << symbol_shift;

/// An adaptive model of one bit.
struct bit_model {
  std::uint32_t zero_count = 1, count = 2, zero_prob = 1u << (bit_shift - 1);
  std::uint32_t cycle = 4, until_update = 4;

  void update() noexcept {
    if ((count += cycle) > bit_max_count) {
      count = (count + 1) >> 1;
      zero_count = (zero_count + 1) >> 1;
      if (zero_count == count) ++count;
    }
    zero_prob = (zero_count * (0x80000000u / count)) >> (31 - bit_shift);
    cycle = (5 * cycle) >> 2;
    if (cycle > 64) cycle = 64;
    until_update = cycle;
  }
};

/// An adaptive model of `n` symbols (2 to 2048): symbol counts, and from
/// them the cumulative distribution, rebuilt on a growing cycle.
class symbol_model {
 public:
  /// A model of n symbols; n = 0: none yet (reset() makes it).
  explicit symbol_model(std::uint32_t n = 0) {
    if (n) reset(n);
  }

  void reset(std::uint32_t n) {
    m_n = n;
    m_count.assign(n, 1);
    m_dist.assign(n, 0);
    // Past 2 symbols, a table of the distribution in about 4n steps starts
    // the search, so that it mostly has one or two symbols left to test (a
    // speed-up only: it finds the same symbol).
    m_table_bits = 0;
    if (n > 2) {
      m_table_bits = 2;
      while ((1u << m_table_bits) < n && m_table_bits < 12) ++m_table_bits;
      m_table.assign((std::size_t(1) << m_table_bits) + 2, 0);
    }
    m_total = 0;
    m_cycle = n;
    update();
    m_until_update = m_cycle = (n + 6) >> 1;
  }
  std::uint32_t size() const noexcept { return m_n; }

  /// After decoding symbol s.
  void seen(std::uint32_t s) noexcept {
    ++m_count[s];
    if (--m_until_update == 0) update();
  }
  const std::uint32_t* distribution() const noexcept { return m_dist.data(); }
  /// The symbols [first, end) among which lies the last one whose
  /// distribution value is <= dv (value / (length >> 15), below 2^15 + 2^6).
  void candidates(std::uint32_t dv, std::uint32_t& first, std::uint32_t& end) const noexcept {
    if (!m_table_bits) {
      first = 0;
      end = m_n;
      return;
    }
    const std::uint32_t size = 1u << m_table_bits;
    std::uint32_t t = dv >> (symbol_shift - m_table_bits);
    if (t > size) t = size;
    first = m_table[t];
    end = m_table[t + 1] + 1;
  }

 private:
  void update() noexcept {
    if ((m_total += m_cycle) > symbol_max_count) {
      m_total = 0;
      for (std::uint32_t k = 0; k < m_n; ++k) m_total += (m_count[k] = (m_count[k] + 1) >> 1);
    }
    const std::uint32_t scale = 0x80000000u / m_total;
    std::uint32_t sum = 0;
    if (!m_table_bits) {
      for (std::uint32_t k = 0; k < m_n; ++k) {
        m_dist[k] = (scale * sum) >> (31 - symbol_shift);
        sum += m_count[k];
      }
    } else {
      // m_table[t]: the last symbol whose range starts at or below step t.
      const std::uint32_t shift = symbol_shift - m_table_bits, size = 1u << m_table_bits;
      std::uint32_t s = 0;
      for (std::uint32_t k = 0; k < m_n; ++k) {
        m_dist[k] = (scale * sum) >> (31 - symbol_shift);
        sum += m_count[k];
        const std::uint32_t w = m_dist[k] >> shift;
        while (s < w) m_table[++s] = k - 1;
      }
      m_table[0] = 0;
      while (s <= size) m_table[++s] = m_n - 1;
    }
    m_cycle = (5 * m_cycle) >> 2;
    const std::uint32_t max_cycle = (m_n + 6) << 3;
    if (m_cycle > max_cycle) m_cycle = max_cycle;
    m_until_update = m_cycle;
  }

  std::uint32_t m_n = 0, m_total = 0, m_cycle = 0, m_until_update = 0, m_table_bits = 0;
  std::vector<std::uint32_t> m_count, m_dist, m_table;
};

/// The arithmetic decoder over one chunk's bytes [p, end).
class decoder {
 public:
  decoder() = default;
  /// Starts decoding at p (four bytes of the interval's value).
  void start(const unsigned char* p, const unsigned char* end) {
    m_p = p;
    m_end = end;
    m_length = 0xFFFFFFFFu;
    m_value = 0;
    for (int i = 0; i < 4; ++i) m_value = (m_value << 8) | next_byte();
    if (m_value >= m_length) throw corrupt("the coded data starts with an impossible value");
  }
  /// Where the decoder has read to.
  const unsigned char* position() const noexcept { return m_p; }

  CED_LAZ_INLINE std::uint32_t bit(bit_model& m) {
    const std::uint32_t x = m.zero_prob * (m_length >> bit_shift);
    std::uint32_t sym;
    if (m_value < x) {
      sym = 0;
      m_length = x;
      ++m.zero_count;
    } else {
      sym = 1;
      m_value -= x;
      m_length -= x;
    }
    if (m_length < min_length) renormalise();
    if (--m.until_update == 0) m.update();
    return sym;
  }

  CED_LAZ_INLINE std::uint32_t symbol(symbol_model& m) {
    const std::uint32_t* dist = m.distribution();
    const std::uint32_t y0 = m_length;
    m_length >>= symbol_shift;
    // The largest symbol s with dist[s] * length <= value, by bisection
    // among the table's candidates.
    const std::uint32_t dv = m_value / m_length;
    std::uint32_t lo, hi;
    m.candidates(dv, lo, hi);
    while (hi > lo + 1) {
      const std::uint32_t k = (lo + hi) >> 1;
      if (dist[k] > dv)
        hi = k;
      else
        lo = k;
    }
    const std::uint32_t x = dist[lo] * m_length;
    const std::uint32_t y = lo + 1 < m.size() ? dist[lo + 1] * m_length : y0;
    m_value -= x;
    m_length = y - x;
    if (m_length < min_length) renormalise();
    m.seen(lo);
    return lo;
  }

  /// `bits` (1 to 32) raw bits.
  std::uint32_t bits(std::uint32_t bits) {
    if (bits > 19) {
      const std::uint32_t low = raw(16);
      return (raw(bits - 16) << 16) | low;
    }
    return raw(bits);
  }
  std::uint32_t u32() {
    const std::uint32_t low = raw(16);
    return (raw(16) << 16) | low;
  }

 private:
  std::uint32_t raw(std::uint32_t bits) {
    const std::uint32_t sym = m_value / (m_length >>= bits);
    m_value -= m_length * sym;
    if (m_length < min_length) renormalise();
    if (sym >= (1u << bits)) throw corrupt("a raw value out of its range");
    return sym;
  }
  std::uint32_t next_byte() {
    if (m_p == m_end) throw corrupt("the coded data ends early");
    return *m_p++;
  }
  void renormalise() {
    do {
      m_value = (m_value << 8) | next_byte();
    } while ((m_length <<= 8) < min_length);
  }

  const unsigned char* m_p = nullptr;
  const unsigned char* m_end = nullptr;
  std::uint32_t m_value = 0, m_length = 0;
};

/// The arithmetic encoder, appending to a string: the inverse of decoder
/// (a carry runs back through the bytes already written).
class encoder {
 public:
  explicit encoder(std::string& out) : m_out(out) {}

  void bit(bit_model& m, std::uint32_t sym) {
    const std::uint32_t x = m.zero_prob * (m_length >> bit_shift);
    if (sym == 0) {
      m_length = x;
      ++m.zero_count;
    } else {
      add(x);
      m_length -= x;
    }
    if (m_length < min_length) renormalise();
    if (--m.until_update == 0) m.update();
  }

  void symbol(symbol_model& m, std::uint32_t sym) {
    const std::uint32_t* dist = m.distribution();
    std::uint32_t x;
    if (sym + 1 == m.size()) {
      x = dist[sym] * (m_length >> symbol_shift);
      add(x);
      m_length -= x;
    } else {
      m_length >>= symbol_shift;
      x = dist[sym] * m_length;
      add(x);
      m_length = dist[sym + 1] * m_length - x;
    }
    if (m_length < min_length) renormalise();
    m.seen(sym);
  }

  /// `bits` (1 to 32) raw bits of v.
  void bits(std::uint32_t bits, std::uint32_t v) {
    if (bits > 19) {
      raw(16, v & 0xFFFFu);
      v >>= 16;
      bits -= 16;
    }
    raw(bits, v);
  }
  void u32(std::uint32_t v) {
    raw(16, v & 0xFFFFu);
    raw(16, v >> 16);
  }

  /// Ends the stream: the bytes that fix the interval, then the zeros the
  /// decoder reads ahead (it reads exactly to the end).
  void done() {
    bool another_byte = true;
    if (m_length > 2 * min_length) {
      add(min_length);
      m_length = min_length >> 1;
    } else {
      add(min_length >> 1);
      m_length = min_length >> 9;
      another_byte = false;
    }
    renormalise();
    m_out.append(another_byte ? 3 : 2, '\0');
  }

 private:
  void raw(std::uint32_t bits, std::uint32_t v) {
    m_length >>= bits;
    add(v * m_length);
    if (m_length < min_length) renormalise();
  }
  void add(std::uint32_t x) {
    const std::uint32_t before = m_base;
    m_base += x;
    if (m_base < before) carry();
  }
  void carry() {
    std::size_t i = m_out.size();
    while (i > m_first && static_cast<unsigned char>(m_out[i - 1]) == 0xFF) m_out[--i] = '\0';
    if (i > m_first) m_out[i - 1] = static_cast<char>(static_cast<unsigned char>(m_out[i - 1]) + 1);
  }
  void renormalise() {
    do {
      m_out.push_back(static_cast<char>(m_base >> 24));
      m_base <<= 8;
    } while ((m_length <<= 8) < min_length);
  }

  std::string& m_out;
  std::size_t m_first = m_out.size();  ///< the stream's first byte
  std::uint32_t m_base = 0, m_length = 0xFFFFFFFFu;
};

/// Integers coded as a correction to a prediction: the corrector's bit
/// length k under one of `contexts` models, then its value (the high bits
/// under a model for k, the rest raw). Values wrap into `bits` bits.
class integer_coder {
 public:
  explicit integer_coder(std::uint32_t bits = 16, std::uint32_t contexts = 1, std::uint32_t bits_high = 8)
      : m_bits_high(bits_high) {
    if (bits && bits < 32) {
      m_corr_bits = bits;
      m_corr_range = 1u << bits;
      m_corr_min = -static_cast<std::int32_t>(m_corr_range / 2);
    } else {
      m_corr_bits = 32;
      m_corr_range = 0;
      m_corr_min = INT32_MIN;
    }
    m_k_models.assign(contexts, symbol_model(m_corr_bits + 1));
    // The corrector models of each k (k = 0 has a bit model), made when k
    // first occurs: most chunks use a few (the same models as made up front,
    // since a model is only ever used from its initial state).
    m_corrector.resize(m_corr_bits + 1);
  }

  std::int32_t decode(decoder& d, std::int32_t prediction, std::uint32_t context) {
    // Wrapping arithmetic, as the format's 32-bit integers wrap.
    std::int32_t real = static_cast<std::int32_t>(static_cast<std::uint32_t>(prediction) +
                                                  static_cast<std::uint32_t>(corrector(d, m_k_models[context])));
    if (m_corr_range) {
      if (real < 0)
        real += static_cast<std::int32_t>(m_corr_range);
      else if (static_cast<std::uint32_t>(real) >= m_corr_range)
        real -= static_cast<std::int32_t>(m_corr_range);
    }
    return real;
  }
  void encode(encoder& e, std::int32_t prediction, std::int32_t real, std::uint32_t context) {
    auto c = static_cast<std::int32_t>(static_cast<std::uint32_t>(real) - static_cast<std::uint32_t>(prediction));
    if (m_corr_range) {
      const std::int32_t corr_max = static_cast<std::int32_t>(m_corr_range / 2) - 1;
      if (c < m_corr_min)
        c += static_cast<std::int32_t>(m_corr_range);
      else if (c > corr_max)
        c -= static_cast<std::int32_t>(m_corr_range);
    }
    write_corrector(e, c, m_k_models[context]);
  }
  /// The bit length k of the last corrector (the decoders use it as context).
  std::uint32_t k() const noexcept { return m_k; }

 private:
  std::int32_t corrector(decoder& d, symbol_model& k_model) {
    m_k = d.symbol(k_model);
    if (m_k == 0) return static_cast<std::int32_t>(d.bit(m_zero));
    if (m_k >= 32) return m_corr_min;
    std::int32_t c;
    if (m_k <= m_bits_high) {
      c = static_cast<std::int32_t>(d.symbol(corrector_model()));
    } else {
      const std::uint32_t low_bits = m_k - m_bits_high;
      const std::uint32_t high = d.symbol(corrector_model());
      c = static_cast<std::int32_t>((high << low_bits) | d.bits(low_bits));
    }
    // c in [0, 2^k): the upper half are the positive correctors from 2^(k-1) + 1,
    // the lower half the negative ones down to -(2^k - 1).
    if (c >= (std::int32_t(1) << (m_k - 1))) return static_cast<std::int32_t>(static_cast<std::uint32_t>(c) + 1u);
    return static_cast<std::int32_t>(static_cast<std::uint32_t>(c) - ((std::uint32_t(1) << m_k) - 1));
  }

  void write_corrector(encoder& e, std::int32_t c, symbol_model& k_model) {
    // k: the bit length of |c| for c <= 0, of c - 1 for c > 0.
    std::uint32_t c1 = c <= 0 ? 0u - static_cast<std::uint32_t>(c) : static_cast<std::uint32_t>(c) - 1;
    m_k = 0;
    while (c1) {
      c1 >>= 1;
      ++m_k;
    }
    e.symbol(k_model, m_k);
    if (m_k == 0) return e.bit(m_zero, static_cast<std::uint32_t>(c));
    if (m_k >= 32) return;
    std::uint32_t v =
        c < 0 ? static_cast<std::uint32_t>(c) + ((std::uint32_t(1) << m_k) - 1) : static_cast<std::uint32_t>(c) - 1;
    if (m_k <= m_bits_high) return e.symbol(corrector_model(), v);
    const std::uint32_t low_bits = m_k - m_bits_high;
    e.symbol(corrector_model(), v >> low_bits);
    e.bits(low_bits, v & ((std::uint32_t(1) << low_bits) - 1));
  }

  symbol_model& corrector_model() {
    symbol_model& m = m_corrector[m_k];
    if (m.size() == 0) m.reset(1u << (m_k <= m_bits_high ? m_k : m_bits_high));
    return m;
  }

  std::uint32_t m_bits_high;
  std::uint32_t m_corr_bits = 0, m_corr_range = 0;
  std::int32_t m_corr_min = 0;
  std::uint32_t m_k = 0;
  std::vector<symbol_model> m_k_models;
  bit_model m_zero;
  std::vector<symbol_model> m_corrector;
};

}  // namespace ced::io::detail::laz
