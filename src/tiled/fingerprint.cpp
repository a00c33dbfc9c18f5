// SPDX-License-Identifier: MIT
// Tiled runs: what a plan records of its input to know it again: a
// fingerprint of the file's bytes, and a hash of every decoded point.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "core/hash.hpp"
#include "tiled/internal.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// A fast hash of decoded data, 8 bytes at a time (the content of a plan).
std::uint64_t hash_words(const unsigned char* p, std::size_t n, std::uint64_t h) {
  auto mix = [](std::uint64_t x, std::uint64_t w) {
    x = (x ^ w) * 0x9E3779B97F4A7C15ull;
    return x ^ (x >> 29);
  };
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = mix(h, w);
  }
  std::uint64_t tail = 0;
  if (i < n) std::memcpy(&tail, p + i, n - i);
  return mix(mix(h, tail), n);
}

}  // namespace

namespace tiled_detail {

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::uint64_t hash_chunk(const point_cloud& c, std::uint64_t h) {
  h = hash_words(reinterpret_cast<const unsigned char*>(c.positions().data()), 12 * c.size(), h);
  for (const field& f : c.fields()) h = hash_words(f.values.bytes(), size_of(f.type()) * c.size(), h);
  return h;
}

/// The file's size, and a hash of it: its size, its first and last 64 KiB and
/// 64 blocks of 4 KiB spread evenly (a different file, or one changed in
/// place, almost surely differs; reading it whole would cost a pass).
std::string fingerprint_of(const std::string& path, std::uint64_t& bytes) {
  std::error_code ec;
  bytes = fs::file_size(path, ec);
  if (ec) fail(path, "cannot read its size: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  std::uint64_t h = detail::fnv1a(reinterpret_cast<const char*>(&bytes), sizeof bytes);
  std::string buf;
  auto block = [&](std::uint64_t at, std::uint64_t n) {
    n = std::min<std::uint64_t>(n, bytes - std::min(at, bytes));
    buf.resize(static_cast<std::size_t>(n));
    in.seekg(static_cast<std::streamoff>(at));
    in.read(buf.data(), static_cast<std::streamsize>(n));
    if (!in) fail(path, "cannot read it");
    h = detail::fnv1a(buf, h);
  };
  block(0, 65536);
  for (std::uint64_t k = 1; k <= 64; ++k) block(bytes / 65 * k, 4096);
  block(bytes > 65536 ? bytes - 65536 : 0, 65536);
  return hex(h);
}

}  // namespace tiled_detail

void check_plan_input(const tile_plan& plan) {
  std::uint64_t bytes = 0;
  const std::string fp = fingerprint_of(plan.request.input, bytes);
  if (bytes != plan.input_bytes || fp != plan.fingerprint)
    fail(plan.request.input, "this is not the file the plan was made for (" + std::to_string(bytes) + " bytes, " +
                                 "fingerprint " + fp + "; the plan says " + std::to_string(plan.input_bytes) +
                                 " bytes, fingerprint " + plan.fingerprint + "): make a new plan");
}

}  // namespace ced
