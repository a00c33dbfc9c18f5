// SPDX-License-Identifier: MIT
#include "core/arena.hpp"

#include <cstdint>
#include <utility>

namespace ced::detail {

namespace {
struct chunk_cache {
  std::mutex mutex;
  std::vector<std::unique_ptr<std::byte[]>> chunks;  // each chunk_arena::chunk_size bytes
};
chunk_cache& cache() {
  static chunk_cache c;
  return c;
}
constexpr std::size_t alignment = 64;
}  // namespace

chunk_arena::~chunk_arena() {
  chunk_cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  for (chunk& k : m_chunks)
    if (k.size == chunk_size && (c.chunks.size() + 1) * chunk_size <= cache_limit)
      c.chunks.push_back(std::move(k.data));
}

std::size_t chunk_arena::cached_bytes() {
  chunk_cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.chunks.size() * chunk_size;
}

void chunk_arena::release_cache() noexcept {
  std::vector<std::unique_ptr<std::byte[]>> chunks;
  {
    chunk_cache& c = cache();
    std::lock_guard<std::mutex> lock(c.mutex);
    chunks.swap(c.chunks);
  }  // freed outside the lock
}

void* chunk_arena::allocate(std::size_t bytes) {
  // Room for aligning the start within a chunk.
  const std::size_t need = bytes + alignment;
  std::lock_guard<std::mutex> lock(m_mutex);
  if (need > chunk_size) {  // a chunk of its own (not cached)
    m_chunks.push_back({std::unique_ptr<std::byte[]>(new std::byte[need]), need});
    const auto at = reinterpret_cast<std::uintptr_t>(m_chunks.back().data.get());
    return m_chunks.back().data.get() + ((alignment - at % alignment) % alignment);
  }
  auto aligned_offset = [&] {
    const auto at = reinterpret_cast<std::uintptr_t>(m_current + m_used);
    return m_used + (alignment - at % alignment) % alignment;
  };
  if (!m_current || aligned_offset() + bytes > chunk_size) {
    std::unique_ptr<std::byte[]> data;
    {
      chunk_cache& c = cache();
      std::lock_guard<std::mutex> cache_lock(c.mutex);
      if (!c.chunks.empty()) {
        data = std::move(c.chunks.back());
        c.chunks.pop_back();
      }
    }
    if (!data) data.reset(new std::byte[chunk_size]);
    m_current = data.get();
    m_used = 0;
    m_chunks.push_back({std::move(data), chunk_size});
  }
  const std::size_t offset = aligned_offset();
  m_used = offset + bytes;
  return m_current + offset;
}

}  // namespace ced::detail
