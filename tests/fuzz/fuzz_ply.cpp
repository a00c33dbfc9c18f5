// SPDX-License-Identifier: MIT
// libFuzzer target: the PLY reader must reject any input with io_error (or
// std::invalid_argument), never crash, hang or allocate without bound.
#include <sstream>
#include <string>

#include "ced/io/ply.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const ced::point_cloud c = ced::io::read_ply(in, "fuzz.ply");
    (void)c.size();
  } catch (const ced::io::io_error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
