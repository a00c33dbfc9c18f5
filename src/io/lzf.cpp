// SPDX-License-Identifier: MIT
// LZF (ced/io/lzf.hpp), the compression of PCD binary_compressed.
#include "ced/io/lzf.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "ced/io/error.hpp"
#include "core/raw_vector.hpp"
#include "scalar_io.hpp"

namespace ced::io {

namespace {

constexpr unsigned k_hash_bits = 15;
constexpr std::size_t k_max_distance = 8192, k_max_match = 264;

/// The three bytes at i as one value (i + 2 < n).
inline std::uint32_t triple(const unsigned char* in, std::size_t i) noexcept {
  return (std::uint32_t(in[i]) << 16) | (std::uint32_t(in[i + 1]) << 8) | in[i + 2];
}
inline std::uint32_t hash_of(std::uint32_t v) noexcept { return (v * 2654435761u) >> (32 - k_hash_bits); }

/// One back-reference of the parse: `len` bytes at `pos` repeat those
/// `dist` bytes before.
struct lzf_match {
  std::size_t pos;
  std::uint32_t len, dist;
};

/// The greedy LZF parse from one position on. Its table holds, for each
/// hash, the last earlier position (+ 1, relative to `base`) with that hash:
/// every position is entered in order, whatever the parse does, so the
/// table at position i depends only on the bytes before i, and only the
/// last k_max_distance of them matter (a candidate further back is never
/// used). A parser seeded with those bytes therefore finds exactly the
/// matches of one that started at the beginning.
class lzf_parser {
 public:
  lzf_parser(const unsigned char* in, std::size_t n) : m_in(in), m_n(n), m_table(std::size_t(1) << k_hash_bits) {}

  /// Ready to parse from `from`: the table as the whole parse has it there.
  void start(std::size_t from) {
    std::fill(m_table.begin(), m_table.end(), 0u);
    m_base = from > k_max_distance ? from - k_max_distance : 0;
    for (std::size_t k = m_base; k < from && k + 2 < m_n; ++k) enter(k);
  }
  /// Parses from `i` (start()'s position, or where the last call stopped),
  /// calling match(m) for each back-reference, until stop(position) holds
  /// at a position the parse considers (a match's start or a literal) or
  /// the input ends; returns that position.
  template <class Match, class Stop>
  std::size_t parse(std::size_t i, Match match, Stop stop) {
    while (i + 2 < m_n && !stop(i)) {
      const std::uint32_t v = triple(m_in, i);
      std::uint32_t& slot = m_table[hash_of(v)];
      const std::size_t candidate = slot;
      slot = static_cast<std::uint32_t>(i - m_base + 1);
      if (candidate != 0) {
        const std::size_t c = m_base + candidate - 1;
        const std::size_t distance = i - c;  // >= 1
        if (distance <= k_max_distance && triple(m_in, c) == v) {
          const std::size_t max_len = std::min(k_max_match, m_n - i);
          std::size_t len = 3;
          while (len < max_len && m_in[c + len] == m_in[i + len]) ++len;
          match(lzf_match{i, static_cast<std::uint32_t>(len), static_cast<std::uint32_t>(distance)});
          for (std::size_t k = i + 1; k < i + len && k + 2 < m_n; ++k) enter(k);
          i += len;
          continue;
        }
      }
      ++i;
    }
    return std::min(i, m_n);
  }

 private:
  void enter(std::size_t k) noexcept { m_table[hash_of(triple(m_in, k))] = static_cast<std::uint32_t>(k - m_base + 1); }

