// SPDX-License-Identifier: MIT
// Private to src/io: the decoders of LAZ's pointwise items, version 1
// (LASzip 1.x: point10, gpstime11, rgb12, byte), which older archives still
// hold. Each predicts a record's item from the record before it, as version
// 2 does (items.hpp), with simpler contexts: a median of three for x
// and y, one sequence of GPS times, colour bytes coded as integers.
// Written from the format's public description; read only (ced writes
// version 2).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "io/laz/coder.hpp"
#include "io/laz/items.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io::detail::laz {

/// point10 v1: the 20 bytes of LAS point formats 0-5.
class point10_v1 {
 public:
  explicit point10_v1(const unsigned char* first) { std::memcpy(m_last, first, 20); }

  void decode(decoder& d, unsigned char* out) {
    const auto median3 = [](const std::int32_t* v) {
      return std::max(std::min(v[0], v[1]), std::min(std::max(v[0], v[1]), v[2]));
    };
    const std::int32_t dx = m_ic_dx.decode(d, median3(m_dx), 0);
    store_le<std::int32_t>(m_last, wrap_add(load_le<std::int32_t>(m_last), dx));
    std::uint32_t k = m_ic_dx.k();
    const std::int32_t dy = m_ic_dy.decode(d, median3(m_dy), k < 19 ? k : 19);
    store_le<std::int32_t>(m_last + 4, wrap_add(load_le<std::int32_t>(m_last + 4), dy));
    k = (k + m_ic_dy.k()) / 2;
    store_le<std::int32_t>(m_last + 8, m_ic_z.decode(d, load_le<std::int32_t>(m_last + 8), k < 19 ? k : 19));
    if (const std::uint32_t changed = d.symbol(m_changed)) {
      if (changed & 32) {
        const auto v = m_ic_intensity.decode(d, load_le<std::uint16_t>(m_last + 12), 0);
        store_le<std::uint16_t>(m_last + 12, static_cast<std::uint16_t>(v));
      }
      if (changed & 16) m_last[14] = static_cast<unsigned char>(d.symbol(m_flags[m_last[14]]));
      if (changed & 8) m_last[15] = static_cast<unsigned char>(d.symbol(m_class[m_last[15]]));
      if (changed & 4) m_last[16] = static_cast<unsigned char>(m_ic_scan_angle.decode(d, m_last[16], k < 3 ? 1 : 0));
      if (changed & 2) m_last[17] = static_cast<unsigned char>(d.symbol(m_user[m_last[17]]));
      if (changed & 1) {
        const auto v = m_ic_source.decode(d, load_le<std::uint16_t>(m_last + 18), 0);
        store_le<std::uint16_t>(m_last + 18, static_cast<std::uint16_t>(v));
      }
    }
    m_dx[m_next] = dx;
    m_dy[m_next] = dy;
    m_next = m_next == 2 ? 0 : m_next + 1;
    std::memcpy(out, m_last, 20);
  }

 private:
  unsigned char m_last[20];
  std::int32_t m_dx[3] = {0, 0, 0}, m_dy[3] = {0, 0, 0};  ///< the last three differences, a ring
  unsigned m_next = 0;
  symbol_model m_changed{64};
  models_by_byte m_flags, m_class, m_user;
  integer_coder m_ic_dx{32, 1}, m_ic_dy{32, 20}, m_ic_z{32, 20};
  integer_coder m_ic_intensity{16, 1}, m_ic_scan_angle{8, 2}, m_ic_source{16, 1};
};

/// gpstime11 v1: a double's bits, coded as integer differences from the last
/// time, multiples of the last difference predicted (one sequence).
class gpstime11_v1 {
 public:
  explicit gpstime11_v1(const unsigned char* first) : m_time(load_le<std::int64_t>(first)) {}

  void decode(decoder& d, unsigned char* out) {
    constexpr std::uint32_t multi_max = 512;
    if (m_diff == 0) {
      const std::uint32_t multi = d.symbol(m_zero_diff);
      if (multi == 1) {
        m_diff = m_ic.decode(d, 0, 0);
        m_time = wrap_add64(m_time, m_diff);
      } else if (multi == 2) {
        m_time = raw64(d);
      }
    } else {
      const std::uint32_t multi = d.symbol(m_multi);
      if (multi < multi_max - 2) {
        std::int32_t got;
        if (multi == 1) {
          got = m_diff = m_ic.decode(d, m_diff, 1);
          m_extreme = 0;
        } else if (multi == 0) {
          got = m_ic.decode(d, m_diff / 4, 2);
          far_diff(got);
        } else {
          got = m_ic.decode(d, wrap_mul(std::int32_t(multi), m_diff), multi < 10 ? 3 : (multi < 50 ? 4 : 5));
          if (multi == multi_max - 3) far_diff(got);
        }
        m_time = wrap_add64(m_time, got);
      } else if (multi == multi_max - 2) {
        m_time = raw64(d);
      }
    }
    store_le<std::int64_t>(out, m_time);
  }

 private:
  static std::int64_t raw64(decoder& d) {
    const std::uint64_t low = d.u32();
    return static_cast<std::int64_t>((std::uint64_t(d.u32()) << 32) | low);
  }
  /// A difference far from the prediction: after more than three in a row
  /// it becomes the last difference.
  void far_diff(std::int32_t got) noexcept {
    if (++m_extreme > 3) {
      m_diff = got;
      m_extreme = 0;
    }
  }

  std::int64_t m_time;
  std::int32_t m_diff = 0, m_extreme = 0;
  symbol_model m_multi{512}, m_zero_diff{3};
  integer_coder m_ic{32, 6};
};

/// rgb12 v1: which of the six colour bytes changed, then each changed byte
/// as an integer from the last point's.
class rgb12_v1 {
 public:
  explicit rgb12_v1(const unsigned char* first) {
    for (int c = 0; c < 3; ++c) m_last[c] = load_le<std::uint16_t>(first + 2 * c);
  }

  void decode(decoder& d, unsigned char* out) {
    const std::uint32_t used = d.symbol(m_used);
    for (std::uint32_t c = 0; c < 3; ++c) {
      const unsigned last = m_last[c];
      unsigned v = (used & (1u << (2 * c))) ? unsigned(m_ic.decode(d, std::int32_t(last & 0xFF), 2 * c)) : last & 0xFF;
      v |= (used & (2u << (2 * c))) ? unsigned(m_ic.decode(d, std::int32_t(last >> 8), 2 * c + 1)) << 8 : last & 0xFF00;
      m_last[c] = static_cast<std::uint16_t>(v);
      store_le<std::uint16_t>(out + 2 * c, m_last[c]);
    }
  }

 private:
  std::uint16_t m_last[3];
  symbol_model m_used{64};
  integer_coder m_ic{8, 6};
};

/// byte v1 (extra bytes): each byte as an integer from the last point's, a context per byte.
class bytes_v1 {
 public:
  bytes_v1(const unsigned char* first, std::size_t n)
      : m_last(first, first + n), m_ic(8, static_cast<std::uint32_t>(n)) {}

  void decode(decoder& d, unsigned char* out) {
    for (std::size_t i = 0; i < m_last.size(); ++i) {
      m_last[i] = static_cast<unsigned char>(m_ic.decode(d, m_last[i], static_cast<std::uint32_t>(i)));
      out[i] = m_last[i];
    }
  }

 private:
  std::vector<unsigned char> m_last;
  integer_coder m_ic;
};

}  // namespace ced::io::detail::laz
