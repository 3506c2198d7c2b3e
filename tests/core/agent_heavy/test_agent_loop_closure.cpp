// SPDX-License-Identifier: BSD-3-Clause
// The robot agent through a loop closure (a drifting block drive): poses stream to the server only when
// they moved more than the streaming threshold, and a scan request brings the requested keyframes' current
// poses, so the server builds submaps with the robot's final poses. (Host only: about 1.5 s.)
#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "tests/core/agent/server_fixture.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/robot_agent.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "tests/support/block_loop_drive.hpp"

using namespace commerge;

TEST_CASE("Robot agent streams poses moved beyond its threshold and refreshes requested ones exactly") {
  const BoxScene scene = MakeBlockLoopScene(11, static_cast<float>(test::kWidth), static_cast<float>(test::kHeight));
  const SpinningLidar lidar = test::BlockLoopLidar();
  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneVlp16));
  REQUIRE(solid.ok());
  ScanStoreParams store_params;
  store_params.capacity_bytes = 4 << 20;
  store_params.max_scans = 1000;
  auto store = ScanStore::Create(store_params);
  REQUIRE(store.ok());
  RobotMapperCapacity capacity;
  capacity.max_keyframes = 400;
  capacity.max_points_per_raw_scan = 20000;
  RobotAgentParams params;
  RobotAgent agent(0, params, capacity, &*solid, store->get());
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 400, MergeServerParams{});
  MergeServer& server = *server_owner;

  // Odometry with a yaw drift of 0.1 deg per metre and 1 % scale error; batches stream as the robot drives.
  const double perimeter = 2.0 * (test::kWidth + test::kHeight);
  Eigen::Isometry3d T_odom = test::PoseOnLoop(0.0), T_prev = T_odom;
  std::vector<PointXYZI> scan;
  KeyframeBatch batch;
  PoseUpdate update;
  std::size_t streamed_poses = 0;
  auto stream = [&]() {
    while (true) {
      auto taken = agent.TakeKeyframeBatch(0, &batch);
      REQUIRE(taken.ok());
      if (!*taken) break;
      REQUIRE(server.OnKeyframeBatch(batch).ok());
    }
    while (agent.TakePoseUpdate(0, &update)) {
      streamed_poses += update.keyframes.size();
      REQUIRE(server.OnPoseUpdate(update).ok());
    }
  };
  for (double s = 0.0; s <= 1.25 * perimeter; s += 0.5) {
    const Eigen::Isometry3d T_truth = test::PoseOnLoop(s);
    Eigen::Isometry3d step = T_prev.inverse() * T_truth;
    step.translation() *= 1.01;
    step.linear() = Eigen::AngleAxisd(0.5 * 0.1 * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * step.linear();
    T_odom = T_odom * step;
    T_prev = T_truth;
    const double yaw = std::atan2(T_truth.linear()(1, 0), T_truth.linear()(0, 0));
    CastScan(scene, lidar, static_cast<float>(T_truth.translation().x()), static_cast<float>(T_truth.translation().y()),
             static_cast<float>(test::kSensorZ), static_cast<float>(yaw), static_cast<std::uint32_t>(s * 2), &scan);
    REQUIRE(agent.AddScan(Span<const PointXYZI>(scan), T_odom).ok());
    stream();
  }
  REQUIRE(agent.Finish().ok());
  stream();
  const RobotMapper& mapper = agent.mapper();
  REQUIRE(mapper.stats().loops_accepted > 0);
  const std::size_t n = mapper.num_keyframes();
  REQUIRE(server.robot(0).size() == n);

  // Every keyframe the server has is within the streaming threshold of the robot's final pose, and the
  // loop closure did move some by more (so the threshold was exercised, not everything re-sent).
  std::size_t moved_far = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Isometry3d& robot = mapper.pose(k);
    const Eigen::Isometry3d& known = server.robot(0).T_map_sensor[k];
    CHECK((robot.translation() - known.translation()).norm() <= params.pose_update_min_translation_m + 1e-4);
    CHECK(RotationAngleRad(robot.linear().transpose() * known.linear()) * 180.0 / kPi <=
          params.pose_update_min_rotation_deg + 1e-2);
    moved_far += (robot.translation() - known.translation()).norm() > params.request_pose_min_translation_m;
  }
  CHECK(streamed_poses > 0);
  CHECK(streamed_poses < n);  // far fewer than "every moved pose every time"

  // A request refreshes exactly the requested keyframes that differ by more than 1 cm.
  ScanRequest request;
  request.robot_id = 0;
  for (std::uint32_t k = 0; k < n; k += 3) request.keyframes.push_back(k);
  std::vector<ScanChunk> chunks;
  PoseUpdate fresh;
  auto answer = agent.AnswerRequest(request, 0, &chunks, &fresh);
  REQUIRE(answer.ok());
  std::size_t expected = 0;
  for (std::uint32_t k : request.keyframes) {
    expected += (mapper.pose(k).translation() - server.robot(0).T_map_sensor[k].translation()).norm() > 0.01 ||
                RotationAngleRad(mapper.pose(k).linear().transpose() * server.robot(0).T_map_sensor[k].linear()) *
                        180.0 / kPi > 0.05;
  }
  CHECK(fresh.keyframes.size() >= expected);
  CHECK(moved_far > 0);
  REQUIRE(server.OnPoseUpdate(fresh).ok());
  for (std::uint32_t k : request.keyframes) {
    CHECK((mapper.pose(k).translation() - server.robot(0).T_map_sensor[k].translation()).norm() < 0.011);
  }
  // Asked again: nothing left to refresh.
  PoseUpdate again;
  REQUIRE(agent.AnswerRequest(request, 0, &chunks, &again).ok());
  CHECK(again.keyframes.empty());
}
