// SPDX-License-Identifier: BSD-3-Clause
// Voxel-grid downsampling throughput on one ~120k-point scan at 1.0 m.
// Usage: bench_voxel_grid [--reps N]   (default 50 timed calls after one warm-up call)
// Uses KITTI 00 frame 0 from the shared data when present, else a seeded synthetic LiDAR-like scan.
#include <cstdio>
#include <string>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "profiling/bench_common.hpp"
#include "platform/memory/peak_rss.hpp"

using commerge::PointXYZI;

int main(int argc, char** argv) {
  int reps = 50;
  if (!commerge::bench::ParseReps(argc, argv, &reps)) return 2;
  std::string source;
  const std::vector<PointXYZI> cloud = commerge::bench::LoadBenchScan(&source);

  const commerge::VoxelGridParams params{1.0};
  commerge::VoxelGrid grid(cloud.size());
  std::vector<PointXYZI> out;
  const auto warmup = grid.Downsample(cloud, params, &out);
  if (!warmup.ok()) {
    std::fprintf(stderr, "voxel grid failed: %s\n", warmup.status().ToString().c_str());
    return 1;
  }

  bool all_ok = true;
  const std::vector<double> ms = commerge::bench::TimeMs(reps, [&] { all_ok &= grid.Downsample(cloud, params, &out).ok(); });
  if (!all_ok) return 1;
  double mean_ms = 0.0;
  for (const double t : ms) mean_ms += t;
  mean_ms /= reps;
  const double median_ms = commerge::bench::Median(ms);

  std::printf("source:          %s\n", source.c_str());
  std::printf("voxel size:      %.2f m, %d reps after 1 warm-up\n", params.voxel_size_m, reps);
  std::printf("points in/out:   %zu -> %zu (dropped non-finite: %zu)\n", cloud.size(), out.size(),
              warmup->dropped_nonfinite);
  std::printf("time per call:   median %.3f ms, mean %.3f ms\n", median_ms, mean_ms);
  std::printf("throughput:      %.1f M points/s (median)\n", static_cast<double>(cloud.size()) / median_ms / 1e3);
  std::printf("workspace:       %s\n",
              commerge::FormatBytes(static_cast<std::int64_t>(grid.workspace_capacity_bytes())).c_str());
  const std::int64_t peak_rss_bytes = commerge::platform::ReadRss().peak_bytes;
  std::printf("peak RSS:        %s\n", commerge::FormatBytes(peak_rss_bytes).c_str());
  return 0;
}
