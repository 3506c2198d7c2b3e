// SPDX-License-Identifier: BSD-3-Clause
#include "platform/memory/allocator.hpp"

#include <cstdlib>

#if defined(CM_WITH_MIMALLOC)
#include <mimalloc.h>
#endif

namespace commerge::platform {

bool MallocIsMimalloc() {
#if defined(CM_WITH_MIMALLOC)
  void* volatile p = std::malloc(64);
  const bool ours = p != nullptr && mi_is_in_heap_region(p);
  std::free(p);
  return ours;
#else
  return false;
#endif
}

std::string AllocatorDescription() {
#if defined(CM_WITH_MIMALLOC)
  const int v = mi_version();
  std::string d = "mimalloc " + std::to_string(v / 100) + "." + std::to_string((v / 10) % 10) + "." +
                  std::to_string(v % 10);
  if (!MallocIsMimalloc()) d += " (linked, but malloc is NOT served by it)";
  return d;
#else
  return "system malloc (sanitizer build)";
#endif
}

Status CapHeap(std::int64_t bytes) {
  if (bytes <= 0) return InvalidArgument("heap cap must be positive, got " + std::to_string(bytes) + " bytes");
#if defined(CM_WITH_MIMALLOC)
  if (mi_reserve_os_memory(static_cast<std::size_t>(bytes), /*commit=*/false, /*allow_large=*/false) != 0) {
    return ResourceExhausted("cannot reserve a heap of " + std::to_string(bytes) + " bytes from the OS");
  }
  mi_option_enable(mi_option_limit_os_alloc);
  return Status::Ok();
#else
  return Unimplemented("a heap cap needs mimalloc; this is a sanitizer build");
#endif
}

}  // namespace commerge::platform
