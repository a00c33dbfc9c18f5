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

}  // namespace ced::detail
