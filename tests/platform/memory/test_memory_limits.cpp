// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "platform/memory/memory_limits.hpp"
#include "platform/memory/peak_rss.hpp"
#include "tests/support/test_data.hpp"

namespace fs = std::filesystem;
using commerge::platform::MemoryLimits;
using commerge::platform::ProbeMemoryLimits;
using commerge::platform::ProbeRoots;

namespace {

int g_tree = 0;

/// A fake /proc + /sys/fs/cgroup tree in the scratch directory.
struct FakeTree {
  fs::path root;
  FakeTree() : root(fs::path(commerge::test::ScratchDir()) / ("tree" + std::to_string(g_tree++))) {
    fs::create_directories(root / "proc/self");
    fs::create_directories(root / "cgroup");
  }
  void Write(const std::string& rel, const std::string& text) const {
    const fs::path p = root / rel;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
  }
  ProbeRoots Roots() const { return ProbeRoots{(root / "proc").string(), (root / "cgroup").string()}; }
};

const char* kMeminfo =
    "MemTotal:       24000000 kB\nMemFree:         1000000 kB\nMemAvailable:   20000000 kB\nBuffers: 0 kB\n";

}  // namespace

TEST_CASE("MemAvailable is read from meminfo in bytes") {
  FakeTree t;
  t.Write("proc/meminfo", kMeminfo);
  t.Write("proc/self/cgroup", "0::/\n");
  const MemoryLimits m = ProbeMemoryLimits(t.Roots());
  CHECK(m.mem_available_bytes == 20000000LL * 1024);
  CHECK(m.cgroup_limit_bytes == -1);
}

TEST_CASE("cgroup v2: the lowest memory.max from the process's group up to the root wins, and 'max' means none") {
  FakeTree t;
  t.Write("proc/meminfo", kMeminfo);
  t.Write("proc/self/cgroup", "0::/user.slice/robot.service\n");
  t.Write("cgroup/user.slice/robot.service/memory.max", "max\n");
  t.Write("cgroup/user.slice/memory.max", "1073741824\n");
  t.Write("cgroup/memory.max", "2147483648\n");
  MemoryLimits m = ProbeMemoryLimits(t.Roots());
  CHECK(m.cgroup_limit_bytes == 1073741824);
  CHECK(m.cgroup_source.find("user.slice/memory.max") != std::string::npos);

  t.Write("cgroup/user.slice/robot.service/memory.max", "268435456\n");
  m = ProbeMemoryLimits(t.Roots());
  CHECK(m.cgroup_limit_bytes == 268435456);

  FakeTree unlimited;
  unlimited.Write("proc/self/cgroup", "0::/a\n");
  unlimited.Write("cgroup/a/memory.max", "max\n");
  CHECK(ProbeMemoryLimits(unlimited.Roots()).cgroup_limit_bytes == -1);
}

TEST_CASE("cgroup v1: hierarchical_memory_limit is preferred, and the huge 'no limit' value means none") {
  FakeTree t;
  t.Write("proc/meminfo", kMeminfo);
  t.Write("proc/self/cgroup", "5:cpu,cpuacct:/x\n4:memory:/docker/abc\n0::/\n");
  t.Write("cgroup/memory/docker/abc/memory.limit_in_bytes", "9223372036854771712\n");
  t.Write("cgroup/memory/docker/abc/memory.stat", "cache 0\nhierarchical_memory_limit 536870912\nrss 0\n");
  MemoryLimits m = ProbeMemoryLimits(t.Roots());
  CHECK(m.cgroup_limit_bytes == 536870912);
  CHECK(m.cgroup_source.find("hierarchical_memory_limit") != std::string::npos);

  FakeTree none;
  none.Write("proc/self/cgroup", "4:memory:/\n");
  none.Write("cgroup/memory/memory.limit_in_bytes", "9223372036854771712\n");
  CHECK(ProbeMemoryLimits(none.Roots()).cgroup_limit_bytes == -1);
}

TEST_CASE("cgroup v1 inside a container: a path missing from the mounted tree falls back to its root") {
  FakeTree t;
  t.Write("proc/self/cgroup", "4:memory:/kubepods/pod1/ctr\n");
  t.Write("cgroup/memory/memory.limit_in_bytes", "805306368\n");
  CHECK(ProbeMemoryLimits(t.Roots()).cgroup_limit_bytes == 805306368);
}

TEST_CASE("Missing /proc files give unknown figures, not errors") {
  FakeTree t;
  const MemoryLimits m = ProbeMemoryLimits(t.Roots());
  CHECK(m.mem_available_bytes == -1);
  CHECK(m.cgroup_limit_bytes == -1);
  CHECK_FALSE(m.cgroup_source.empty());
}

TEST_CASE("This machine: MemAvailable is known and positive") {
  const MemoryLimits m = ProbeMemoryLimits();
  CHECK(m.mem_available_bytes > 0);
}

TEST_CASE("ParseProcStatus reads VmRSS and VmHWM, and ReadRss sees a touched allocation") {
  const auto r = commerge::platform::ParseProcStatus("Name:\tx\nVmHWM:\t  2048 kB\nVmRSS:\t  1024 kB\n");
  CHECK(r.peak_bytes == 2048 * 1024);
  CHECK(r.current_bytes == 1024 * 1024);
  CHECK(commerge::platform::ParseProcStatus("Name: x\n").peak_bytes == -1);

  const auto before = commerge::platform::ReadRss();
  REQUIRE(before.peak_bytes > 0);
  const std::size_t n = 48u << 20;
  auto* block = new unsigned char[n];
  for (std::size_t i = 0; i < n; i += 4096) block[i] = static_cast<unsigned char>(i);
  asm volatile("" : : "r"(block) : "memory");
  const auto after = commerge::platform::ReadRss();
  delete[] block;
  CHECK(after.peak_bytes >= before.current_bytes + static_cast<std::int64_t>(n) - (8 << 20));
}
