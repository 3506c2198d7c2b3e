// SPDX-License-Identifier: BSD-3-Clause
// The process allocator: mimalloc (linked into every commerge executable except sanitizer builds).
#pragma once

#include <cstdint>
#include <string>

#include "core/common/status.hpp"

namespace commerge::platform {

/// True when malloc() is served by mimalloc (checked on a live allocation, not assumed from the build).
bool MallocIsMimalloc();

/// Calls of the global operator new (all forms) since the process started. Defined with the operators in
/// new_delete.cpp, which every commerge executable links: tests use it to assert that a steady-state call
/// does not allocate.
std::uint64_t OperatorNewCalls() noexcept;

/// "mimalloc 2.0.9" or "system malloc (sanitizer build)".
std::string AllocatorDescription();

/// Hard heap cap for the rest of the process: reserves `bytes` from the OS and forbids mimalloc to take
/// more, so a runaway module gets std::bad_alloc instead of the OOM killer. Call once, early in main.
/// Usable heap = bytes + the segment mimalloc took before main (up to 32 MiB). Not available without mimalloc.
Status CapHeap(std::int64_t bytes);

}  // namespace commerge::platform
