// SPDX-License-Identifier: MIT
// libFuzzer target: the LZF compressor (tests/fuzz/lzf_entry.hpp). Every
// parse must give the bytes of the plain parse and decompress to the data;
// any difference aborts with what differed.
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "lzf_entry.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string what = ced_fuzz::lzf_one(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!what.empty()) {
    std::fprintf(stderr, "fuzz_lzf: %s\n", what.c_str());
    std::abort();
  }
  return 0;
}
