// SPDX-License-Identifier: BSD-3-Clause
// commerge: a vector whose capacity is fixed at construction. push_back() on a full vector returns false
// (counted) instead of reallocating, so steady-state code never touches the heap.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <utility>

#include "core/common/span.hpp"

namespace commerge {

template <class T>
class FixedVector {
 public:
  /// Reserves `capacity` elements (start-up allocation; may throw std::bad_alloc).
  explicit FixedVector(std::size_t capacity) : storage_(capacity ? new Slot[capacity] : nullptr), capacity_(capacity) {}
  ~FixedVector() { clear(); }
  FixedVector(const FixedVector&) = delete;
  FixedVector& operator=(const FixedVector&) = delete;

  /// Appends a copy/move of `value`; false when full.
  template <class U>
  bool push_back(U&& value) {
    return emplace_back(std::forward<U>(value)) != nullptr;
  }
  /// Constructs an element at the end; nullptr when full.
  template <class... Args>
  T* emplace_back(Args&&... args) {
    if (size_ == capacity_) {
      ++rejected_;
      return nullptr;
    }
    T* p = new (&storage_[size_]) T(std::forward<Args>(args)...);
    ++size_;
    if (size_ > high_water_) high_water_ = size_;
    return p;
  }
  void pop_back() noexcept {
    if (size_ > 0) data()[--size_].~T();
  }
  void clear() noexcept {
    while (size_ > 0) pop_back();
  }

  T* data() noexcept { return std::launder(reinterpret_cast<T*>(storage_.get())); }
  const T* data() const noexcept { return std::launder(reinterpret_cast<const T*>(storage_.get())); }
  T& operator[](std::size_t i) noexcept { return data()[i]; }
  const T& operator[](std::size_t i) const noexcept { return data()[i]; }
  T* begin() noexcept { return data(); }
  T* end() noexcept { return data() + size_; }
  const T* begin() const noexcept { return data(); }
  const T* end() const noexcept { return data() + size_; }
  Span<T> span() noexcept { return Span<T>(data(), size_); }
  Span<const T> span() const noexcept { return Span<const T>(data(), size_); }

  std::size_t size() const noexcept { return size_; }
  bool empty() const noexcept { return size_ == 0; }
  std::size_t capacity() const noexcept { return capacity_; }
  std::size_t available() const noexcept { return capacity_ - size_; }
  bool full() const noexcept { return size_ == capacity_; }
  std::size_t high_water() const noexcept { return high_water_; }
  /// Appends refused because the vector was full.
  std::size_t rejected() const noexcept { return rejected_; }

 private:
  struct alignas(T) Slot {
    unsigned char bytes[sizeof(T)];
  };
  std::unique_ptr<Slot[]> storage_;
  std::size_t capacity_ = 0;
  std::size_t size_ = 0;
  std::size_t high_water_ = 0;
  std::size_t rejected_ = 0;
};

}  // namespace commerge
