// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/memory/fixed_pool.hpp"
#include "core/memory/fixed_vector.hpp"

using commerge::FixedPool;
using commerge::FixedVector;

namespace {
struct Tracked {
  static int alive;
  int value;
  explicit Tracked(int v) : value(v) { ++alive; }
  ~Tracked() { --alive; }
};
int Tracked::alive = 0;
}  // namespace

TEST_CASE("FixedPool creates up to capacity, then refuses and counts") {
  FixedPool<Tracked> pool(3);
  Tracked* a = pool.Create(1);
  Tracked* b = pool.Create(2);
  Tracked* c = pool.Create(3);
  REQUIRE((a && b && c));
  CHECK(pool.full());
  CHECK(pool.Create(4) == nullptr);
  CHECK(pool.failed_acquires() == 1);
  CHECK(Tracked::alive == 3);
  CHECK(pool.Destroy(b));
  CHECK(Tracked::alive == 2);
  CHECK_FALSE(pool.Destroy(b));  // double free is refused
  Tracked* d = pool.Create(5);
  CHECK(d == b);  // the freed slot is reused
  CHECK(d->value == 5);
  CHECK(pool.high_water() == 3);
  CHECK(pool.reserved_bytes() == 3 * FixedPool<Tracked>::BytesPerSlot());
}

TEST_CASE("FixedPool refuses pointers it does not own") {
  FixedPool<Tracked> pool(2);
  Tracked outside(7);
  CHECK_FALSE(pool.Owns(&outside));
  CHECK_FALSE(pool.Destroy(&outside));
  CHECK_FALSE(pool.Destroy(nullptr));
  Tracked* a = pool.Create(1);
  auto* misaligned = reinterpret_cast<Tracked*>(reinterpret_cast<char*>(a) + 1);
  CHECK_FALSE(pool.Owns(misaligned));
  CHECK(pool.Owns(a));
}

TEST_CASE("FixedPool destroys live objects with the pool") {
  Tracked::alive = 0;
  {
    FixedPool<Tracked> pool(4);
    pool.Create(1);
    pool.Create(2);
    CHECK(Tracked::alive == 2);
  }
  CHECK(Tracked::alive == 0);
}

TEST_CASE("FixedPool matches a set model under random create/destroy") {
  FixedPool<int> pool(50);
  std::set<int*> live;
  std::mt19937 rng(1);
  std::size_t high = 0;
  for (int i = 0; i < 5000; ++i) {
    if (rng() % 3 != 0) {
      int* p = pool.Create(i);
      if (live.size() == 50) {
        CHECK(p == nullptr);
      } else {
        REQUIRE(p != nullptr);
        CHECK(live.insert(p).second);  // never hands out a live slot twice
      }
    } else if (!live.empty()) {
      auto it = live.begin();
      std::advance(it, static_cast<long>(rng() % live.size()));
      CHECK(pool.Destroy(*it));
      live.erase(it);
    }
    high = std::max(high, live.size());
    CHECK(pool.used() == live.size());
  }
  CHECK(pool.high_water() == high);
}

TEST_CASE("FixedVector appends up to capacity and never reallocates") {
  FixedVector<std::string> v(2);
  const std::string* base = v.data();
  CHECK(v.push_back(std::string("a")));
  CHECK(v.push_back(std::string("b")));
  CHECK_FALSE(v.push_back(std::string("c")));
  CHECK(v.rejected() == 1);
  CHECK(v.data() == base);
  CHECK(v.size() == 2);
  CHECK(v[1] == "b");
  v.pop_back();
  CHECK(v.size() == 1);
  CHECK(v.high_water() == 2);
  CHECK(v.available() == 1);
  v.clear();
  CHECK(v.empty());
}
