// SPDX-License-Identifier: MIT
// Private to src/tiled: what identifies a plan's input and its runs: hashes,
// run boxes, the file's fingerprint (fingerprint.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "ced/cloud.hpp"
#include "ced/tiled.hpp"

namespace ced::tiled_detail {

namespace fs = std::filesystem;

std::string hex(std::uint64_t v);
/// A chunk's positions and every field's values, into the content hash.
std::uint64_t hash_chunk(const point_cloud& c, std::uint64_t h);
/// hash_chunk() of the points [first, first + n) of `c`, as of a cloud of
/// those alone (a run of tile_plan::runs).
std::uint64_t hash_points(const point_cloud& c, std::size_t first, std::size_t n, std::uint64_t h);
/// The box of the points [first, first + n) of `c` (n > 0): a run's
/// plan_run::box, which a tile that reads the run checks.
std::array<float, 6> run_box(const point_cloud& c, std::size_t first, std::size_t n);
/// The file's size (into `bytes`), and a hash of it (check_plan_input()).
std::string fingerprint_of(const std::string& path, std::uint64_t& bytes);
/// Whether every file of the input (a file, or a folder or @LIST of them)
/// is LAZ or COPC: the decoding costs far more than reading its bytes.
bool compressed_input(const std::string& path, const io::read_options& read);
/// A hash of every byte of file `path` (tile_plan::bytes_hash).
std::uint64_t file_bytes_hash(const std::string& path);
/// tile_plan::bytes_hash of the input: of its files' file_bytes_hash(), in
/// order (`hashes`: theirs when known, else computed here).
std::string bytes_hash_of(const std::string& path, const std::vector<std::uint64_t>& hashes = {});

}  // namespace ced::tiled_detail
