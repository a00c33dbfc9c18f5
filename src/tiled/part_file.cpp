// SPDX-License-Identifier: MIT
// Tiled runs: a tile's part as a file (write_part, read_part, and the reader
// the merge streams from).
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

#include "ced/io/output_file.hpp"
#include "tiled/internal.hpp"

namespace ced {

using namespace tiled_detail;

namespace {
constexpr char part_magic[8] = {'C', 'E', 'D', 'P', 'A', 'R', 'T', '1'};
}  // namespace

namespace tiled_detail {

void write_part_as(const std::string& path, const tile_plan& plan, const std::string& digest, const tile_part& part) {
  std::string out(part_magic, 8);
  // A part of another plan would be stamped with this plan's digest.
  if (part.plan != digest)
    throw std::invalid_argument("the part of tile " + std::to_string(part.tile) +
                                " belongs to another plan (plan digest " +
                                (part.plan.empty() ? std::string("none") : part.plan) + ", `plan` has " + digest + ")");
  out += digest;
  auto put = [&](const auto& v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(part.tile);
  put(std::uint64_t(part.index.size()));
  put(std::uint32_t(part.saliency.size()));
  put(std::uint32_t(plan.fields.size()));
  for (std::uint64_t c : part.candidates) put(c);
  put(part.any_candidates);
  put(part.detect_ms);
  for (std::size_t j = 0; j < part.index.size(); ++j) {
    append_record(out, part.index[j], part.file_index[j], part.keypoints, j);
    for (const auto& s : part.saliency) put(s[j]);
  }
  io::atomic_output_file f(path);
  f.stream().write(out.data(), static_cast<std::streamsize>(out.size()));
  f.commit();
}

part_reader::part_reader(const std::string& path, const tile_plan& plan, const std::string& digest) : m_path(path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec) fail(path, "cannot read its size: " + ec.message());
  const auto modalities = modalities_of(plan.request.modalities);
  const std::size_t m = modalities.size();
  // magic, digest, tile, keypoints, modalities, fields, candidates, any, ms
  const std::size_t head = 8 + digest.size() + 8 + 8 + 4 + 4 + 8 * m + 8 + 8;
  std::string b(std::min<std::uint64_t>(size, head), '\0');
  in.read(b.data(), static_cast<std::streamsize>(b.size()));
  if (!in) fail(path, "cannot read it");
  if (b.size() < 8 + digest.size()) fail(path, "truncated tile part (" + std::to_string(size) + " bytes)");
  if (std::memcmp(b.data(), part_magic, 8) != 0) fail(path, "not a ced tile part");
  if (b.compare(8, digest.size(), digest) != 0)
    fail(path,
         "this part belongs to another plan (plan digest " + b.substr(8, digest.size()) + ", expected " + digest + ")");
  if (b.size() < head) fail(path, "truncated tile part (" + std::to_string(size) + " bytes)");
  std::size_t at = 8 + digest.size();
  auto get = [&](auto& v) {
    std::memcpy(&v, b.data() + at, sizeof v);
    at += sizeof v;
  };
  std::uint32_t nm = 0, nf = 0;
  totals.plan = digest;
  get(totals.tile);
  get(m_count);
  get(nm);
  get(nf);
  if (nm != m || nf != plan.fields.size()) fail(path, "its modalities or fields differ from the plan's");
  name_modalities(plan, modalities, totals);
  totals.candidates.resize(m);
  std::memcpy(totals.candidates.data(), b.data() + at, 8 * m);
  at += 8 * m;
  get(totals.any_candidates);
  get(totals.detect_ms);
  totals.keypoints = empty_cloud(plan, 0);
  totals.saliency.assign(m, {});
  m_record = record_size(plan) + 4 * m;
  m_offset = head;
  if (m_count > (size - head) / m_record || size - head != m_count * m_record)
    fail(path, "truncated or oversized tile part: " + std::to_string(m_count) + " keypoints declared");
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
    if (!in) fail(m_path, "cannot read it (was it changed during the merge?)");
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
    std::memcpy(s.data() + j, r, 4);
    r += 4;
  }
}

void resize_part(tile_part& p, const tile_plan& plan, std::size_t n) {
  p.keypoints = empty_cloud(plan, n);
  p.index.resize(n);
  p.file_index.resize(n);
  for (auto& s : p.saliency) s.resize(n);
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
