// SPDX-License-Identifier: BSD-3-Clause
// `commerge demo`: the README's main-job command on a built-in generated world.
//
// Today it runs the parts of the pipeline that exist: a two-robot street world, ray-cast HDL-64E-like
// scans along overlapping trajectories, 1 m voxelisation of every keyframe (what robots keep and would
// send), and the map files. Descriptors, the server cascade and registration join as they are built.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/bytes.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/pcd.hpp"
#include "platform/io/ply.hpp"

namespace commerge::app {

namespace {

struct DemoOptions {
  std::string out_dir = "out/demo";
  std::uint32_t seed = 7;
  int keyframes_per_robot = 10;
  MemoryFlags memory;
};

struct RobotPath {
  const char* name;
  float start_x_m, y_m, yaw_rad;
};

int RunDemo(const DemoOptions& o) {
  // The demo world is small: size the budget for it unless the user asks otherwise.
  MemoryFlags memory = o.memory;
  if (memory.robots == 0) memory.robots = 2;
  if (memory.max_keyframes == 0) memory.max_keyframes = 1000;
  if (memory.scan_store_mb == 0) memory.scan_store_mb = 64;
  MemorySetup setup;
  if (int rc = SetUpMemory(AppKind::kRun, memory, &setup, /*print_table=*/false); rc != kExitOk) return rc;
  std::printf("commerge demo: %s\n", setup.verdict.c_str());

  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "commerge demo: cannot create output directory %s: %s\n", o.out_dir.c_str(),
                 ec.message().c_str());
    return kExitFailure;
  }

  const BoxScene scene = MakeStreetScene(o.seed);
  const SpinningLidar lidar;  // HDL-64E-like
  // Two robots drive the same street in opposite directions; their keyframes (1 m apart) overlap.
  const RobotPath robots[] = {{"alpha", -20.0f, -1.5f, 0.0f}, {"beta", -20.0f + o.keyframes_per_robot - 4.0f, 1.5f, 3.14159265f}};
  const float sensor_height_m = 1.73f;

  std::vector<PointXYZI> raw, voxels, map_points;
  std::vector<std::uint16_t> map_robot_ids;
  VoxelGridParams vparams;  // 1.0 m, the paper's setting
  std::size_t raw_points = 0, voxel_points = 0;
  for (std::uint16_t r = 0; r < 2; ++r) {
    const RobotPath& path = robots[r];
    const float dir = std::cos(path.yaw_rad) > 0 ? 1.0f : -1.0f;
    for (int k = 0; k < o.keyframes_per_robot; ++k) {
      const float x = path.start_x_m + dir * static_cast<float>(k);
      CastScan(scene, lidar, x, path.y_m, sensor_height_m, path.yaw_rad, o.seed * 1000u + r * 100u + static_cast<std::uint32_t>(k), &raw);
      auto stats = VoxelDownsample(Span<const PointXYZI>(raw), vparams, &voxels);
      if (!stats.ok()) {
        std::fprintf(stderr, "commerge demo: voxelisation failed: %s\n", stats.status().message().c_str());
        return kExitFailure;
      }
      raw_points += raw.size();
      voxel_points += voxels.size();
      if (r == 0 && k == 0) {
        const std::string first = o.out_dir + "/alpha_000000.bin";
        if (Status st = platform::WriteKittiBin(first, Span<const PointXYZI>(raw)); !st.ok()) {
          std::fprintf(stderr, "commerge demo: %s\n", st.message().c_str());
          return kExitFailure;
        }
      }
      // Ground-truth placement: the demo's reference map (the merge estimates this once registration exists).
      const float c = std::cos(path.yaw_rad), s = std::sin(path.yaw_rad);
      for (const PointXYZI& p : voxels) {
        map_points.push_back({c * p.x - s * p.y + x, s * p.x + c * p.y + path.y_m, p.z + sensor_height_m, p.intensity});
        map_robot_ids.push_back(r);
      }
    }
    std::printf("  robot %-5s %d keyframes along the street\n", path.name, o.keyframes_per_robot);
  }

  const std::string pcd = o.out_dir + "/map_ground_truth.pcd";
  const std::string ply = o.out_dir + "/map_ground_truth.ply";
  for (Status st : {platform::WritePcd(pcd, Span<const PointXYZI>(map_points), platform::PcdEncoding::kBinary,
                                       Span<const std::uint16_t>(map_robot_ids)),
                    platform::WritePly(ply, Span<const PointXYZI>(map_points), Span<const std::uint16_t>(map_robot_ids))}) {
    if (!st.ok()) {
      std::fprintf(stderr, "commerge demo: %s\n", st.message().c_str());
      return kExitFailure;
    }
  }
  const std::int64_t raw_bytes = static_cast<std::int64_t>(raw_points * sizeof(PointXYZI));
  const std::int64_t voxel_bytes = static_cast<std::int64_t>(voxel_points * sizeof(PointXYZI));
  std::printf("  scans: %d, raw points %zu (%s), after 1 m voxels %zu (%s, %.1f%% of raw)\n",
              2 * o.keyframes_per_robot, raw_points, FormatBytes(raw_bytes).c_str(), voxel_points,
              FormatBytes(voxel_bytes).c_str(), 100.0 * static_cast<double>(voxel_bytes) / static_cast<double>(raw_bytes));
  std::printf("  wrote %s, %s (robot id per point), %s/alpha_000000.bin\n", pcd.c_str(), ply.c_str(), o.out_dir.c_str());
  std::printf("  not in this build yet: descriptors, server cascade, registration (the map above uses ground truth)\n");
  std::printf("  %s\n", PeakRssLine().c_str());
  return kExitOk;
}

}  // namespace

Command AddDemoCommand(CLI::App& root) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* cmd = root.add_subcommand("demo", "Run the pipeline on a small built-in two-robot world");
  cmd->add_option("--out", o->out_dir, "Output directory")->capture_default_str();
  cmd->add_option("--seed", o->seed, "World seed")->capture_default_str();
  cmd->add_option("--keyframes", o->keyframes_per_robot, "Keyframes per robot (1 m apart)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o]() -> int { return RunDemo(*o); }};
}

}  // namespace commerge::app
