// SPDX-License-Identifier: MIT
// LZF (ced/io/lzf.hpp), the compression of PCD binary_compressed.
#include "ced/io/lzf.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "ced/io/error.hpp"
#include "core/raw_vector.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io {

namespace detail {
bool lzf_vector_passes = true;
}  // namespace detail

namespace {

constexpr unsigned k_hash_bits = 15;
static_assert(k_hash_bits <= 16, "hashes are kept as 16 bits");
constexpr std::size_t k_max_distance = 8192, k_max_match = 264;

/// The three bytes at i as one value (i + 2 < n).
inline std::uint32_t triple(const unsigned char* in, std::size_t i) noexcept {
  return (std::uint32_t(in[i]) << 16) | (std::uint32_t(in[i + 1]) << 8) | in[i + 2];
}
inline std::uint32_t hash_of(std::uint32_t v) noexcept { return (v * 2654435761u) >> (32 - k_hash_bits); }

/// The hashes of positions [k0, n) at `in` (in[n + 1] readable) to h[k0..n).
void lzf_hashes_scalar(const unsigned char* in, std::size_t k0, std::size_t n, std::uint16_t* h) noexcept {
  for (std::size_t k = k0; k < n; ++k) h[k] = static_cast<std::uint16_t>(hash_of(triple(in, k)));
}
/// Marks (bit k of marks, cleared before) the positions k in [k0, n) at `in`
/// (in[n + 1] readable) whose candidate dist[k] bytes before (0: none) is
/// within reach and starts with the same 3 bytes.
void lzf_matches_scalar(const unsigned char* in, std::size_t k0, std::size_t n, const std::uint32_t* dist,
                        std::uint64_t* marks) noexcept {
  for (std::size_t k = k0; k < n;) {
    const std::size_t w = k / 64, k_end = std::min(n, w * 64 + 64);
    std::uint64_t bits = 0;  // in a register: no store and reload of the word per position
    for (; k < k_end; ++k) {
      const std::uint32_t d = dist[k];
      const bool near = d - 1 < k_max_distance;  // 0 wraps
      const std::size_t back = near ? d : 0;     // out of reach: the position itself, in cache
      bits |= std::uint64_t(near & (triple(in - back, k) == triple(in, k))) << (k % 64);
    }
    marks[w] |= bits;
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
/// lzf_hashes_scalar() of [0, n) (n a multiple of 8, in[n + 3] readable),
/// and each position's 3 bytes to own[] (the first in the low byte) for
/// lzf_matches_avx2().
__attribute__((target("avx2"))) std::size_t lzf_hashes_avx2(const unsigned char* in, std::size_t n, std::uint16_t* h,
                                                            std::uint32_t* own) noexcept {
  // Lane j of a 32-bit vector: bytes k + j, k + j + 1, k + j + 2 as triple() orders them.
  const __m256i shuffle = _mm256_setr_epi8(2, 1, 0, -1, 3, 2, 1, -1, 4, 3, 2, -1, 5, 4, 3, -1,  //
                                           2, 1, 0, -1, 3, 2, 1, -1, 4, 3, 2, -1, 5, 4, 3, -1);
  const __m256i in_order = _mm256_setr_epi8(0, 1, 2, -1, 1, 2, 3, -1, 2, 3, 4, -1, 3, 4, 5, -1,  //
                                            0, 1, 2, -1, 1, 2, 3, -1, 2, 3, 4, -1, 3, 4, 5, -1);
  const __m256i mul = _mm256_set1_epi32(static_cast<int>(2654435761u));
  for (std::size_t k = 0; k < n; k += 8) {
    // bytes k..k+7 in the low lane, k+4..k+11 in the high one (each 8-byte load stays below k + 12 ≤ n + 4)
    std::uint64_t lo, hi;
    std::memcpy(&lo, in + k, 8);
    std::memcpy(&hi, in + k + 4, 8);
    const __m256i bytes = _mm256_set_epi64x(0, static_cast<long long>(hi), 0, static_cast<long long>(lo));
    const __m256i v = _mm256_shuffle_epi8(bytes, shuffle);
    const __m256i hv = _mm256_srli_epi32(_mm256_mullo_epi32(v, mul), 32 - k_hash_bits);
    const __m128i packed = _mm_packus_epi32(_mm256_castsi256_si128(hv), _mm256_extracti128_si256(hv, 1));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(h + k), packed);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(own + k), _mm256_shuffle_epi8(bytes, in_order));
  }
  return n;
}
/// lzf_matches_scalar() of [0, n) (n a multiple of 8, in[n + 3] readable).
__attribute__((target("avx2"))) std::size_t lzf_matches_avx2(const unsigned char* in, std::size_t n,
                                                             const std::uint32_t* dist, const std::uint32_t* own,
                                                             std::uint64_t* marks) noexcept {
  const __m256i one = _mm256_set1_epi32(1), flip = _mm256_set1_epi32(static_cast<int>(0x80000000u));
  const __m256i reach = _mm256_set1_epi32(static_cast<int>(k_max_distance ^ 0x80000000u));
  const __m256i low3 = _mm256_set1_epi32(0xffffff), lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (std::size_t k = 0; k < n; k += 8) {
    const __m256i d = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(dist + k));
    // d − 1 < k_max_distance, unsigned (0 wraps): signed with the sign bits flipped
    const __m256i near = _mm256_cmpgt_epi32(reach, _mm256_xor_si256(_mm256_sub_epi32(d, one), flip));
    // offsets from in + k: j − d in reach, j itself otherwise
    const __m256i off = _mm256_sub_epi32(lanes, _mm256_and_si256(d, near));
    const __m256i theirs = _mm256_i32gather_epi32(reinterpret_cast<const int*>(in + k), off, 1);
    const __m256i mine = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(own + k));
    const __m256i same = _mm256_cmpeq_epi32(_mm256_and_si256(theirs, low3), mine);
    const auto bits = static_cast<std::uint64_t>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_and_si256(same, near))));
    marks[k / 64] |= bits << (k % 64);
  }
  return n;
}
bool lzf_has_avx2() noexcept {
  static const bool has = __builtin_cpu_supports("avx2");
  return has && detail::lzf_vector_passes;
}
#endif

