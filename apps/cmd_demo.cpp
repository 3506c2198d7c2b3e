// SPDX-License-Identifier: BSD-3-Clause
// `commerge demo`: the README's main-job command on a built-in generated world.
//
// Today it runs the parts of the pipeline that exist: a two-robot street world, ray-cast HDL-64E-like
// scans along overlapping trajectories, the robot side (keyframes, SOLiD, 1 m scans in the budgeted scan
// store, loop closure, pose graph), and the map files. The server cascade and registration join as they
// are built.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/common/bytes.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/robot_mapper.hpp"
#include "core/slam/scan_store.hpp"
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
  const RobotPath robots[] = {{"alpha", -20.0f, -1.5f, 0.0f},
                              {"beta", -20.0f + static_cast<float>(o.keyframes_per_robot) - 4.0f, 1.5f, 3.14159265f}};
  const float sensor_height_m = 1.73f;

  std::vector<PointXYZI> raw, stored, map_points;
  std::vector<std::uint16_t> map_robot_ids;
  std::vector<std::uint8_t> spill_buffer;
  std::size_t raw_points = 0, stored_points = 0, record_bytes = 0, store_bytes = 0;
  for (std::uint16_t r = 0; r < 2; ++r) {
    const RobotPath& path = robots[r];
    // The robot side as deployed: SOLiD on raw scans, 1 m voxels into the budgeted scan store, loop closure.
    auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneHdl64e));
    auto store_params = ScanStoreParamsFromBudget(setup.config, ScanStorePolicy::kEvictOldest);
    if (!solid.ok() || !store_params.ok()) {
      std::fprintf(stderr, "commerge demo: %s\n", (!solid.ok() ? solid.status() : store_params.status()).message().c_str());
      return kExitFailure;
    }
    auto store = ScanStore::Create(*store_params);
    if (!store.ok()) {
      std::fprintf(stderr, "commerge demo: scan store: %s\n", store.status().message().c_str());
      return kExitFailure;
    }
    RobotMapperCapacity capacity;
    capacity.max_keyframes = static_cast<std::size_t>(setup.config.max_keyframes_per_robot);
    capacity.max_points_per_raw_scan = static_cast<std::size_t>(setup.config.max_points_per_raw_scan);
    capacity.max_points_per_stored_scan = static_cast<std::size_t>(setup.config.max_points_per_stored_scan);
    RobotMapper mapper(RobotMapperParams{}, capacity, &*solid, store->get());

    const float dir = std::cos(path.yaw_rad) > 0 ? 1.0f : -1.0f;
    Eigen::Isometry3d T_world_start = Eigen::Isometry3d::Identity();
    std::size_t valid = 0;
    for (int k = 0; k < o.keyframes_per_robot; ++k) {
      const float x = path.start_x_m + dir * static_cast<float>(k);
      Eigen::Isometry3d T_world_sensor = Eigen::Isometry3d::Identity();
      T_world_sensor.linear() = Eigen::AngleAxisd(path.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      T_world_sensor.translation() = Eigen::Vector3d(x, path.y_m, sensor_height_m);
      if (k == 0) T_world_start = T_world_sensor;
      CastScan(scene, lidar, x, path.y_m, sensor_height_m, path.yaw_rad,
               o.seed * 1000u + r * 100u + static_cast<std::uint32_t>(k), &raw);
      raw_points += raw.size();
      // Odometry: the robot's motion since its start (this demo has no drift yet).
      auto step = mapper.AddScan(Span<const PointXYZI>(raw), T_world_start.inverse() * T_world_sensor);
      if (!step.ok()) {
        std::fprintf(stderr, "commerge demo: robot %s: %s\n", path.name, step.status().message().c_str());
        return kExitFailure;
      }
      valid += step->is_keyframe && step->descriptor.valid;
      if (r == 0 && k == 0) {
        const std::string first = o.out_dir + "/alpha_000000.bin";
        if (Status st = platform::WriteKittiBin(first, Span<const PointXYZI>(raw)); !st.ok()) {
          std::fprintf(stderr, "commerge demo: %s\n", st.message().c_str());
          return kExitFailure;
        }
      }
    }
    // The reference map: every stored (encoded, 1 m) scan placed with the robot's poses and its true start.
    for (std::size_t k = 0; k < mapper.num_keyframes(); ++k) {
      auto n = (*store)->GetPoints(static_cast<std::uint32_t>(k), &stored, &spill_buffer);
      if (!n.ok()) continue;  // evicted (a tiny --scan-store-mb): not in the map
      stored_points += stored.size();
      const Eigen::Isometry3d T = T_world_start * mapper.pose(k);
      for (const PointXYZI& p : stored) {
        const Eigen::Vector3d q = T * Eigen::Vector3d(p.x, p.y, p.z);
        map_points.push_back({static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), p.intensity});
        map_robot_ids.push_back(r);
      }
    }
    record_bytes += mapper.num_keyframes() * kKeyframeRecordBytes;
    store_bytes += (*store)->stats().used_bytes;
    std::printf("  robot %-5s %zu keyframes, %zu valid SOLiD descriptors (%zu B on the wire), %zu scans in its "
                "store (%s), %llu loops\n",
                path.name, mapper.num_keyframes(), valid, mapper.num_keyframes() * kKeyframeRecordBytes,
                (*store)->stats().num_scans, FormatBytes(static_cast<std::int64_t>((*store)->stats().used_bytes)).c_str(),
                static_cast<unsigned long long>(mapper.stats().loops_accepted));
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
  std::printf("  scans: %d, raw %zu points (%s); stored at 1 m: %zu points (%s encoded, %.1f%% of raw); "
              "descriptors + poses: %s\n",
              2 * o.keyframes_per_robot, raw_points, FormatBytes(raw_bytes).c_str(), stored_points,
              FormatBytes(static_cast<std::int64_t>(store_bytes)).c_str(),
              100.0 * static_cast<double>(store_bytes) / static_cast<double>(raw_bytes),
              FormatBytes(static_cast<std::int64_t>(record_bytes)).c_str());
  std::printf("  wrote %s, %s (robot id per point), %s/alpha_000000.bin\n", pcd.c_str(), ply.c_str(), o.out_dir.c_str());
  std::printf("  not in this build yet: server cascade and registration (the map places each robot by its true "
              "start)\n");
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
