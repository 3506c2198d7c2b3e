// SPDX-License-Identifier: BSD-3-Clause
#include "platform/memory/memory_limits.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

namespace commerge::platform {

namespace {

// cgroup v1 reports "no limit" as a huge page-aligned number (9223372036854771712 on 4 KiB pages).
constexpr std::int64_t kNoLimitThreshold = std::int64_t{1} << 62;

bool ReadFile(const std::string& path, std::string* out) {
  std::ifstream in(path);
  if (!in) return false;
  std::ostringstream ss;
  ss << in.rdbuf();
  *out = ss.str();
  return true;
}

/// Parses a limit file: a decimal byte count, or "max". Returns -1 for "max", absent, unparsable or "no limit".
std::int64_t ReadLimitFile(const std::string& path, bool* present) {
  std::string text;
  *present = ReadFile(path, &text);
  if (!*present) return -1;
  if (text.compare(0, 3, "max") == 0) return -1;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end == text.c_str() || v <= 0 || v >= kNoLimitThreshold) return -1;
  return static_cast<std::int64_t>(v);
}

std::int64_t ParseMemAvailable(const std::string& meminfo) {
  std::istringstream lines(meminfo);
  std::string line;
  while (std::getline(lines, line)) {
    long long kb = 0;
    if (std::sscanf(line.c_str(), "MemAvailable: %lld kB", &kb) == 1 && kb >= 0) return kb * 1024;
  }
  return -1;
}

std::string ParentOf(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos || slash == 0) return "/";
  return path.substr(0, slash);
}

/// Lowest memory.max from `dir` up to the mount root of a cgroup v2 hierarchy at `mount`.
void ProbeV2(const std::string& mount, std::string cg_path, MemoryLimits* out) {
  for (;;) {
    const std::string dir = cg_path == "/" ? mount : mount + cg_path;
    bool present = false;
    const std::int64_t v = ReadLimitFile(dir + "/memory.max", &present);
    if (v > 0 && (out->cgroup_limit_bytes < 0 || v < out->cgroup_limit_bytes)) {
      out->cgroup_limit_bytes = v;
      out->cgroup_source = dir + "/memory.max";
    }
    if (cg_path == "/") break;
    cg_path = ParentOf(cg_path);
  }
}

/// cgroup v1 memory controller: hierarchical_memory_limit (includes ancestors) or memory.limit_in_bytes.
/// Inside containers the path of /proc/self/cgroup may not exist in the mounted tree: fall back to its root.
void ProbeV1(const std::string& mount, const std::string& cg_path, MemoryLimits* out) {
  for (const std::string& dir : {mount + (cg_path == "/" ? "" : cg_path), mount}) {
    std::string stat;
    if (ReadFile(dir + "/memory.stat", &stat)) {
      std::istringstream lines(stat);
      std::string line;
      while (std::getline(lines, line)) {
        long long v = 0;
        if (std::sscanf(line.c_str(), "hierarchical_memory_limit %lld", &v) == 1) {
          if (v > 0 && v < kNoLimitThreshold) {
            out->cgroup_limit_bytes = v;
            out->cgroup_source = dir + "/memory.stat (hierarchical_memory_limit)";
          } else {
            out->cgroup_source = dir + ": no limit";
          }
          return;
        }
      }
    }
    bool present = false;
    const std::int64_t v = ReadLimitFile(dir + "/memory.limit_in_bytes", &present);
    if (present) {
      if (v > 0) {
        out->cgroup_limit_bytes = v;
        out->cgroup_source = dir + "/memory.limit_in_bytes";
      } else {
        out->cgroup_source = dir + ": no limit";
      }
      return;
    }
  }
}

}  // namespace

MemoryLimits ProbeMemoryLimits(const ProbeRoots& roots) {
  MemoryLimits out;
  std::string text;
  if (ReadFile(roots.proc + "/meminfo", &text)) out.mem_available_bytes = ParseMemAvailable(text);
  if (out.mem_available_bytes < 0) {
    out.meminfo_warning = "warning: no MemAvailable in " + roots.proc + "/meminfo (is /proc mounted?), not checked";
  }

  out.cgroup_source = "no cgroup memory limit";
  if (!ReadFile(roots.proc + "/self/cgroup", &text)) {
    out.cgroup_source = "no " + roots.proc + "/self/cgroup";
    return out;
  }
  // Lines are "hierarchy-id:controllers:path". v1 memory controller: "N:memory:/path" (controllers may be a
  // comma list). v2: "0::/path".
  std::string v1_path, v2_path;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t a = line.find(':');
    const std::size_t b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string controllers = "," + line.substr(a + 1, b - a - 1) + ",";
    const std::string path = line.substr(b + 1);
    if (line.compare(0, a, "0") == 0 && b == a + 1) {
      v2_path = path;
    } else if (controllers.find(",memory,") != std::string::npos) {
      v1_path = path;
    }
  }
  if (!v1_path.empty()) {
    ProbeV1(roots.cgroup_fs + "/memory", v1_path, &out);
  } else if (!v2_path.empty()) {
    // Pure v2 mounts at cgroup_fs; hybrid systems mount it at cgroup_fs/unified (without the memory controller).
    ProbeV2(roots.cgroup_fs, v2_path, &out);
  }
  return out;
}

}  // namespace commerge::platform
