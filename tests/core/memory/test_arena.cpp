// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "core/memory/arena.hpp"

using commerge::Arena;

TEST_CASE("Arena hands out aligned, disjoint blocks and tracks used, available and high water") {
  Arena arena(1024);
  CHECK(arena.capacity() == 1024);
  CHECK(arena.used() == 0);
  auto* a = static_cast<unsigned char*>(arena.Allocate(10, 1));
  auto* b = static_cast<unsigned char*>(arena.Allocate(8, 8));
  REQUIRE(a != nullptr);
  REQUIRE(b != nullptr);
  CHECK(reinterpret_cast<std::uintptr_t>(b) % 8 == 0);
  CHECK(b >= a + 10);  // no overlap
  CHECK(arena.used() >= 18);
  CHECK(arena.available() == arena.capacity() - arena.used());
  CHECK(arena.high_water() == arena.used());
}

TEST_CASE("Arena refuses what does not fit, counts it, and keeps working") {
  Arena arena(64);
  REQUIRE(arena.Allocate(60, 1) != nullptr);
  CHECK(arena.Allocate(8, 1) == nullptr);
  CHECK(arena.failed_allocations() == 1);
  CHECK(arena.used() == 60);
  CHECK(arena.Allocate(4, 1) != nullptr);  // exactly fills it
  CHECK(arena.available() == 0);
  CHECK(arena.Allocate(1, 1) == nullptr);
  CHECK(arena.failed_allocations() == 2);
}

TEST_CASE("Arena rejects overflowing array sizes and bad alignments") {
  Arena arena(256);
  CHECK(arena.AllocateArray<std::uint64_t>(SIZE_MAX / 4) == nullptr);
  CHECK(arena.Allocate(8, 3) == nullptr);  // not a power of two
  CHECK(arena.Allocate(8, 0) == nullptr);
  CHECK(arena.failed_allocations() == 3);
  CHECK(arena.used() == 0);
}

TEST_CASE("Arena Mark/Rewind/Reset free memory but keep the high-water mark") {
  Arena arena(4096);
  REQUIRE(arena.Allocate(100) != nullptr);
  const Arena::Marker m = arena.Mark();
  REQUIRE(arena.AllocateArray<double>(200) != nullptr);
  const std::size_t peak = arena.used();
  arena.Rewind(m);
  CHECK(arena.used() == 100);
  CHECK(arena.high_water() == peak);
  arena.Reset();
  CHECK(arena.used() == 0);
  CHECK(arena.high_water() == peak);
}

TEST_CASE("Arena over caller storage never exceeds it (random allocation sequence vs a byte-count model)") {
  alignas(16) static unsigned char storage[2000];
  Arena arena(storage, sizeof storage);
  std::mt19937 rng(42);
  std::vector<std::pair<unsigned char*, std::size_t>> blocks;
  for (int i = 0; i < 500; ++i) {
    const std::size_t n = 1 + rng() % 64;
    const std::size_t align = std::size_t{1} << (rng() % 5);
    const std::size_t before = arena.used();
    auto* p = static_cast<unsigned char*>(arena.Allocate(n, align));
    if (p == nullptr) {
      CHECK(arena.used() == before);
      continue;
    }
    CHECK(p >= storage);
    CHECK(p + n <= storage + sizeof storage);
    CHECK(reinterpret_cast<std::uintptr_t>(p) % align == 0);
    for (const auto& [q, m] : blocks) CHECK((p + n <= q || q + m <= p));
    blocks.emplace_back(p, n);
  }
  CHECK(arena.failed_allocations() > 0);  // 500 x ~32 B cannot fit in 2000 B
}

TEST_CASE("Arena of capacity zero or null storage refuses everything") {
  Arena empty(std::size_t{0});
  CHECK(empty.Allocate(1) == nullptr);
  Arena null_storage(nullptr, 100);
  CHECK(null_storage.capacity() == 0);
  CHECK(null_storage.Allocate(1) == nullptr);
}
