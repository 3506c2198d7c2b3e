// SPDX-License-Identifier: BSD-3-Clause
// Simulator throughput: scans per second per world and LiDAR model at the models' default resolution,
// mission planning and world generation times, peak RSS; optionally the time to write a whole 2-robot
// VLP-16 dataset (what `commerge sim` does).
//
// Usage: bench_sim [--quick] [--scans N] [--keyframes N] [--write-keyframes N] [--threads N] [--out DIR]
//   --quick              3 scans per world and model (a smoke run)
//   --scans N            scans timed per world and model (default 20)
//   --keyframes N        keyframes per robot of the benchmark missions (default 2000)
//   --write-keyframes N  also write a 2-robot urban VLP-16 dataset of N keyframes per robot (default 0: skip)
//   --threads N          threads for that dataset (default 1)
//   --out DIR            where to write it (default: a temporary directory, removed afterwards)
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "core/sim/lidar_models.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/procedural_world.hpp"
#include "platform/io/kitti_dataset_writer.hpp"
#include "platform/memory/peak_rss.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace commerge;

double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

void Usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--quick] [--scans N] [--keyframes N] [--write-keyframes N] [--threads N] [--out DIR]\n"
               "  scans/s per world (urban, campus, indoor, cave) and lidar (vlp16, hdl64, os128, livox) at the\n"
               "  models' default resolution; --write-keyframes N also writes a 2-robot urban VLP-16 dataset\n",
               argv0);
}

