// SPDX-License-Identifier: BSD-3-Clause
// commerge: a minimal non-owning view over contiguous memory (C++17 has no std::span).
#pragma once

#include <array>
#include <cstddef>
#include <type_traits>
#include <vector>

namespace commerge {

/// Non-owning view of `size()` contiguous elements of type T. Cheap to copy; never allocates.
template <class T>
class Span {
 public:
  using element_type = T;
  using value_type = std::remove_cv_t<T>;

  constexpr Span() noexcept = default;
  constexpr Span(T* data, std::size_t size) noexcept : data_(data), size_(size) {}
  template <std::size_t N>
  constexpr Span(T (&array)[N]) noexcept : data_(array), size_(N) {}
  /// From a std::array (const or mutable, matching T's constness).
  template <class U, std::size_t N, class = std::enable_if_t<std::is_convertible<U (*)[], T (*)[]>::value>>
  constexpr Span(std::array<U, N>& a) noexcept : data_(a.data()), size_(N) {}
  template <class U, std::size_t N, class = std::enable_if_t<std::is_convertible<const U (*)[], T (*)[]>::value>>
  constexpr Span(const std::array<U, N>& a) noexcept : data_(a.data()), size_(N) {}
  /// From a vector (const or mutable, matching T's constness).
  template <class U, class A,
            class = std::enable_if_t<std::is_convertible<U (*)[], T (*)[]>::value>>
  Span(std::vector<U, A>& v) noexcept : data_(v.data()), size_(v.size()) {}
  template <class U, class A,
            class = std::enable_if_t<std::is_convertible<const U (*)[], T (*)[]>::value>>
  Span(const std::vector<U, A>& v) noexcept : data_(v.data()), size_(v.size()) {}
  /// Span<T> converts to Span<const T>.
  template <class U, class = std::enable_if_t<std::is_convertible<U (*)[], T (*)[]>::value>>
  constexpr Span(const Span<U>& other) noexcept : data_(other.data()), size_(other.size()) {}

  constexpr T* data() const noexcept { return data_; }
  constexpr std::size_t size() const noexcept { return size_; }
  constexpr bool empty() const noexcept { return size_ == 0; }
  constexpr T& operator[](std::size_t i) const noexcept { return data_[i]; }
  constexpr T* begin() const noexcept { return data_; }
  constexpr T* end() const noexcept { return data_ + size_; }
  /// Elements [offset, offset + count); the caller guarantees the range is inside the view.
  constexpr Span subspan(std::size_t offset, std::size_t count) const noexcept {
    return Span(data_ + offset, count);
  }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace commerge
