// SPDX-License-Identifier: MIT
// LZF (ced/io/lzf.hpp): known streams, round trips, and corrupt or truncated
// input refused with an io_error, never read or written out of bounds.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "ced/io/error.hpp"
#include "ced/io/lzf.hpp"
#include "file_support.hpp"
#include "fuzz/lzf_entry.hpp"
#include "io/base/scalar_io.hpp"

using ced::io::io_error;

namespace {

std::string lzf_error(const std::string& compressed, std::size_t out_size) {
  try {
    ced::io::lzf_decompress(compressed, out_size, "lzf");
  } catch (const io_error& e) {
    return e.what();
  }
  return "<no io_error thrown>";
}

}  // namespace

TEST(Lzf, HandEncodedStreamDecodes) {
  // Literal "abc", then a back-reference of 9 bytes at distance 3 (extended length byte), then one of 3 bytes.
  const std::string lzf(
      "\x02"
      "abc"
      "\xE0\x00\x02"
      "\x20\x04",
      9);
  EXPECT_EQ(ced::io::lzf_decompress(lzf, 15, "lzf"), "abcabcabcabcbca");
}

TEST(Lzf, RandomAndRepetitiveDataRoundTrip) {
  std::mt19937 rng(7);
  std::vector<std::string> inputs = {"", "a", "ab", "abc", "aaaa", std::string(1 << 20, '\0')};
  for (std::size_t size : {5u, 31u, 32u, 33u, 1000u, 100000u}) {
    std::string s(size, '\0');
    for (auto& ch : s) ch = static_cast<char>(rng());
    inputs.push_back(s);  // incompressible
    std::string t(size, '\0');
    for (std::size_t i = 0; i < size; ++i) t[i] = static_cast<char>(rng() % 4 == 0 ? rng() : i % 13);
    inputs.push_back(t);  // partly repetitive
  }
  std::string long_range;  // repeats at distances near the 8192 limit
  for (int i = 0; i < 20000; ++i) long_range += static_cast<char>((i % 8193) * 2654435761u >> 24);
  inputs.push_back(long_range);
  for (const auto& in : inputs) {
    const std::string packed = ced::io::lzf_compress(in);
    EXPECT_LE(packed.size(), in.size() + in.size() / 32 + 1);
    EXPECT_EQ(ced::io::lzf_decompress(packed, in.size(), "lzf"), in) << "size " << in.size();
  }
  EXPECT_LT(ced::io::lzf_compress(std::string(1 << 20, '\0')).size(), (1u << 20) / 80);
}

TEST(Lzf, SegmentsOnThreadsGiveTheBytesOfOneParse) {
  // Segments parsed apart (and joined where a match runs over a boundary)
  // must give exactly the bytes of one parse from the start.
  std::mt19937 rng(11);
  std::vector<std::string> inputs;
  for (std::size_t size : {0u, 1u, 2u, 3u, 40u, 4097u, 4098u, 5000u, 60000u}) {
    std::string s(size, '\0');
    for (auto& ch : s) ch = static_cast<char>(rng());
    inputs.push_back(s);
    for (auto& ch : s) ch = static_cast<char>(rng() % 3);  // short matches everywhere
    inputs.push_back(s);
  }
  std::string copies;  // long matches over many boundaries, at distances up to 8192
  while (copies.size() < 120000)
    copies += copies.size() > 9000 && rng() % 4 ? copies.substr(copies.size() - 1 - rng() % 8000, 1 + rng() % 600)
                                                : std::string(1, static_cast<char>(rng()));
  inputs.push_back(copies);
  inputs.push_back(std::string(50000, 'z'));
  for (std::size_t period : {8191u, 8192u, 8193u}) {  // repeats at the reach of a back-reference and just past it
    std::string block(period, '\0');
    for (auto& ch : block) ch = static_cast<char>(rng());
    inputs.push_back(block + block + block.substr(0, 5000));
  }
  std::string floats;  // like a PCD column: slowly varying floats
  for (int i = 0; i < 20000; ++i) {
    const float f = static_cast<float>(i % 700) * 0.01f + static_cast<float>(rng() % 50) * 1e-4f;
    floats.append(reinterpret_cast<const char*>(&f), sizeof f);
  }
  inputs.push_back(floats);
  for (const std::string& in : inputs) {
    const std::string whole = ced::io::detail::lzf_compress_segmented(in, in.size() + 1, 1);
    EXPECT_EQ(whole, ced::io::lzf_compress(in));
    // The windowed passes give the bytes of the plain parse, a position at a
    // time, with and without the vector passes.
    EXPECT_EQ(whole, ced::io::detail::lzf_compress_reference(in)) << "size " << in.size();
    ced::io::detail::lzf_vector_passes = false;
    EXPECT_EQ(ced::io::detail::lzf_compress_segmented(in, in.size() + 1, 1), whole) << "portable, size " << in.size();
    ced::io::detail::lzf_vector_passes = true;
    ASSERT_EQ(ced::io::lzf_decompress(whole, in.size(), "lzf"), in);
    for (std::size_t segment : {1u, 2u, 7u, 64u, 1000u, 8192u, 8193u, 30000u}) {
      if (segment < 64 && in.size() > 5000) continue;  // each segment seeds 8 KiB: too slow
      for (unsigned threads : {2u, 3u})
        EXPECT_EQ(ced::io::detail::lzf_compress_segmented(in, segment, threads), whole)
            << "size " << in.size() << ", segments of " << segment << ", " << threads << " threads";
    }
  }
}

