// SPDX-License-Identifier: BSD-3-Clause
// commerge: a bump allocator over one fixed block. Allocation is O(1), never touches the heap after
// construction, and fails with nullptr (counted) when the block is full: the caller decides the policy.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>

namespace commerge {

class Arena {
 public:
  /// Position to rewind to (see Mark/Rewind).
  struct Marker {
    std::size_t offset = 0;
  };

  /// Owns a block of `capacity_bytes` taken from the heap once, here (start-up); may throw std::bad_alloc.
  explicit Arena(std::size_t capacity_bytes);
  /// Uses caller-provided storage; the caller keeps it alive and aligned as needed.
  Arena(void* block, std::size_t capacity_bytes) noexcept;

  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;

  /// `bytes` aligned to `alignment` (a power of two), or nullptr when the block cannot hold it.
  void* Allocate(std::size_t bytes, std::size_t alignment = alignof(std::max_align_t)) noexcept;

  /// Uninitialised storage for `count` objects of T, or nullptr when full or `count * sizeof(T)` overflows.
  template <class T>
  T* AllocateArray(std::size_t count) noexcept {
    if (count > SIZE_MAX / sizeof(T)) {
      ++failed_allocations_;
      return nullptr;
    }
    return static_cast<T*>(Allocate(count * sizeof(T), alignof(T)));
  }

  Marker Mark() const noexcept { return Marker{used_}; }
  /// Frees everything allocated after `marker` (which must come from this arena and not be newer than used()).
  void Rewind(Marker marker) noexcept {
    if (marker.offset <= used_) used_ = marker.offset;
  }
  /// Frees everything.
  void Reset() noexcept { used_ = 0; }

  std::size_t capacity() const noexcept { return capacity_; }
  std::size_t used() const noexcept { return used_; }
  std::size_t available() const noexcept { return capacity_ - used_; }
  /// Largest used() ever reached (including padding for alignment).
  std::size_t high_water() const noexcept { return high_water_; }
  /// Allocation requests refused because the block was full.
  std::size_t failed_allocations() const noexcept { return failed_allocations_; }

 private:
  std::unique_ptr<std::byte[]> owned_;
  std::byte* block_ = nullptr;
  std::size_t capacity_ = 0;
  std::size_t used_ = 0;
  std::size_t high_water_ = 0;
  std::size_t failed_allocations_ = 0;
};

}  // namespace commerge
