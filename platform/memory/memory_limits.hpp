// SPDX-License-Identifier: BSD-3-Clause
// What the operating system lets this process use: MemAvailable and the effective cgroup memory limit
// (cgroup v2 memory.max up the hierarchy, or cgroup v1 memory.limit_in_bytes / hierarchical_memory_limit).
#pragma once

#include <cstdint>
#include <string>

namespace commerge::platform {

struct MemoryLimits {
  std::int64_t mem_available_bytes = -1;  ///< /proc/meminfo MemAvailable; -1 when unreadable
  std::int64_t cgroup_limit_bytes = -1;   ///< lowest limit found; -1 when there is none
  std::string cgroup_source;              ///< the file the limit came from, or why there is none
  std::string meminfo_warning;            ///< why MemAvailable is unknown (e.g. no /proc mounted); empty when read
};

/// Where to look; tests point these at fake trees.
struct ProbeRoots {
  std::string proc = "/proc";
  std::string cgroup_fs = "/sys/fs/cgroup";
};

/// Reads MemAvailable and the cgroup limit (v2 first, then v1). Never fails: unknown figures are -1.
MemoryLimits ProbeMemoryLimits(const ProbeRoots& roots = ProbeRoots{});

}  // namespace commerge::platform
