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
