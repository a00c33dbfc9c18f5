// SPDX-License-Identifier: MIT
// libFuzzer target: modality spec strings, then detection on a tiny cloud
// that has the fields a spec may name. Bad specs are std::invalid_argument.
#include <string>

#include "ced/ced.hpp"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, std::size_t size) {
  static const ced::point_cloud cloud = [] {
    ced::point_cloud c;
    for (int i = 0; i < 20; ++i) c.push_back(0.01f * float(i % 5), 0.01f * float(i / 5), 0.0f);
    std::vector<double> v(20);
    for (int i = 0; i < 20; ++i) v[std::size_t(i)] = i * 7 % 256;
    for (const char* name : {"red", "green", "blue", "intensity", "nir", "a"})
      c.add_field(name, ced::scalar_type::uint8, v);
    return c;
  }();
  const std::string spec(reinterpret_cast<const char*>(data), size);
  try {
    const auto m = ced::make_modality(spec);
    ced::detect_params p;
    p.threads = 1;
    (void)ced::detect(cloud, p, {m});
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
