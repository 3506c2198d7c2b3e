// SPDX-License-Identifier: BSD-3-Clause
// Voxel-grid downsampling throughput on one ~120k-point scan at 1.0 m.
// Usage: bench_voxel_grid [--reps N]   (default 50 timed calls after one warm-up call)
// Uses KITTI 00 frame 0 from the shared data when present, else a seeded synthetic LiDAR-like scan.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/memory/peak_rss.hpp"

using commerge::PointXYZI;

namespace {

// Stand-in when the KITTI scan is absent: an HDL-64E-like ray-cast scan of the generated street world.
std::vector<PointXYZI> SyntheticScan() {
  std::vector<PointXYZI> pts;
  commerge::CastScan(commerge::MakeStreetScene(42), commerge::SpinningLidar{}, 0.0f, 0.0f, 1.73f, 0.0f, 42, &pts);
  return pts;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 50;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--reps N]\n", argv[0]);
      return 2;
    }
  }
  if (reps < 1) {
    std::fprintf(stderr, "--reps must be >= 1\n");
    return 2;
  }

  const char* data_env = std::getenv("COMMERGE_SHARED_DATA");
  const std::string data_dir = data_env && *data_env ? data_env : CM_SHARED_DATA_DIR;
  const std::string kitti_path = data_dir + "/kitti/kitti00_frames0-15/velodyne/000000.bin";
  std::vector<PointXYZI> cloud;
  std::string source;
  if (auto scan = commerge::platform::ReadKittiBin(kitti_path); scan.ok()) {
    cloud = std::move(scan->points);
    source = "KITTI " + kitti_path;
  } else {
    cloud = SyntheticScan();
    source = "synthetic ray-cast street scan, seed 42 (KITTI scan unavailable: " + scan.status().ToString() + ")";
  }

  const commerge::VoxelGridParams params{1.0};
  commerge::VoxelGrid grid(cloud.size());
  std::vector<PointXYZI> out;
  const auto warmup = grid.Downsample(cloud, params, &out);
  if (!warmup.ok()) {
    std::fprintf(stderr, "voxel grid failed: %s\n", warmup.status().ToString().c_str());
    return 1;
  }

  std::vector<double> ms(static_cast<std::size_t>(reps));
  for (double& t : ms) {
    const auto start = std::chrono::steady_clock::now();
    const auto result = grid.Downsample(cloud, params, &out);
    t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!result.ok()) return 1;
  }
  double mean_ms = 0.0;
  for (const double t : ms) mean_ms += t;
  mean_ms /= reps;
  std::sort(ms.begin(), ms.end());
  const double median_ms = reps % 2 ? ms[reps / 2] : 0.5 * (ms[reps / 2 - 1] + ms[reps / 2]);

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