/// The hashes of positions [0, n) at `in` (in[n + 1] readable); the first
/// `fast` (a multiple of 8, in[fast + 3] readable) in vectors where the CPU
/// has AVX2, which also writes their own 3 bytes to own[] for lzf_matches().
void lzf_hashes(const unsigned char* in, std::size_t n, std::size_t fast, std::uint16_t* h,
                std::uint32_t* own) noexcept {
  std::size_t done = 0;
#if defined(__x86_64__) && defined(__GNUC__)
  if (lzf_has_avx2()) done = lzf_hashes_avx2(in, fast, h, own);
#else
  (void)fast;
  (void)own;
#endif
  lzf_hashes_scalar(in, done, n, h);
}
/// lzf_matches_scalar() of [0, n), the first `fast` in vectors as lzf_hashes() chose.
void lzf_matches(const unsigned char* in, std::size_t n, std::size_t fast, const std::uint32_t* dist,
                 const std::uint32_t* own, std::uint64_t* marks) noexcept {
  std::size_t done = 0;
#if defined(__x86_64__) && defined(__GNUC__)
  if (lzf_has_avx2()) done = lzf_matches_avx2(in, fast, dist, own, marks);
#else
  (void)fast;
  (void)own;
#endif
  lzf_matches_scalar(in, done, n, dist, marks);
}

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
  /// The parse from start()'s position `i` until the first position it
  /// considers at or after `to` (or the input's end), which it returns:
  /// exactly what parse(i, match, [to](k) { return k >= to; }) does, but a
  /// window of positions at a time, in passes without data-dependent
  /// branches. Since every position enters the table whatever the parse
  /// does, each position's candidate (and whether it starts a match of at
  /// least 3 bytes) is known before the parse reaches it; the parse then
  /// only jumps from one marked position to the next. The table is left
  /// past the returned position, so parse() cannot go on from it.
  template <class Match>
  std::size_t parse_until(std::size_t i, std::size_t to, Match match) {
    const std::size_t last = m_n > 2 ? m_n - 2 : 0;  // positions considered: k + 2 < n
    std::size_t b = i;                               // positions below b have entered the table
    while (i < last && i < to) {
      const std::size_t a = b;
      if (a <= i) {  // the next window: [i, …), the positions skipped by a match entered too
        b = std::min(last, a + k_window);
        mark(a, b);
        m_window = a;
      }
      const std::size_t limit = std::min(b, to);
      const std::size_t p = next_mark(i, limit);
      if (p >= limit) {
        i = limit;
        continue;
      }
      const std::size_t c = p - m_dist[p - m_window];
      const std::size_t len = match_length(c, p);
      match(lzf_match{p, static_cast<std::uint32_t>(len), static_cast<std::uint32_t>(p - c)});
      i = p + len;
    }
    return std::min(i, m_n);
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

  /// How many bytes from p repeat those from c < p (at least 3, which the
  /// caller knows), as the byte-by-byte loop of parse() counts them.
  std::size_t match_length(std::size_t c, std::size_t p) const noexcept {
    const std::size_t max_len = std::min(k_max_match, m_n - p);
    std::size_t len = 3;
    for (; detail::host_little_endian() && len + 8 <= max_len; len += 8) {
      std::uint64_t x, y;
      std::memcpy(&x, m_in + c + len, 8);
      std::memcpy(&y, m_in + p + len, 8);
      if (x != y) return len + static_cast<std::size_t>(__builtin_ctzll(x ^ y)) / 8;  // little-endian: the first byte
    }
    while (len < max_len && m_in[c + len] == m_in[p + len]) ++len;
    return len;
  }

  /// Enters positions [a, b) (b + 2 ≤ n) in order and marks, in m_marks
  /// (bit k − a), those whose candidate is within reach and starts with the
  /// same three bytes, with its distance in m_dist[k − a].
  void mark(std::size_t a, std::size_t b) noexcept {
    const std::size_t count = b - a;
    // Positions whose 4-byte loads stay inside the input go through the
    // vector passes (AVX2 where the CPU has it); the last few, scalar.
    const std::size_t fast = std::min(count, m_n >= a + 4 ? m_n - a - 4 : 0) / 8 * 8;
    // 1. Each position's hash.
    lzf_hashes(m_in + a, count, fast, m_hash, m_own);
    // 2. The table, in order: each position's candidate, as a distance (0: none).
    std::uint32_t* const table = m_table.data();
    const auto rel = static_cast<std::uint32_t>(a - m_base + 1);  // position a as the table has it
    for (std::size_t k = 0; k < count; ++k) {
      std::uint32_t& slot = table[m_hash[k]];
      const std::uint32_t candidate = slot;
      slot = rel + static_cast<std::uint32_t>(k);
      m_dist[k] = candidate != 0 ? rel + static_cast<std::uint32_t>(k) - candidate : 0;
    }
    // 3. Which candidates are in reach and start with the same 3 bytes. One
    // out of reach reads the position itself (in cache): most candidates
    // are stale, and reading them would miss the cache.
    std::fill(m_marks, m_marks + (count + 63) / 64, std::uint64_t(0));
    lzf_matches(m_in + a, count, fast, m_dist, m_own, m_marks);
  }
  /// The first marked position in [i, limit) of the window, or limit.
  std::size_t next_mark(std::size_t i, std::size_t limit) const noexcept {
    std::size_t k = i - m_window;
    const std::size_t end = limit - m_window;
    while (k < end) {
      const std::uint64_t w = m_marks[k / 64] >> (k % 64);
      if (w != 0) return std::min(limit, m_window + k + static_cast<std::size_t>(__builtin_ctzll(w)));
      k = (k / 64 + 1) * 64;
    }
    return limit;
  }

  static constexpr std::size_t k_window = 1024;
  std::uint64_t m_marks[k_window / 64];
  std::uint16_t m_hash[k_window];
  std::uint32_t m_own[k_window];
  std::uint32_t m_dist[k_window];
  std::size_t m_window = 0;  // the window's first position

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

/// The LZF bytes of all n bytes at `in` as one parse, to o (room for
/// lzf_bound(n)); returns their end. Windowed: parse_until()'s passes;
/// otherwise parse(), a position at a time (the reference).
unsigned char* compress_whole(const unsigned char* in, std::size_t n, unsigned char* o, bool windowed) {
  lzf_parser p(in, n);
  p.start(0);
  std::size_t lit = 0;
  const auto match = [&](const lzf_match& m) {
    o = put_match(m, put_literals(in, lit, m.pos, o));
    lit = m.pos + m.len;
  };
  if (windowed)
    p.parse_until(0, n, match);
  else
    p.parse(0, match, [](std::size_t) { return false; });
  return put_literals(in, lit, n, o);
}

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
    end = p.parse_until(from, to, [&](const lzf_match& m) {
      o = put_literals(in, lit, m.pos, o);
      token_at.push_back(static_cast<std::size_t>(o - first));
      o = put_match(m, o);
      matches.push_back(m);
      lit = m.pos + m.len;
    });
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
    out.resize(static_cast<std::size_t>(compress_whole(in, n, first, true) - first));
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

std::string lzf_compress_reference(std::string_view input) {
  const auto* in = reinterpret_cast<const unsigned char*>(input.data());
  const std::size_t n = input.size();
  std::string out(lzf_bound(n), '\0');
  auto* const first = reinterpret_cast<unsigned char*>(out.data());
  out.resize(static_cast<std::size_t>(compress_whole(in, n, first, false) - first));
  return out;
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