  const unsigned char* m_in;
  std::size_t m_n;
  std::vector<std::uint32_t> m_table;
  std::size_t m_base = 0;  // positions are entered relative to it (segments are far below 4 GiB)
};

/// Writes in[from, to) as literal runs of at most 32 bytes at o; returns the end.
unsigned char* put_literals(const unsigned char* in, std::size_t from, std::size_t to, unsigned char* o) noexcept {
  while (from < to) {
    const std::size_t k = std::min<std::size_t>(32, to - from);
    *o++ = static_cast<unsigned char>(k - 1);
    std::memcpy(o, in + from, k);
    o += k;
    from += k;
  }
  return o;
}

/// Writes the back-reference m at o; returns the end.
unsigned char* put_match(const lzf_match& m, unsigned char* o) noexcept {
  const std::size_t l = m.len - 2, off = m.dist - 1;
  if (l < 7) {
    *o++ = static_cast<unsigned char>((l << 5) | (off >> 8));
  } else {
    *o++ = static_cast<unsigned char>((7 << 5) | (off >> 8));
    *o++ = static_cast<unsigned char>(l - 7);
  }
  *o++ = static_cast<unsigned char>(off & 0xff);
  return o;
}

/// Literals cost one byte in 32, a back-reference at most as much as it
/// covers: LZF of n bytes never takes more than this.
constexpr std::size_t lzf_bound(std::size_t n) noexcept { return n + n / 32 + 16; }

/// One segment's parse and its LZF bytes, as if the whole parse were at its
/// first byte with no literal pending: each back-reference after the
/// literals before it, none of the literals after the last one.
struct segment_parse {
  std::vector<lzf_match> matches;
  std::vector<std::size_t> token_at;                    ///< where each match's bytes start in `bytes`
  ced::detail::raw_column_vector<unsigned char> bytes;  ///< its capacity is reused
  std::size_t size = 0;                                 ///< bytes used
  std::size_t end = 0;  ///< where the parse stopped: ≥ the segment's end unless the input ended

  void run(lzf_parser& p, const unsigned char* in, std::size_t from, std::size_t to) {
    matches.clear();
    token_at.clear();
    if (bytes.size() < lzf_bound(to - from) + 8) bytes.resize(lzf_bound(to - from) + 8);
    unsigned char* const first = bytes.data();
    unsigned char* o = first;
    std::size_t lit = from;
    p.start(from);
    end = p.parse(
        from,
        [&](const lzf_match& m) {
          o = put_literals(in, lit, m.pos, o);
          token_at.push_back(static_cast<std::size_t>(o - first));
          o = put_match(m, o);
          matches.push_back(m);
          lit = m.pos + m.len;
        },
        [to](std::size_t i) { return i >= to; });
    size = static_cast<std::size_t>(o - first);
  }
  /// Whether the parse considered position q (not strictly inside a match).
  bool considered(std::size_t q) const {
    auto it = std::upper_bound(matches.begin(), matches.end(), q,
                               [](std::size_t x, const lzf_match& m) { return x < m.pos; });
    if (it == matches.begin()) return true;
    --it;
    return q == it->pos || q >= it->pos + it->len;
  }
  /// The first of its matches at or after q.
  std::size_t first_from(std::size_t q) const {
    return static_cast<std::size_t>(std::lower_bound(matches.begin(), matches.end(), q,
                                                     [](const lzf_match& m, std::size_t x) { return m.pos < x; }) -
                                    matches.begin());
  }
};

}  // namespace

namespace detail {

std::size_t lzf_segment_bytes(std::size_t n) noexcept {
  // Segments of 1 MiB (the seed of each, 8 KiB of table entries, costs
  // under 1 %); an input under 8 MiB is one segment, on one thread (the
  // segments' own buffers would cost more than a second thread gains).
  constexpr std::size_t mib = std::size_t(1) << 20;
  return n < 8 * mib ? std::max<std::size_t>(n, 1) : mib;
}

void lzf_compress_into(std::string_view input, ced::detail::raw_column_vector<unsigned char>& out, std::size_t segment,
                       unsigned threads) {
  const auto* in = reinterpret_cast<const unsigned char*>(input.data());
  const std::size_t n = input.size();
  segment = std::max<std::size_t>(segment, 1);
  const std::size_t segments = (n + segment - 1) / segment;
  out.resize(lzf_bound(n));
  unsigned char* const first = out.data();
  unsigned char* o = first;
  const std::size_t batch = std::min<std::size_t>(segments, ced::detail::effective_threads(threads));
  if (batch <= 1) {  // one thread: the parse straight into the output
    lzf_parser p(in, n);
    p.start(0);
    std::size_t lit = 0;
    p.parse(
        0,
        [&](const lzf_match& m) {
          o = put_match(m, put_literals(in, lit, m.pos, o));
          lit = m.pos + m.len;
        },
        [](std::size_t) { return false; });
    o = put_literals(in, lit, n, o);
    out.resize(static_cast<std::size_t>(o - first));
    return;
  }
  // Segments are parsed and coded on their own, a batch at a time in
  // parallel, each as if the parse were at its first byte. The whole parse
  // reaches a segment's start exactly unless a match runs over it: then it
  // goes on from where it is, one step at a time, until it reaches a
  // position the segment's parse also considered; from there the two are
  // the same, and so are the bytes from the segment's next match on. Only
  // the literals before that match are coded again (their runs of 32 start
  // where the whole parse's literals do).
  std::vector<segment_parse> parsed(batch);
  lzf_parser walker(in, n);
  std::size_t pos = 0, lit = 0;  // where the whole parse is; its pending literals' start
  for (std::size_t s0 = 0; s0 < segments; s0 += batch) {
    const std::size_t count = std::min(batch, segments - s0);
    ced::detail::parallel_for(count, threads, 1, [&](std::size_t b, std::size_t e) {
      lzf_parser p(in, n);
      for (std::size_t k = b; k < e; ++k) {
        const std::size_t from = (s0 + k) * segment;
        parsed[k].run(p, in, from, std::min(n, from + segment));
      }
    });
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t from = (s0 + k) * segment, to = std::min(n, from + segment);
      const segment_parse& own = parsed[k];
      if (pos >= to) continue;  // a match of the whole parse covers the segment
      if (pos > from) {
        walker.start(pos);
        pos = walker.parse(
            pos,
            [&](const lzf_match& m) {
              o = put_match(m, put_literals(in, lit, m.pos, o));
              lit = m.pos + m.len;
            },
            [&](std::size_t i) { return i >= to || own.considered(i); });
        if (pos >= to) continue;
      }
      const std::size_t f = own.first_from(pos);
      if (f < own.matches.size()) {
        o = put_literals(in, lit, own.matches[f].pos, o);
        const std::size_t bytes = own.size - own.token_at[f];
        std::memcpy(o, own.bytes.data() + own.token_at[f], bytes);
        o += bytes;
        lit = own.matches.back().pos + own.matches.back().len;
      }
      pos = own.end;
    }
  }
  o = put_literals(in, lit, n, o);
  out.resize(static_cast<std::size_t>(o - first));
}

std::string lzf_compress_segmented(std::string_view input, std::size_t segment, unsigned threads) {
  ced::detail::raw_column_vector<unsigned char> out;
  lzf_compress_into(input, out, segment, threads);
  return std::string(out.begin(), out.end());
}

}  // namespace detail

