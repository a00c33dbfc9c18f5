// SPDX-License-Identifier: MIT
// libFuzzer target: the CSV/text reader must reject any input with io_error
// (or std::invalid_argument), never crash, hang or allocate without bound.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ced/io/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const ced::point_cloud c = ced::io::read_csv_buffer(text, "fuzz.csv");
    (void)c.size();
  } catch (const ced::io::io_error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
