// SPDX-License-Identifier: BSD-3-Clause
// The simulated-dataset writer (platform/io/kitti_dataset_writer.hpp): files re-read with the platform readers
// equal what was generated, the frame chain p_gt = T_gt_robotstart * poses_gt[k] * p_scan puts ground
// returns on the ground, overlapping robots' re-read poses coincide in the ground-truth frame gt, and a non-empty output
// directory is refused unless forced (which removes only the dataset's own files).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/sim/lidar_models.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/procedural_world.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_writer.hpp"
#include "platform/io/poses.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

namespace fs = std::filesystem;

struct Written {
  MissionPlan plan;
  std::string root;
};

/// Plans a small mission and writes it (scans of the first `scans` keyframes of every robot, 16 beams x 120).
Written WriteSmallDataset(const std::string& name, OverlapMode overlap, int keyframes, int scans) {
  MissionParams p;
  p.world = WorldKind::kUrban;
  p.overlap = overlap;
  p.robots = 2;
  p.keyframes_per_robot = keyframes;
  p.seed = 12;
  auto plan = PlanMission(p);
  REQUIRE(plan.ok());
  const World world = *BuildMissionWorld(*plan);
  const std::string root = test::ScratchFile(name);
  auto writer = KittiDatasetWriter::Create(root, 2, false);
  REQUIRE_MESSAGE(writer.ok(), writer.status().ToString());
  std::vector<Eigen::Isometry3d> starts;
  LidarModel lidar = MakeLidarModel(LidarKind::kVlp16);
  lidar.azimuth_steps = 120;
  LidarScanWorkspace ws;
  std::vector<PointXYZI> scan;
  for (const RobotMission& r : plan->robots) {
    REQUIRE(writer->WriteTrajectory(r.id, r.odometry, r.gt, r.times_s, r.T_gt_robotstart).ok());
    starts.push_back(r.T_gt_robotstart);
    for (int k = 0; k < scans; ++k) {
      REQUIRE(SimulateLidarScan(world, lidar, r.T_gt_sensor(static_cast<std::size_t>(k)),
                                ScanNoiseSeed(p, r.id, static_cast<std::size_t>(k)), static_cast<std::uint64_t>(k), &ws, &scan)
                  .ok());
      REQUIRE(writer->WriteScan(r.id, static_cast<std::size_t>(k), scan).ok());
    }
  }
  REQUIRE(writer->WriteStartTransforms(starts).ok());
  REQUIRE(writer->WriteInfo("world: urban\n").ok());
  return {std::move(plan).value(), root};
}

bool Near(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tol) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() <= tol;
}

TEST_CASE("kitti dataset writer: re-read poses, times, start transforms and scans equal what was generated") {
  const Written w = WriteSmallDataset("roundtrip", OverlapMode::kModerate, 40, 3);
  for (const RobotMission& r : w.plan.robots) {
    const std::string dir = w.root + "/" + SimRobotDirName(r.id);
    auto odo = ReadKittiPoses(dir + "/poses.txt");
    auto gt = ReadKittiPoses(dir + "/poses_gt.txt");
    auto times = ReadTimes(dir + "/times.txt");
    auto start = ReadKittiPoses(dir + "/T_gt_robotstart.txt");
    REQUIRE(odo.ok());
    REQUIRE(gt.ok());
    REQUIRE(times.ok());
    REQUIRE(start.ok());
    REQUIRE(odo->size() == r.odometry.size());
    REQUIRE(gt->size() == r.gt.size());
    REQUIRE(times->size() == r.times_s.size());
    for (std::size_t k = 0; k < r.gt.size(); ++k) {
      CHECK(Near((*odo)[k], r.odometry[k], 1e-12));  // the reader re-orthonormalises: agreement to rounding
      CHECK(Near((*gt)[k], r.gt[k], 1e-12));
      CHECK((*times)[k] == r.times_s[k]);  // shortest exact text
    }
    CHECK(Near((*gt)[0], Eigen::Isometry3d::Identity(), 1e-15));
    CHECK(Near(start->front(), r.T_gt_robotstart, 1e-12));
    CHECK(fs::exists(dir + "/calib.txt"));
    CHECK(test::ReadTextFile(dir + "/calib.txt").find("Tr: 1 0 0 0 0 1 0 0 0 0 1 0") != std::string::npos);
    for (int k = 0; k < 3; ++k) {
      auto scan = ReadKittiBin(dir + "/velodyne/" + KittiScanFileName(static_cast<std::size_t>(k)));
      REQUIRE(scan.ok());
      CHECK(scan->points.size() > 500);
    }
  }
  auto starts = ReadKittiPoses(w.root + "/start_transforms.txt");
  REQUIRE(starts.ok());
  REQUIRE(starts->size() == 2);
  CHECK(Near((*starts)[1], w.plan.robots[1].T_gt_robotstart, 1e-12));
  CHECK(KittiScanFileName(42) == "000042.bin");
  CHECK(fs::exists(w.root + "/robot_1/velodyne/000002.bin"));
  CHECK(test::ReadTextFile(w.root + "/sim_info.txt") == "world: urban\n");
}

