// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
// LZF, the compression of PCD binary_compressed (also through ced/io/pcd.hpp).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace ced::io {

/// LZF compression in the liblzf format used by PCD binary_compressed. Never
/// fails; the output may be slightly larger than the input (at most
/// size + size / 32 + 1 bytes) when the input does not compress.
std::string lzf_compress(std::string_view in);
/// Decompresses LZF data that must expand to exactly `out_size` bytes. Every
/// read and write is bounds-checked: a truncated input, a back-reference
/// before the start of the output, output past `out_size` or output shorter
/// than `out_size` throw io_error "<name_for_errors>: corrupt LZF data (...)".
std::string lzf_decompress(std::string_view in, std::size_t out_size, const std::string& name_for_errors);

}  // namespace ced::io