std::string lzf_compress(std::string_view input) {
  return detail::lzf_compress_segmented(input, detail::lzf_segment_bytes(input.size()), 0);
}

std::string lzf_decompress(std::string_view input, std::size_t out_size, const std::string& name_for_errors) {
  std::string result(out_size, '\0');
  detail::lzf_decompress_into(input, result.data(), out_size, name_for_errors);
  return result;
}

void detail::lzf_decompress_into(std::string_view input, char* output, std::size_t out_size,
                                 const std::string& name_for_errors) {
  const auto corrupt = [&](const std::string& why) {
    throw io_error(name_for_errors, "corrupt LZF data (" + why + ")");
  };
  const auto* in = reinterpret_cast<const unsigned char*>(input.data());
  const std::size_t n = input.size();
  auto* out = reinterpret_cast<unsigned char*>(output);
  std::size_t ip = 0, op = 0;
  while (ip < n) {
    const std::size_t at = ip;
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t run = ctrl + 1;
      if (run > n - ip)
        corrupt("a literal run of " + std::to_string(run) + " bytes at input offset " + std::to_string(at) +
                " goes past the end of the input");
      if (run > out_size - op) corrupt("the output would exceed the declared " + std::to_string(out_size) + " bytes");
      std::memcpy(out + op, in + ip, run);
      ip += run;
      op += run;
    } else {
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= n) corrupt("truncated back-reference at input offset " + std::to_string(at));
        len += in[ip++];
      }
      if (ip >= n) corrupt("truncated back-reference at input offset " + std::to_string(at));
      const std::size_t distance = ((ctrl & 0x1fu) << 8) + in[ip++] + 1;
      if (distance > op)
        corrupt("a back-reference at input offset " + std::to_string(at) + " points before the start of the output");
      len += 2;
      if (len > out_size - op) corrupt("the output would exceed the declared " + std::to_string(out_size) + " bytes");
      const unsigned char* src = out + op - distance;
      if (distance >= len) {
        std::memcpy(out + op, src, len);
      } else {
        for (std::size_t k = 0; k < len; ++k) out[op + k] = src[k];  // overlapping: repeats a pattern
      }
      op += len;
    }
  }
  if (op != out_size)
    corrupt("it expands to " + std::to_string(op) + " bytes, not the declared " + std::to_string(out_size));
}

}  // namespace ced::io
