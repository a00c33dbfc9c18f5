// SPDX-License-Identifier: MIT
// Tiled runs: what a plan records of its input to know it again: a
// fingerprint of the file's bytes, and a hash of every decoded point.
// Both hash little-endian values whatever the host, so that a plan made on
// one machine checks its input on another.
#include "tiled/fingerprint.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "ced/io/catalogue.hpp"
#include "core/hash.hpp"
#include "tiled/records.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// A fast hash of decoded data, 8 bytes at a time (the content of a plan),
/// the bytes taken as little-endian words.
std::uint64_t hash_words(const unsigned char* p, std::size_t n, std::uint64_t h) {
  auto mix = [](std::uint64_t x, std::uint64_t w) {
    x = (x ^ w) * 0x9E3779B97F4A7C15ull;
    return x ^ (x >> 29);
  };
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) h = mix(h, io::detail::load_le<std::uint64_t>(p + i));
  std::uint64_t tail = 0;
  for (std::size_t k = 0; i + k < n; ++k) tail |= std::uint64_t(p[i + k]) << (8 * k);
  return mix(mix(h, tail), n);
}

/// hash_words() of n values of w bytes at p, each little-endian.
std::uint64_t hash_values(const unsigned char* p, std::size_t w, std::size_t n, std::uint64_t h) {
  if (io::detail::host_little_endian() || w == 1) return hash_words(p, w * n, h);
  std::vector<char> le(w * n);
  for (std::size_t i = 0; i < n; ++i) copy_le(le.data() + w * i, reinterpret_cast<const char*>(p) + w * i, w);
  return hash_words(reinterpret_cast<const unsigned char*>(le.data()), le.size(), h);
}

}  // namespace

namespace tiled_detail {

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::array<float, 6> run_box(const point_cloud& c, std::size_t first, std::size_t n) {
  const float* q0 = c.position(first);
  std::array<float, 6> box = {q0[0], q0[1], q0[2], q0[0], q0[1], q0[2]};
  for (std::size_t i = first; i < first + n; ++i) {
    const float* q = c.position(i);
    for (std::size_t k = 0; k < 3; ++k) {
      box[k] = std::min(box[k], q[k]);
      box[3 + k] = std::max(box[3 + k], q[k]);
    }
  }
  return box;
}

std::uint64_t hash_chunk(const point_cloud& c, std::uint64_t h) { return hash_points(c, 0, c.size(), h); }

std::uint64_t hash_points(const point_cloud& c, std::size_t first, std::size_t n, std::uint64_t h) {
  h = hash_values(reinterpret_cast<const unsigned char*>(c.positions().data() + 3 * first), 4, 3 * n, h);
  for (const field& f : c.fields()) {
    const std::size_t w = size_of(f.type());
    h = hash_values(f.values.bytes() + w * first, w, n, h);
  }
  return h;
}

/// The file's size, and a hash of it: its size, its first and last 64 KiB and
/// 64 blocks of 4 KiB spread evenly (a different file, or one changed in
/// place, almost surely differs; reading it whole would cost a pass).
std::string fingerprint_of(const std::string& path, std::uint64_t& bytes) {
  if (io::names_catalogue(path)) {  // a folder or @LIST: its files, named and hashed in order
    bytes = 0;
    std::string all;
    for (const std::string& f : io::catalogue_files({path})) {
      std::uint64_t b = 0;
      all += f + '\n' + fingerprint_of(f, b) + '\n';
      bytes += b;
    }
    return hex(detail::fnv1a(all));
  }
  std::error_code ec;
  bytes = fs::file_size(path, ec);
  if (ec) throw io::io_error(path, "cannot read its size: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw io::io_error(path, "cannot open");
  std::string size_le;
  append_le(size_le, bytes);
  std::uint64_t h = detail::fnv1a(size_le);
  std::string buf;
  auto block = [&](std::uint64_t at, std::uint64_t n) {
    n = std::min<std::uint64_t>(n, bytes - std::min(at, bytes));
    buf.resize(static_cast<std::size_t>(n));
    in.seekg(static_cast<std::streamoff>(at));
    in.read(buf.data(), static_cast<std::streamsize>(n));
    if (!in) throw io::io_error(path, "cannot read it");
    h = detail::fnv1a(buf, h);
  };
  block(0, 65536);
  for (std::uint64_t k = 1; k <= 64; ++k) block(bytes / 65 * k, 4096);
  block(bytes > 65536 ? bytes - 65536 : 0, 65536);
  return hex(h);
}

}  // namespace tiled_detail

namespace tiled_detail {

bool compressed_input(const std::string& path, const io::read_options& read) {
  const std::vector<std::string> files =
      io::names_catalogue(path) ? io::catalogue_files({path}) : std::vector<std::string>{path};
  for (const std::string& f : files) {
    const io::file_format fmt = read.format == io::file_format::automatic ? io::format_of(f) : read.format;
    if (fmt != io::file_format::laz && fmt != io::file_format::copc) return false;
  }
  return !files.empty();
}

std::uint64_t file_bytes_hash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw io::io_error(path, "cannot open");
  // Eight bytes at a time (a multiply and a rotation each), the tail and the
  // size through FNV-1a: several GB a second.
  std::uint64_t h = detail::fnv1a_offset, size = 0;
  std::vector<char> buf(std::size_t(4) << 20);
  for (;;) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    std::size_t i = 0;
    for (; i + 8 <= got; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, buf.data() + i, 8);
      h = (h ^ w) * 0x9E3779B97F4A7C15ull;
      h = (h << 31) | (h >> 33);
    }
    h = detail::fnv1a(buf.data() + i, got - i, h);
    size += got;
    if (got < buf.size()) break;
  }
  if (in.bad()) throw io::io_error(path, "cannot read it");
  std::string size_le;
  append_le(size_le, size);
  return detail::fnv1a(size_le, h);
}

std::string bytes_hash_of(const std::string& path, const std::vector<std::uint64_t>& hashes) {
  if (!io::names_catalogue(path)) return hex(hashes.empty() ? file_bytes_hash(path) : hashes.front());
  std::string all;
  const std::vector<std::string> files = io::catalogue_files({path});
  for (std::size_t i = 0; i < files.size(); ++i)
    all += hex(i < hashes.size() ? hashes[i] : file_bytes_hash(files[i])) + '\n';
  return hex(detail::fnv1a(all));
}

}  // namespace tiled_detail

void check_plan_input(const tile_plan& plan) {
  std::uint64_t bytes = 0;
  const std::string fp = fingerprint_of(plan.request.input, bytes);
  if (bytes != plan.input_bytes || fp != plan.fingerprint)
    throw io::io_error(plan.request.input, "this is not the file the plan was made for (" + std::to_string(bytes) +
                                               " bytes, " + "fingerprint " + fp + "; the plan says " +
                                               std::to_string(plan.input_bytes) + " bytes, fingerprint " +
                                               plan.fingerprint + "): make a new plan");
}

}  // namespace ced
