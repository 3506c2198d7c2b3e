// SPDX-License-Identifier: BSD-3-Clause
// commerge: a pool of `capacity` slots for objects of type T, allocated once at construction.
// Create() returns nullptr when the pool is full (counted); Destroy() returns the slot. No heap use after
// construction, O(1) both ways, slots keep their address for their lifetime.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>

namespace commerge {

template <class T>
class FixedPool {
 public:
  /// Reserves `capacity` slots (start-up allocation; may throw std::bad_alloc).
  explicit FixedPool(std::size_t capacity)
      : slots_(capacity ? new Slot[capacity] : nullptr), next_free_(capacity ? new std::size_t[capacity] : nullptr),
        live_(capacity ? new bool[capacity]() : nullptr), capacity_(capacity) {
    for (std::size_t i = 0; i < capacity_; ++i) next_free_[i] = i + 1;  // i + 1 == capacity_ ends the list
    free_head_ = 0;
  }
  ~FixedPool() {
    for (std::size_t i = 0; i < capacity_; ++i) {
      if (live_[i]) Get(i)->~T();
    }
  }
  FixedPool(const FixedPool&) = delete;
  FixedPool& operator=(const FixedPool&) = delete;

  /// Constructs a T in a free slot; nullptr when the pool is full.
  template <class... Args>
  T* Create(Args&&... args) {
    if (free_head_ >= capacity_) {
      ++failed_acquires_;
      return nullptr;
    }
    const std::size_t i = free_head_;
    T* object = new (&slots_[i]) T(std::forward<Args>(args)...);
    free_head_ = next_free_[i];
    live_[i] = true;
    ++used_;
    if (used_ > high_water_) high_water_ = used_;
    return object;
  }

  /// Destroys an object obtained from Create() of this pool. Returns false (and does nothing) for a pointer
  /// that is not a live object of this pool.
  bool Destroy(T* object) noexcept {
    const std::size_t i = IndexOf(object);
    if (i >= capacity_ || !live_[i]) return false;
    object->~T();
    live_[i] = false;
    next_free_[i] = free_head_;
    free_head_ = i;
    --used_;
    return true;
  }

  /// True when `object` is a live object of this pool.
  bool Owns(const T* object) const noexcept {
    const std::size_t i = IndexOf(object);
    return i < capacity_ && live_[i];
  }

  std::size_t capacity() const noexcept { return capacity_; }
  std::size_t used() const noexcept { return used_; }
  std::size_t available() const noexcept { return capacity_ - used_; }
  bool full() const noexcept { return used_ == capacity_; }
  std::size_t high_water() const noexcept { return high_water_; }
  std::size_t failed_acquires() const noexcept { return failed_acquires_; }
  /// Bytes reserved by the pool (slots + bookkeeping), for budget reports.
  std::size_t reserved_bytes() const noexcept { return capacity_ * BytesPerSlot(); }
  static constexpr std::size_t BytesPerSlot() noexcept { return sizeof(Slot) + sizeof(std::size_t) + sizeof(bool); }

 private:
  struct alignas(T) Slot {
    unsigned char bytes[sizeof(T)];
  };

  T* Get(std::size_t i) noexcept { return std::launder(reinterpret_cast<T*>(&slots_[i])); }
  std::size_t IndexOf(const T* object) const noexcept {
    const auto p = reinterpret_cast<std::uintptr_t>(object);
    const auto base = reinterpret_cast<std::uintptr_t>(slots_.get());
    if (capacity_ == 0 || p < base || p >= base + capacity_ * sizeof(Slot) || (p - base) % sizeof(Slot) != 0) {
      return capacity_;
    }
    return static_cast<std::size_t>((p - base) / sizeof(Slot));
  }

  std::unique_ptr<Slot[]> slots_;
  std::unique_ptr<std::size_t[]> next_free_;
  std::unique_ptr<bool[]> live_;
  std::size_t capacity_ = 0;
  std::size_t free_head_ = 0;
  std::size_t used_ = 0;
  std::size_t high_water_ = 0;
  std::size_t failed_acquires_ = 0;
};

}  // namespace commerge