int WriteDataset(int keyframes, int threads, std::string out_dir) {
  const bool temporary = out_dir.empty();
  if (temporary) out_dir = (std::filesystem::temp_directory_path() / "commerge-bench-sim").string();
  MissionParams params;
  params.world = WorldKind::kUrban;
  params.overlap = OverlapMode::kModerate;
  params.robots = 2;
  params.keyframes_per_robot = keyframes;
  const auto t0 = Clock::now();
  auto plan = PlanMission(params);
  if (!plan.ok()) {
    std::fprintf(stderr, "plan: %s\n", plan.status().ToString().c_str());
    return 1;
  }
  auto world = BuildMissionWorld(*plan);
  if (!world.ok()) {
    std::fprintf(stderr, "world: %s\n", world.status().ToString().c_str());
    return 1;
  }
  const double setup_s = Since(t0);
  auto writer = platform::KittiDatasetWriter::Create(out_dir, 2, /*force=*/true);
  if (!writer.ok()) {
    std::fprintf(stderr, "writer: %s\n", writer.status().ToString().c_str());
    return 1;
  }
  const LidarModel lidar = MakeLidarModel(LidarKind::kVlp16);
  const auto t1 = Clock::now();
  for (const RobotMission& r : plan->robots) {
    if (!writer->WriteTrajectory(r.id, r.odometry, r.gt, r.times_s, r.T_gt_robotstart).ok()) return 1;
  }
  const std::size_t total = 2 * static_cast<std::size_t>(keyframes);
  std::atomic<std::size_t> next{0}, points{0};
  std::atomic<bool> failed{false};
  auto worker = [&] {
    LidarScanWorkspace ws;
    std::vector<PointXYZI> scan;
    for (std::size_t job = next++; job < total && !failed; job = next++) {
      const int r = static_cast<int>(job / static_cast<std::size_t>(keyframes));
      const std::size_t k = job % static_cast<std::size_t>(keyframes);
      const RobotMission& robot = plan->robots[static_cast<std::size_t>(r)];
      if (!SimulateLidarScan(*world, lidar, robot.T_gt_sensor(k), ScanNoiseSeed(params, r, k), k, &ws, &scan).ok() ||
          !writer->WriteScan(r, k, scan).ok()) {
        failed = true;
      }
      points += scan.size();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  if (failed) {
    std::fprintf(stderr, "writing the dataset failed\n");
    return 1;
  }
  const double write_s = Since(t1);
  std::printf("\ndataset: urban, 2 robots x %d keyframes, VLP-16 (%d rays/scan), %d thread(s), %s\n", keyframes,
              lidar.rays_per_frame(), threads, out_dir.c_str());
  std::printf("  plan + world %.2f s; scans + files %.1f s = %.1f scans/s; %.0f points/scan; %s written\n", setup_s,
              write_s, static_cast<double>(total) / write_s, static_cast<double>(points) / static_cast<double>(total),
              FormatBytes(static_cast<std::int64_t>(points * sizeof(PointXYZI))).c_str());
  if (temporary) {
    std::error_code ec;
    std::filesystem::remove_all(out_dir, ec);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int scans = 20, keyframes = 2000, write_keyframes = 0, threads = 1;
  std::string out_dir;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](int* v) {
      if (i + 1 >= argc) return false;
      *v = std::atoi(argv[++i]);
      return true;
    };
    if (std::strcmp(argv[i], "--quick") == 0) {
      scans = 3;
    } else if (std::strcmp(argv[i], "--scans") == 0 && value(&scans)) {
    } else if (std::strcmp(argv[i], "--keyframes") == 0 && value(&keyframes)) {
    } else if (std::strcmp(argv[i], "--write-keyframes") == 0 && value(&write_keyframes)) {
    } else if (std::strcmp(argv[i], "--threads") == 0 && value(&threads)) {
    } else if (std::strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
      out_dir = argv[++i];
    } else {
      Usage(argv[0]);
      return std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0 ? 0 : 2;
    }
  }
  if (scans < 1 || keyframes < 2 || write_keyframes < 0 || threads < 1) {
    Usage(argv[0]);
    return 2;
  }
  const LidarKind lidars[] = {LidarKind::kVlp16, LidarKind::kHdl64e, LidarKind::kOs1_128, LidarKind::kLivox};
  std::printf("scans/s per world and lidar (1 thread, %d scans spread along robot 0's route, %d keyframes, moderate "
              "overlap, 2 robots)\n",
              scans, keyframes);
  std::printf("%-7s %9s %9s %8s | %-6s %9s %10s %11s\n", "world", "plan ms", "world ms", "prims", "lidar", "scans/s",
              "Mrays/s", "points/scan");
  for (WorldKind kind : {WorldKind::kUrban, WorldKind::kCampus, WorldKind::kIndoor, WorldKind::kCave}) {
    MissionParams params;
    params.world = kind;
    params.keyframes_per_robot = keyframes;
    const auto t0 = Clock::now();
    auto plan = PlanMission(params);
    const double plan_ms = 1e3 * Since(t0);
    if (!plan.ok()) {
      std::fprintf(stderr, "plan: %s\n", plan.status().ToString().c_str());
      return 1;
    }
    const auto t1 = Clock::now();
    auto world = BuildMissionWorld(*plan);
    const double world_ms = 1e3 * Since(t1);
    if (!world.ok()) {
      std::fprintf(stderr, "world: %s\n", world.status().ToString().c_str());
      return 1;
    }
    const WorldStats st = world->stats();
    const std::size_t prims = st.boxes + st.cylinders + st.spheres + st.tunnel_segments;
    for (LidarKind lk : lidars) {
      const LidarModel lidar = MakeLidarModel(lk);
      LidarScanWorkspace ws;
      std::vector<PointXYZI> scan;
      std::size_t points = 0;
      const RobotMission& robot = plan->robots[0];
      const auto t2 = Clock::now();
      for (int s = 0; s < scans; ++s) {
        const std::size_t k = static_cast<std::size_t>(s) * (robot.gt.size() - 1) / static_cast<std::size_t>(scans);
        if (!SimulateLidarScan(*world, lidar, robot.T_gt_sensor(k), 1, k, &ws, &scan).ok()) return 1;
        points += scan.size();
      }
      const double secs = Since(t2);
      std::printf("%-7s %9.1f %9.1f %8zu | %-6s %9.1f %10.2f %11.0f\n", WorldKindName(kind), plan_ms, world_ms, prims,
                  LidarKindName(lk), scans / secs, scans * lidar.rays_per_frame() / secs / 1e6,
                  static_cast<double>(points) / scans);
    }
  }
  std::printf("peak RSS: %s\n", FormatBytes(platform::ReadRss().peak_bytes).c_str());
  if (write_keyframes > 0) {
    if (int rc = WriteDataset(write_keyframes, threads, out_dir); rc != 0) return rc;
    std::printf("peak RSS: %s\n", FormatBytes(platform::ReadRss().peak_bytes).c_str());
  }
  return 0;
}
