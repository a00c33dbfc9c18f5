// SPDX-License-Identifier: MIT
// io::cloud_writer: a cloud written in pieces is the bytes of the whole cloud
// written at once; wrong counts, layouts and streams are errors.

#include "stream_test_support.hpp"

using namespace stream_test;

// ------------------------------------------------------------ cloud_writer

namespace {

/// Points [i0, i0 + n) of `c`, with its fields and origin.
point_cloud slice(const point_cloud& c, std::size_t i0, std::size_t n) {
  std::vector<std::uint8_t> keep(c.size(), 0);
  std::fill(keep.begin() + std::ptrdiff_t(i0), keep.begin() + std::ptrdiff_t(i0 + n), 1);
  point_cloud s = c;
  s.filter(keep);
  return s;
}

/// The bytes cloud_writer writes of `c` in pieces of random sizes (some empty).
std::string in_pieces(const point_cloud& c, ced::io::file_format format, std::uint32_t seed) {
  const std::string path = temp_file("pieces_" + std::to_string(seed) + "." + ced::io::format_name(format));
  {
    ced::io::atomic_output_file f(path);
    ced::io::cloud_writer w(f.stream(), slice(c, 0, 0), c.size(), format);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::size_t> size(0, c.size() / 3 + 1);
    for (std::size_t at = 0; at < c.size();) {
      const std::size_t n = std::min(size(rng), c.size() - at);
      w.write(slice(c, at, n));
      at += n;
    }
    EXPECT_EQ(w.written(), c.size());
    w.finish();
    f.commit();
  }
  return read_bytes(path);
}

/// A stream that cannot seek (like a pipe).
struct pipe_buf : std::streambuf {
  std::string data;
  int_type overflow(int_type ch) override {
    if (ch != traits_type::eof()) data += traits_type::to_char_type(ch);
    return ch;
  }
};

}  // namespace

TEST(CloudWriter, PiecesAreTheWholeCloudsBytes) {
  using ced::io::file_format;
  for (auto format : {file_format::ply, file_format::pcd, file_format::las, file_format::csv, file_format::laz})
    for (std::size_t n : {0, 1, 17, 20000, 120001}) {
      if (n == 120001 && format != file_format::laz) continue;  // LAZ: chunks of 50,000 across the pieces
      const point_cloud c = georeferenced_cloud(n);
      point_cloud local = c;  // without an origin: float positions in PLY, PCD, CSV
      local.set_origin({0, 0, 0});
      for (const point_cloud* cloud : std::array<const point_cloud*, 2>{&c, &local}) {
        std::ostringstream whole;
        ced::io::write_cloud(whole, *cloud, format);
        for (std::uint32_t seed : {1u, 2u})
          EXPECT_EQ(in_pieces(*cloud, format, seed), whole.str())
              << ced::io::format_name(format) << ", " << n << " points, seed " << seed;
      }
    }
}

TEST(CloudWriter, WrongCountsLayoutsAndStreamsAreErrors) {
  using ced::io::file_format;
  const point_cloud c = georeferenced_cloud(10);
  const point_cloud layout = slice(c, 0, 0);
  for (auto format : {file_format::ply, file_format::pcd, file_format::csv}) {
    std::ostringstream out;
    ced::io::cloud_writer w(out, layout, 10, format);
    w.write(slice(c, 0, 6));
    EXPECT_THROW(w.write(slice(c, 0, 6)), std::invalid_argument);  // 12 of 10
    EXPECT_THROW(w.finish(), io_error);                            // 6 of 10
    point_cloud other = slice(c, 0, 2);
    other.fields().pop_back();
    EXPECT_THROW(w.write(other), std::invalid_argument);
    point_cloud moved = slice(c, 0, 2);
    moved.set_origin({0, 0, 0});
    EXPECT_THROW(w.write(moved), std::invalid_argument);
    w.write(slice(c, 6, 4));
    EXPECT_NO_THROW(w.finish());
  }
  pipe_buf pipe;
  std::ostream unseekable(&pipe);
  EXPECT_THROW(ced::io::cloud_writer(unseekable, layout, 10, file_format::las), std::invalid_argument);
  EXPECT_THROW(ced::io::cloud_writer(unseekable, layout, 10, file_format::laz), std::invalid_argument);
  EXPECT_NO_THROW(ced::io::cloud_writer(unseekable, layout, 10, file_format::ply));
  std::ostringstream out;
  EXPECT_THROW(ced::io::cloud_writer(out, layout, 10, file_format::automatic), std::invalid_argument);
  point_cloud bad = layout;
  bad.add_field("x", scalar_type::float32, std::vector<double>{});
  EXPECT_THROW(ced::io::cloud_writer(out, bad, 0, file_format::ply), std::invalid_argument);
}
