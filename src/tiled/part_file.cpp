// SPDX-License-Identifier: MIT
// Tiled runs: a tile's part as a file (write_part, read_part, and the reader
// the merge streams from).
//
// A part file, little-endian whatever the host (records.cpp), m modalities:
//   offset 0       8-byte magic "CEDPART\0"
//   offset 8       u32 format version (tiled_file_version)
//   offset 12      the plan's digest (16 hex characters)
//   offset 28      u64 tile, u64 keypoints, u32 m, u32 fields (the plan's tile fields)
//   offset 52      u64 candidates per modality (m of them)
//   offset 52+8m   u64 any_candidates, f64 detect_ms
//   offset 68+8m   per keypoint, ascending index: its point record, then
//                  its f32 saliency per modality, then its f32 rank
//                  (detection_result::rank_score)
#include "tiled/part_file.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <type_traits>

#include "ced/io/output_file.hpp"
#include "tiled/fingerprint.hpp"
#include "tiled/modalities.hpp"
#include "tiled/records.hpp"

namespace ced {

using namespace tiled_detail;

namespace tiled_detail {

void write_part_as(const std::string& path, const tile_plan& plan, const std::string& digest, const tile_part& part) {
  std::string out = tiled_header(part_kind);
  // A part of another plan would be stamped with this plan's digest.
  if (part.plan != digest)
    throw std::invalid_argument("the part of tile " + std::to_string(part.tile) +
                                " belongs to another plan (plan digest " +
                                (part.plan.empty() ? std::string("none") : part.plan) + ", `plan` has " + digest + ")");
  out += digest;
  append_le(out, part.tile);
  append_le(out, std::uint64_t(part.index.size()));
  append_le(out, std::uint32_t(part.saliency.size()));
  append_le(out, std::uint32_t(tile_fields_of(plan).size()));
  for (std::uint64_t c : part.candidates) append_le(out, c);
  append_le(out, part.any_candidates);
  append_le(out, part.detect_ms);
  for (std::size_t j = 0; j < part.index.size(); ++j) {
    append_record(out, part.index[j], part.file_index[j], part.keypoints, j);
    for (const auto& s : part.saliency) append_le(out, s[j]);
    append_le(out, part.rank[j]);
  }
  io::atomic_output_file f(path);
  f.stream().write(out.data(), static_cast<std::streamsize>(out.size()));
  f.commit();
}

part_reader::part_reader(const std::string& path, const tile_plan& plan, const std::string& digest) : m_path(path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw io::io_error(path, std::string("cannot open: ") + std::strerror(errno));
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec) throw io::io_error(path, "cannot read its size: " + ec.message());
  const auto modalities = modalities_of(plan.request.modalities);
  const std::size_t m = modalities.size();
  // header, digest, tile, keypoints, modalities, fields, candidates, any, ms
  const std::size_t head = tiled_header_bytes + digest.size() + 8 + 8 + 4 + 4 + 8 * m + 8 + 8;
  std::string b(std::min<std::uint64_t>(size, head), '\0');
  in.read(b.data(), static_cast<std::streamsize>(b.size()));
  if (!in) throw io::io_error(path, "cannot read it");
  check_tiled_header(b.data(), b.size(), size, part_kind, path);
  std::size_t at = tiled_header_bytes;
  if (b.size() < at + digest.size())
    throw io::io_error(path, "truncated tile part (" + std::to_string(size) + " bytes)");
  if (b.compare(at, digest.size(), digest) != 0)
    throw io::io_error(path, "this part belongs to another plan (plan digest " + b.substr(at, digest.size()) +
                                 ", expected " + digest + ")");
  if (b.size() < head) throw io::io_error(path, "truncated tile part (" + std::to_string(size) + " bytes)");
  at += digest.size();
  auto get = [&](auto& v) {
    v = load_le<std::remove_reference_t<decltype(v)>>(b.data() + at);
    at += sizeof v;
  };
  std::uint32_t nm = 0, nf = 0;
  totals.plan = digest;
  get(totals.tile);
  get(m_count);
  get(nm);
  get(nf);
  if (nm != m || nf != tile_fields_of(plan).size())
    throw io::io_error(path, "its modalities or fields differ from the plan's");
  name_modalities(plan, modalities, totals);
  totals.candidates.resize(m);
  for (auto& c : totals.candidates) get(c);
  get(totals.any_candidates);
  get(totals.detect_ms);
  totals.keypoints = empty_cloud(plan, 0);
  totals.saliency.assign(m, {});
  m_record = record_size(plan) + 4 * m + 4;
  m_offset = head;
  if (m_count > (size - head) / m_record || size - head != m_count * m_record)
    throw io::io_error(path, "truncated or oversized tile part: " + std::to_string(m_count) + " keypoints declared");
  m_left = m_count;
}

const char* part_reader::next(std::size_t buffer) {
  if (m_at == m_buf.size()) {
    if (m_left == 0) return nullptr;
    const std::uint64_t n = std::min<std::uint64_t>(m_left, std::max<std::size_t>(1, buffer / m_record));
    m_buf.resize(static_cast<std::size_t>(n * m_record));
    std::ifstream in(m_path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(m_offset));
    in.read(m_buf.data(), static_cast<std::streamsize>(m_buf.size()));
    if (!in) throw io::io_error(m_path, "cannot read it (was it changed during the merge?)");
    m_offset += m_buf.size();
    m_left -= n;
    m_at = 0;
  }
  const char* r = m_buf.data() + m_at;
  m_at += m_record;
  return r;
}

void decode_part_record(const char* r, tile_part& p, std::size_t j) {
  r = decode_records(r, 1, p.keypoints, j, p.index.data() + j, p.file_index.data() + j);
  for (auto& s : p.saliency) {
    s[j] = load_le<float>(r);
    r += 4;
  }
  p.rank[j] = load_le<float>(r);
}

void resize_part(tile_part& p, const tile_plan& plan, std::size_t n) {
  p.keypoints = empty_cloud(plan, n);
  p.index.resize(n);
  p.file_index.resize(n);
  for (auto& s : p.saliency) s.resize(n);
  p.rank.resize(n);
}

}  // namespace tiled_detail

void write_part(const std::string& path, const tile_plan& plan, const tile_part& part) {
  write_part_as(path, plan, plan.digest(), part);
}

tile_part read_part(const std::string& path, const tile_plan& plan) {
  part_reader r(path, plan, plan.digest());
  tile_part p = std::move(r.totals);
  resize_part(p, plan, static_cast<std::size_t>(r.count()));
  const std::size_t buffer = std::size_t(8) << 20;
  for (std::size_t j = 0; j < p.index.size(); ++j) decode_part_record(r.next(buffer), p, j);
  return p;
}

}  // namespace ced
