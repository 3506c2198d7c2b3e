// SPDX-License-Identifier: BSD-3-Clause
// Shared by the benchmarks: the --reps flag, the 120k-point test scan, timing and medians.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "platform/io/kitti_bin.hpp"

namespace commerge::bench {

/// Parses `[--reps N]` (N >= 1) into *reps; prints usage and returns false on anything else.
inline bool ParseReps(int argc, char** argv, int* reps) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      *reps = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--reps N]\n", argv[0]);
      return false;
    }
  }
  if (*reps < 1) {
    std::fprintf(stderr, "--reps must be >= 1\n");
    return false;
  }
  return true;
}

/// ../shared/data, or $COMMERGE_SHARED_DATA.
inline std::string SharedDataDir() {
  const char* env = std::getenv("COMMERGE_SHARED_DATA");
  return env && *env ? env : CM_SHARED_DATA_DIR;
}

/// KITTI 00 frame 0 (124 668 points) when the shared data is present, else a seeded HDL-64E-like ray-cast
/// street scan; `*source` says which.
inline std::vector<PointXYZI> LoadBenchScan(std::string* source) {
  const std::string path = SharedDataDir() + "/kitti/kitti00_frames0-15/velodyne/000000.bin";
  std::vector<PointXYZI> cloud;
  if (auto scan = platform::ReadKittiBin(path); scan.ok()) {
    cloud = std::move(scan->points);
    *source = "KITTI " + path;
  } else {
    CastScan(MakeStreetScene(42), SpinningLidar{}, 0.0f, 0.0f, 1.73f, 0.0f, 42, &cloud);
    *source = "synthetic ray-cast street scan, seed 42 (KITTI scan unavailable: " + scan.status().ToString() + ")";
  }
  return cloud;
}

/// Milliseconds of each of `reps` calls of f().
template <class F>
std::vector<double> TimeMs(int reps, F&& f) {
  std::vector<double> ms(static_cast<std::size_t>(reps));
  for (double& t : ms) {
    const auto start = std::chrono::steady_clock::now();
    f();
    t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return ms;
}

inline double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace commerge::bench