TEST_CASE("kitti dataset writer: T_gt_robotstart * poses_gt(k) puts the scans' ground returns on z = 0") {
  const Written w = WriteSmallDataset("frames", OverlapMode::kComplete, 300, 6);
  for (int r = 0; r < 2; ++r) {
    const std::string dir = w.root + "/" + SimRobotDirName(r);
    const Eigen::Isometry3d T_gt_start = ReadKittiPoses(dir + "/T_gt_robotstart.txt")->front();
    const std::vector<Eigen::Isometry3d> gt = *ReadKittiPoses(dir + "/poses_gt.txt");
    for (std::size_t k = 0; k < 6; k += 5) {
      const auto scan = ReadKittiBin(dir + "/velodyne/" + KittiScanFileName(k));
      REQUIRE(scan.ok());
      std::size_t on_ground = 0, below = 0;
      for (const PointXYZI& p : scan->points) {
        const Eigen::Vector3d q = T_gt_start * gt[k] * Eigen::Vector3f(p.x, p.y, p.z).cast<double>();
        on_ground += std::fabs(q.z()) < 0.06;
        below += q.z() < -0.1;
      }
      CHECK(on_ground > scan->points.size() / 5);  // the lower beams hit the flat ground
      CHECK(below == 0);                           // nothing under it: the frame chain is right
    }
  }
  // Complete overlap, read back: mapped through their start transforms, the two robots' ground-truth
  // keyframes coincide (within the lane offsets) over the whole route.
  std::vector<Eigen::Vector3d> gt0, gt1;
  for (int r = 0; r < 2; ++r) {
    const std::string dir = w.root + "/" + SimRobotDirName(r);
    const Eigen::Isometry3d start = ReadKittiPoses(dir + "/T_gt_robotstart.txt")->front();
    const std::vector<Eigen::Isometry3d> gt = *ReadKittiPoses(dir + "/poses_gt.txt");
    for (const Eigen::Isometry3d& g : gt) (r ? gt1 : gt0).push_back((start * g).translation());
  }
  std::size_t matched = 0;
  for (const Eigen::Vector3d& p : gt0) {
    double nearest = 1e9;
    for (const Eigen::Vector3d& q : gt1) nearest = std::min(nearest, (p - q).norm());
    matched += nearest < 5.0;
  }
  CHECK(static_cast<double>(matched) >= 0.9 * static_cast<double>(gt0.size()));
}

TEST_CASE("kitti dataset writer: a non-empty directory is refused, --force replaces only the dataset's files") {
  const std::string root = test::ScratchDir() + "/occupied";
  fs::create_directories(root + "/robot_7/velodyne");
  {
    std::FILE* f = std::fopen((root + "/notes.txt").c_str(), "w");
    REQUIRE(f != nullptr);
    std::fputs("keep me\n", f);
    std::fclose(f);
    f = std::fopen((root + "/sim_info.txt").c_str(), "w");
    REQUIRE(f != nullptr);
    std::fclose(f);
  }
  auto refused = KittiDatasetWriter::Create(root, 2, false);
  REQUIRE(!refused.ok());
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
  CHECK(refused.status().message().find("not empty") != std::string::npos);
  CHECK(refused.status().message().find("--force") != std::string::npos);
  auto forced = KittiDatasetWriter::Create(root, 2, true);
  REQUIRE(forced.ok());
  CHECK(fs::exists(root + "/notes.txt"));
  CHECK(!fs::exists(root + "/robot_7"));
  CHECK(!fs::exists(root + "/sim_info.txt"));
  CHECK(fs::is_directory(root + "/robot_1/velodyne"));
  // A file where the root should be is an error naming it.
  auto not_dir = KittiDatasetWriter::Create(root + "/notes.txt", 2, true);
  REQUIRE(!not_dir.ok());
  CHECK(not_dir.status().message().find("notes.txt") != std::string::npos);
  // Mismatched trajectory sizes are refused.
  std::vector<Eigen::Isometry3d> poses(3, Eigen::Isometry3d::Identity());
  std::vector<double> times(2, 0.0);
  CHECK(forced->WriteTrajectory(0, poses, poses, times, Eigen::Isometry3d::Identity()).code() ==
        StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace commerge::platform
