// SPDX-License-Identifier: MIT
// libFuzzer target: the LAZ decoder (through the LAS reader, which hands it
// any file whose point format byte says compressed) must reject any input
// with io_error (or std::invalid_argument), never crash, hang or allocate
// without bound. Seeded with a real LAZ file (tests/fuzz/corpus/laz).
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ced/io/las.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    ced::io::las_read_info info;
    const ced::point_cloud c = ced::io::read_las_buffer(bytes, "fuzz.laz", &info);
    (void)c.size();
  } catch (const ced::io::io_error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
