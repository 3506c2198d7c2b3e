// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the fuzz targets and the seed writer: failing loudly (libFuzzer turns the abort into a
// crash report and saves the input), and measuring the largest single heap allocation of a piece of code through
// the sanitizer allocator's malloc hook.
#pragma once

#include <cstddef>
#include <cstdint>

namespace commerge::fuzz {

/// Prints "cm-fuzz: <printf message>" to stderr and aborts.
[[noreturn]] void Fail(const char* format, ...) __attribute__((format(printf, 1, 2)));

/// While an AllocationWatch lives, every heap allocation of the process (malloc, operator new; all sizes) is
/// recorded: how many, and the largest. Not nestable; the fuzz targets are single-threaded.
class AllocationWatch {
 public:
  AllocationWatch() noexcept;
  ~AllocationWatch();
  AllocationWatch(const AllocationWatch&) = delete;
  AllocationWatch& operator=(const AllocationWatch&) = delete;

  std::size_t largest_bytes() const noexcept;
  std::size_t allocations() const noexcept;
  /// False when the hook could not be installed (no sanitizer runtime): the figures then stay 0.
  static bool Available() noexcept;
};

}  // namespace commerge::fuzz
