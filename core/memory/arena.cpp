// SPDX-License-Identifier: BSD-3-Clause
#include "core/memory/arena.hpp"

#include <algorithm>

namespace commerge {

Arena::Arena(std::size_t capacity_bytes)
    : owned_(capacity_bytes ? new std::byte[capacity_bytes] : nullptr), block_(owned_.get()),
      capacity_(capacity_bytes) {}

Arena::Arena(void* block, std::size_t capacity_bytes) noexcept
    : block_(static_cast<std::byte*>(block)), capacity_(block ? capacity_bytes : 0) {}

void* Arena::Allocate(std::size_t bytes, std::size_t alignment) noexcept {
  if (alignment == 0 || (alignment & (alignment - 1)) != 0) {
    ++failed_allocations_;
    return nullptr;
  }
  const std::uintptr_t base = reinterpret_cast<std::uintptr_t>(block_);
  const std::uintptr_t current = base + used_;
  const std::uintptr_t aligned = (current + (alignment - 1)) & ~static_cast<std::uintptr_t>(alignment - 1);
  const std::size_t padding = static_cast<std::size_t>(aligned - current);
  if (block_ == nullptr || padding > capacity_ - used_ || bytes > capacity_ - used_ - padding) {
    ++failed_allocations_;
    return nullptr;
  }
  used_ += padding + bytes;
  high_water_ = std::max(high_water_, used_);
  return block_ + (aligned - base);
}

}  // namespace commerge
