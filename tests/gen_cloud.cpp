// SPDX-License-Identifier: MIT
// A test fixture as a file: `gen_cloud N SEED OUT.las|ply|...` writes the
// room of test_support.hpp (floor, two walls, a box; colour patches, NIR,
// intensity) with N points, moved to georeferenced coordinates
// (x + 500000, y + 4000000) and with its colour as 16-bit fields, as the
// CLI tests of tiles and MPI need a cloud of a million points or more.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "ced/io/io.hpp"
#include "test_support.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: gen_cloud N SEED OUT\n");
    return 2;
  }
  try {
    ced::point_cloud c = ced_test::make_room(std::stoul(argv[1]), static_cast<std::uint32_t>(std::stoul(argv[2])));
    c.set_origin({500000.0, 4000000.0, 0.0});
    for (auto& f : c.fields())
      if (f.name == "red" || f.name == "green" || f.name == "blue") {
        std::vector<double> v(c.size());
        for (std::size_t i = 0; i < c.size(); ++i) v[i] = f.values[i];
        f.values = ced::column(ced::scalar_type::uint16, v);
      }
    ced::io::write_cloud(argv[3], c);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gen_cloud: %s\n", e.what());
    return 1;
  }
  return 0;
}
