// SPDX-License-Identifier: MIT
// libFuzzer target: the stb image decoding of user RGB-D frames (depth and
// colour images) must reject any input with io_error, never crash, hang or
// allocate beyond the frame its header declares.
#include <cstddef>
#include <stdexcept>
#include <string_view>

#include "rgbd_entry.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  try {
    ced_fuzz::rgbd_one(std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const ced::io::io_error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
