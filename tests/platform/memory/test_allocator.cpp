// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#include "platform/memory/allocator.hpp"

TEST_CASE("With mimalloc linked, malloc is served by mimalloc") {
#if defined(CM_WITH_MIMALLOC)
  CHECK(commerge::platform::MallocIsMimalloc());
  CHECK(commerge::platform::AllocatorDescription().rfind("mimalloc 2.", 0) == 0);
#else
  CHECK_FALSE(commerge::platform::MallocIsMimalloc());
#endif
}

TEST_CASE("An impossible allocation throws std::bad_alloc instead of aborting the process") {
  // mimalloc's own operator new would abort() here; ours (platform/memory/new_delete.cpp) throws.
  volatile std::size_t huge = std::size_t{1} << 60;
  CHECK_THROWS_AS(static_cast<void>(std::vector<char>(huge)), std::bad_alloc);
  char* p = nullptr;
  CHECK_THROWS_AS(p = new char[huge], std::bad_alloc);
  delete[] p;
  CHECK(new (std::nothrow) char[huge] == nullptr);
}

TEST_CASE("CapHeap rejects a non-positive cap") {
  CHECK(commerge::platform::CapHeap(0).code() == commerge::StatusCode::kInvalidArgument);
}

TEST_CASE("OperatorNewCalls counts every operator new") {
  const std::uint64_t before = commerge::platform::OperatorNewCalls();
  auto* a = new int(1);
  auto* b = new double[4];
  auto* c = new (std::nothrow) char;
  asm volatile("" : : "r"(a), "r"(b), "r"(c) : "memory");  // keep GCC from eliding the new/delete pairs
  const std::uint64_t after = commerge::platform::OperatorNewCalls();
  delete a;
  delete[] b;
  delete c;
  CHECK(after - before == 3);
}
