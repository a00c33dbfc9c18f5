// SPDX-License-Identifier: MIT
// libFuzzer target: the PCD reader (and its LZF decompressor) must reject any
// input with io_error (or std::invalid_argument), never crash, hang or
// allocate without bound.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ced/io/pcd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    const ced::point_cloud c = ced::io::read_pcd_buffer(bytes, "fuzz.pcd");
    (void)c.size();
  } catch (const ced::io::io_error&) {
  } catch (const std::invalid_argument&) {
  }
  // LZF alone: the first two bytes give the expected output size (scaled,
  // capped at 1 MiB), the rest is the compressed stream.
  if (size >= 2) {
    std::size_t out_size = (std::size_t(data[0]) << 8 | std::size_t(data[1])) * 16;
    if (out_size > (std::size_t(1) << 20)) out_size = std::size_t(1) << 20;
    try {
      const std::string out = ced::io::lzf_decompress(bytes.substr(2), out_size, "fuzz.lzf");
      (void)out.size();
    } catch (const ced::io::io_error&) {
    } catch (const std::invalid_argument&) {
    }
  }
  return 0;
}
