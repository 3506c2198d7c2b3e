// SPDX-License-Identifier: BSD-3-Clause
// The merge files (platform/io/merge_outputs.hpp), read back: transforms.txt names every robot and pair with the
// transform as 12 numbers that parse back to it; trajectories go to robot_<r>_world.tum or _own_frame.tum (the
// other one removed) with T_world_map T_map_sensor per keyframe, and _gt.tum when there is ground truth.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/geometry/se3.hpp"
#include "platform/io/merge_outputs.hpp"
#include "platform/io/poses.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

Eigen::Isometry3d Pose(double yaw_rad, double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw_rad, 0.05, -0.02);
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

// The data lines of transforms.txt: keyword, ids, state and the 3x4 matrix.
struct Line {
  std::string keyword, state;
  std::vector<int> ids;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
};

std::vector<Line> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<Line> out;
  std::string text;
  while (std::getline(in, text)) {
    if (text.empty() || text[0] == '#') continue;
    std::istringstream s(text);
    Line l;
    s >> l.keyword;
    const int ids = l.keyword == "pair" ? 2 : 1;
    for (int i = 0; i < ids; ++i) {
      int id = -1;
      s >> id;
      l.ids.push_back(id);
    }
    s >> l.state;
    Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) s >> M(r, c);
    }
    REQUIRE_FALSE(s.fail());
    l.T.matrix() = M;
    out.push_back(l);
  }
  return out;
}

}  // namespace

TEST_CASE("transforms.txt: one line per robot and per pair, transforms that parse back") {
  MergeResultMessage m;
  m.round = 3;
  m.robot_ids = {0, 2, 5};
  m.in_world = {1, 1, 0};
  m.T_world_map = {Eigen::Isometry3d::Identity(), Pose(1.2, 30.5, -2.25, 0.5), Eigen::Isometry3d::Identity()};
  MergePairOutcome p;
  p.alpha = 0;
  p.beta = 2;
  p.success = true;
  p.consistent = true;
  p.verdict = "success";
  p.T_alpha_beta = Pose(1.2, 30.5, -2.25, 0.5);
  MergePairOutcome q;
  q.alpha = 2;
  q.beta = 5;
  q.verdict = "stage A: no cluster with span area >= tau_area";
  m.pairs = {p, q};
  const std::string path = test::ScratchDir() + "/transforms.txt";
  REQUIRE(WriteTransforms(path, m, "unit test").ok());
  const std::string text = test::ReadTextFile(path);
  CHECK(text.find("# unit test: merge result of round 3") == 0);
  CHECK(text.find("stage A: no cluster with span area >= tau_area") != std::string::npos);
  const std::vector<Line> lines = ReadLines(path);
  REQUIRE(lines.size() == 5);
  for (std::size_t i = 0; i < 3; ++i) {
    CHECK(lines[i].keyword == "robot");
    CHECK(lines[i].ids[0] == m.robot_ids[i]);
    CHECK(lines[i].state == (m.in_world[i] ? "merged" : "unmerged"));
    CHECK(lines[i].T.isApprox(m.T_world_map[i], 1e-8));
  }
  CHECK(lines[3].keyword == "pair");
  CHECK(lines[3].ids == std::vector<int>{0, 2});
  CHECK(lines[3].state == "merged");
  CHECK(lines[3].T.isApprox(p.T_alpha_beta, 1e-8));
  CHECK(lines[4].ids == std::vector<int>{2, 5});
  CHECK(lines[4].state == "unmerged");
  CHECK(WriteTransforms(test::ScratchDir() + "/no/such/dir/transforms.txt", m, "x").code() == StatusCode::kIoError);
}

TEST_CASE("Trajectories: world or own frame by placement, ground truth beside, an earlier round's other file removed") {
  const std::string dir = test::ScratchDir() + "/trajectories";
  std::filesystem::create_directories(dir);
  RobotTrajectory t;
  t.robot = 4;
  t.T_world_map = Pose(0.7, 10.0, 5.0, 0.0);
  for (int k = 0; k < 5; ++k) {
    t.T_map_sensor.push_back(Pose(0.1 * k, 1.0 * k, 0.5 * k, 0.0));
    t.times_s.push_back(100.0 + k);
  }
  t.in_world = false;
  REQUIRE(WriteTrajectory(dir, t).ok());
  CHECK(std::filesystem::exists(dir + "/robot_4_own_frame.tum"));
  CHECK_FALSE(std::filesystem::exists(dir + "/robot_4_gt.tum"));
  t.in_world = true;
  t.ground_truth = t.T_map_sensor;
  REQUIRE(WriteTrajectory(dir, t).ok());
  CHECK_FALSE(std::filesystem::exists(dir + "/robot_4_own_frame.tum"));
  auto world = ReadTumPoses(dir + "/robot_4_world.tum");
  REQUIRE(world.ok());
  REQUIRE(world->size() == 5);
  for (std::size_t k = 0; k < 5; ++k) {
    CHECK((*world)[k].time_s == doctest::Approx(100.0 + static_cast<double>(k)));
    CHECK((*world)[k].T_frame_sensor.isApprox(t.T_world_map * t.T_map_sensor[k], 1e-6));
  }
  auto gt = ReadTumPoses(dir + "/robot_4_gt.tum");
  REQUIRE(gt.ok());
  CHECK(gt->size() == 5);
  t.times_s.pop_back();
  CHECK(WriteTrajectory(dir, t).code() == StatusCode::kInvalidArgument);
}

}  // namespace commerge::platform