TEST(Lzf, GeneratedDataParsesAlikeEveryWay) {
  // fuzz_lzf's check on programs drawn at random: literals, copies near and
  // past the 8 KiB reach, runs, float columns (tests/fuzz/lzf_entry.hpp).
  std::mt19937 rng(29);
  std::size_t bytes = 0;
  for (int i = 0; i < 300; ++i) {
    std::string program(1 + rng() % 400, '\0');
    for (auto& ch : program) ch = static_cast<char>(rng());
    const std::string data = ced_fuzz::lzf_data(program);
    bytes += data.size();
    EXPECT_EQ(ced_fuzz::lzf_check(data, 64 + rng() % 20000), "") << "program " << i << ", " << data.size() << " bytes";
  }
  EXPECT_GT(bytes, std::size_t(1) << 20);  // the programs made data, not empty strings
}

TEST(Lzf, CorruptDataIsDetected) {
  // Back-reference before the start of the output.
  EXPECT_CONTAINS(lzf_error(std::string("\x20\x00", 2), 3), "corrupt LZF data");
  EXPECT_CONTAINS(lzf_error(std::string("\x20\x00", 2), 3), "before the start of the output");
  EXPECT_CONTAINS(lzf_error(std::string("\x01xy\x20\x05", 5), 5), "before the start of the output");
  // Output overflow: by a literal run and by a back-reference.
  EXPECT_CONTAINS(lzf_error(std::string("\x03xyzw", 5), 3), "exceed the declared 3 bytes");
  EXPECT_CONTAINS(lzf_error(std::string("\x00x\xE0\x10\x00", 5), 10), "exceed the declared 10 bytes");
  // Input ends inside a literal run or a back-reference.
  EXPECT_CONTAINS(lzf_error(std::string("\x05xy", 3), 6), "past the end of the input");
  EXPECT_CONTAINS(lzf_error(std::string("\x00x\x20", 3), 4), "truncated back-reference");
  EXPECT_CONTAINS(lzf_error(std::string("\x00x\xE0", 3), 12), "truncated back-reference");
  // Too short.
  EXPECT_CONTAINS(lzf_error(std::string("\x01xy", 3), 3), "expands to 2 bytes, not the declared 3");
  EXPECT_CONTAINS(lzf_error("", 1), "corrupt LZF data");
}

TEST(Lzf, FlippedBytesNeverReadOrWriteOutOfBounds) {
  std::mt19937 rng(3);
  std::string in;
  for (int i = 0; i < 5000; ++i) in += static_cast<char>(i % 50 < 10 ? rng() : i % 17);
  const std::string packed = ced::io::lzf_compress(in);
  int errors = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bad = packed;
    for (int k = 0; k < 3; ++k) bad[rng() % bad.size()] ^= static_cast<char>(1 + rng() % 255);
    if (trial % 3 == 0) bad.resize(rng() % bad.size());
    try {
      EXPECT_EQ(ced::io::lzf_decompress(bad, in.size(), "lzf").size(), in.size());
    } catch (const io_error& e) {
      EXPECT_CONTAINS(e.what(), "corrupt LZF data");
      ++errors;
    }
  }
  EXPECT_GT(errors, 1000);
}

TEST(Lzf, KnownCompressedStreams) {
  // ced's compressor is deterministic: the bytes of PCD binary_compressed files depend on it.
  EXPECT_EQ(ced::io::lzf_compress(""), "");
  EXPECT_EQ(ced::io::lzf_compress("ab"), std::string("\x01"
                                                     "ab",
                                                     3));
  // A literal 'a', then a back-reference of 9 bytes at distance 1 (the pattern repeated).
  EXPECT_EQ(ced::io::lzf_compress("aaaaaaaaaa"), std::string("\x00"
                                                             "a"
                                                             "\xE0\x00\x00",
                                                             5));
  // A literal "abc", then 12 bytes at distance 3.
  EXPECT_EQ(ced::io::lzf_compress("abcabcabcabcabc"), std::string("\x02"
                                                                  "abc"
                                                                  "\xE0\x03\x02",
                                                                  7));
  // Literal runs hold at most 32 bytes.
  std::string distinct;
  for (int i = 0; i < 40; ++i) distinct += static_cast<char>(i);
  const std::string packed = ced::io::lzf_compress(distinct);
  EXPECT_EQ(packed, "\x1f" + distinct.substr(0, 32) + "\x07" + distinct.substr(32));
}

TEST(Lzf, EveryTruncationIsAnError) {
  std::string in;
  for (int i = 0; i < 3000; ++i) in += static_cast<char>(i % 7 == 0 ? i * 31 : i % 11);
  const std::string packed = ced::io::lzf_compress(in);
  ASSERT_EQ(ced::io::lzf_decompress(packed, in.size(), "lzf"), in);
  for (std::size_t n = 0; n < packed.size(); ++n)
    EXPECT_CONTAINS(lzf_error(packed.substr(0, n), in.size()), "lzf: corrupt LZF data") << "first " << n << " bytes";
}

TEST(Lzf, WrongDeclaredSizeIsAnError) {
  const std::string in(1000, 'x');
  const std::string packed = ced::io::lzf_compress(in);
  EXPECT_CONTAINS(lzf_error(packed, in.size() + 1), "not the declared 1001");
  EXPECT_CONTAINS(lzf_error(packed, in.size() - 1), "exceed the declared 999 bytes");
  EXPECT_CONTAINS(lzf_error(packed, 0), "corrupt LZF data");
}
