// SPDX-License-Identifier: MIT
// Private: small text helpers shared by core and io (not installed). ASCII
// only and locale-independent.
#pragma once

#include <charconv>
#include <string>
#include <string_view>
#include <vector>

namespace ced::detail {

/// ' ', '\t', '\n', '\r', '\v' or '\f' (std::isspace in the "C" locale).
inline bool is_space(char c) noexcept {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/// `c` in lower case when it is an ASCII capital.
inline char ascii_lower(char c) noexcept { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }

/// `s` with ASCII capitals in lower case.
inline std::string to_lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = ascii_lower(c);
  return r;
}

/// `s` with ASCII small letters in capitals.
inline std::string to_upper(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = c >= 'a' && c <= 'z' ? static_cast<char>(c - 'a' + 'A') : c;
  return r;
}

/// True when `a` and `b` are equal ignoring ASCII case.
inline bool iequal(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (ascii_lower(a[i]) != ascii_lower(b[i])) return false;
  return true;
}

/// `s` without leading and trailing spaces (is_space).
inline std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

/// A number for messages as %g writes it, 6 significant digits (0.05,
/// 1e-30, 2.5e+06, nan), in any locale.
inline std::string number_text(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 6);
  return std::string(buf, r.ptr);
}

/// At most 40 characters of `s`, non-printable bytes replaced by '?', for messages.
inline std::string printable(std::string_view s) {
  std::string r;
  for (char c : s.substr(0, 40)) r += (c >= 32 && c < 127) ? c : '?';
  if (s.size() > 40) r += "...";
  return r;
}

/// Reads the words of a text one by one: the runs of characters between
/// separators (by default is_space).
template <bool (*IsSeparator)(char) noexcept = is_space>
struct word_reader {
  const char* p;    ///< where the next word is looked for
  const char* end;  ///< the end of the text

  explicit word_reader(std::string_view text) noexcept : p(text.data()), end(text.data() + text.size()) {}

  /// The next word, or false at the end of the text.
  bool next(std::string_view& word) noexcept {
    while (p < end && IsSeparator(*p)) ++p;
    if (p == end) return false;
    const char* b = p;
    while (p < end && !IsSeparator(*p)) ++p;
    word = std::string_view(b, static_cast<std::size_t>(p - b));
    return true;
  }
};

/// The words of `line` (runs of non-space characters).
inline std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  word_reader<> reader(line);
  for (std::string_view w; reader.next(w);) words.push_back(w);
  return words;
}

/// Appends `size` bytes at `data` to `out` as base64 (RFC 4648, with '=' padding).
inline void base64_append(const void* data, std::size_t size, std::string& out) {
  static const char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  out.reserve(out.size() + (size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const unsigned v = (unsigned(p[i]) << 16) | (unsigned(p[i + 1]) << 8) | p[i + 2];
    out += table[v >> 18];
    out += table[(v >> 12) & 63];
    out += table[(v >> 6) & 63];
    out += table[v & 63];
  }
  if (i < size) {
    const unsigned v = (unsigned(p[i]) << 16) | (i + 1 < size ? unsigned(p[i + 1]) << 8 : 0u);
    out += table[v >> 18];
    out += table[(v >> 12) & 63];
    out += i + 1 < size ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
}

/// The bytes that base64_append() wrote as `text`; false (and `out` partly
/// filled) when `text` is not such base64: a length not a multiple of 4, a
/// character outside the alphabet, or misplaced padding.
inline bool base64_decode(std::string_view text, std::string& out) {
  out.clear();
  if (text.size() % 4 != 0) return false;
  const auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  out.reserve(text.size() / 4 * 3);
  for (std::size_t i = 0; i < text.size(); i += 4) {
    const bool last = i + 4 == text.size();
    const int pad = last ? (text[i + 3] == '=') + (text[i + 2] == '=') : 0;
    if (pad == 1 && text[i + 2] == '=') return false;  // "x=y=" style
    unsigned v = 0;
    for (int k = 0; k < 4; ++k) {
      const int d = k >= 4 - pad ? 0 : value(text[i + std::size_t(k)]);
      if (d < 0) return false;
      v = (v << 6) | unsigned(d);
    }
    out += static_cast<char>(v >> 16);
    if (pad < 2) out += static_cast<char>((v >> 8) & 255);
    if (pad < 1) out += static_cast<char>(v & 255);
  }
  return true;
}

}  // namespace ced::detail
