// SPDX-License-Identifier: BSD-3-Clause
// Test helper: `cm_alloc_probe --touch-mb N` allocates and touches N MiB, then reports VmHWM;
// `cm_alloc_probe --until-oom` allocates 1 MiB blocks until std::bad_alloc and reports how far it got.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <vector>

#include "core/common/bytes.hpp"
#include "platform/memory/peak_rss.hpp"

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--touch-mb") == 0) {
    const long mb = std::strtol(argv[2], nullptr, 10);
    if (mb <= 0 || mb > 65536) {
      std::fprintf(stderr, "cm_alloc_probe: --touch-mb takes 1..65536, got '%s'\n", argv[2]);
      return 2;
    }
    const std::size_t n = static_cast<std::size_t>(mb) << 20;
    std::unique_ptr<unsigned char[]> block(new unsigned char[n]);
    for (std::size_t i = 0; i < n; i += 4096) block[i] = static_cast<unsigned char>(i >> 12);
    asm volatile("" : : "r"(block.get()) : "memory");
    std::printf("touched %ld MiB, VmHWM %s\n", mb, commerge::FormatBytes(commerge::platform::ReadRss().peak_bytes).c_str());
    return 0;
  }
  if (argc == 2 && std::strcmp(argv[1], "--until-oom") == 0) {
    std::vector<std::unique_ptr<unsigned char[]>> blocks;
    blocks.reserve(1 << 16);
    try {
      for (int i = 0; i < (1 << 16); ++i) {  // stops at 64 GiB at the latest
        blocks.emplace_back(new unsigned char[1 << 20]);
        blocks.back()[0] = 1;
      }
    } catch (const std::bad_alloc&) {
      std::printf("bad_alloc after %zu MiB\n", blocks.size());
      return 0;
    }
    std::printf("no bad_alloc after %zu MiB\n", blocks.size());
    return 1;
  }
  std::fprintf(stderr, "usage: cm_alloc_probe --touch-mb N | --until-oom\n");
  return 2;
}
