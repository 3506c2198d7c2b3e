// SPDX-License-Identifier: BSD-3-Clause
// tests/fuzz/fuzz_support.hpp: Fail() and the allocation watch (a second malloc hook beside libFuzzer's; the
// sanitizer allocator runs up to five).
#include "tests/fuzz/fuzz_support.hpp"

#include <sanitizer/allocator_interface.h>

#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>

namespace commerge::fuzz {

namespace {

std::atomic<bool> g_watching{false};
std::atomic<std::size_t> g_largest{0};
std::atomic<std::size_t> g_count{0};

void OnMalloc(const volatile void*, std::size_t size) {
  if (!g_watching.load(std::memory_order_relaxed)) return;
  g_count.fetch_add(1, std::memory_order_relaxed);
  std::size_t seen = g_largest.load(std::memory_order_relaxed);
  while (size > seen && !g_largest.compare_exchange_weak(seen, size, std::memory_order_relaxed)) {
  }
}

void OnFree(const volatile void*) {}

bool InstallHook() { return __sanitizer_install_malloc_and_free_hooks(OnMalloc, OnFree) != 0; }

}  // namespace

void Fail(const char* format, ...) {
  std::fputs("cm-fuzz: ", stderr);
  va_list args;
  va_start(args, format);
  std::vfprintf(stderr, format, args);
  va_end(args);
  std::fputc('\n', stderr);
  std::fflush(stderr);
  std::abort();
}

bool AllocationWatch::Available() noexcept {
  static const bool installed = InstallHook();
  return installed;
}

AllocationWatch::AllocationWatch() noexcept {
  (void)Available();
  g_largest.store(0, std::memory_order_relaxed);
  g_count.store(0, std::memory_order_relaxed);
  g_watching.store(true, std::memory_order_relaxed);
}

AllocationWatch::~AllocationWatch() { g_watching.store(false, std::memory_order_relaxed); }

std::size_t AllocationWatch::largest_bytes() const noexcept { return g_largest.load(std::memory_order_relaxed); }
std::size_t AllocationWatch::allocations() const noexcept { return g_count.load(std::memory_order_relaxed); }

}  // namespace commerge::fuzz
