// SPDX-License-Identifier: BSD-3-Clause
// How the robots of a finished mission agree along the path they share (core/eval/path_agreement.hpp): reads a
// server's trajectories (TRAJ/robot_<r>_world.tum, written after each round: the keyframes it holds in the world
// frame, the keyframe index as the time stamp) and a `commerge sim` dataset's truth (DATA/robot_<r>/poses_gt.txt
// and T_gt_robotstart.txt: p_gt = T_gt_robotstart * poses_gt[k]; one scan per keyframe), and prints the error of
// the relative position of every two robots' keyframes within --radius-m of each other.
// Usage: path_agreement --trajectories DIR --data DIR [--radius-m 10] [--stride 1]
// Robots without a _world.tum (not placed) are left out. Exit 0 with the figures, 2 on bad input.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/eval/path_agreement.hpp"
#include "platform/io/poses.hpp"

int main(int argc, char** argv) {
  std::string trajectories, data;
  commerge::PathAgreementParams params;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--trajectories") == 0 && has_value) {
      trajectories = argv[++i];
    } else if (std::strcmp(argv[i], "--data") == 0 && has_value) {
      data = argv[++i];
    } else if (std::strcmp(argv[i], "--radius-m") == 0 && has_value) {
      params.radius_m = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--stride") == 0 && has_value) {
      params.keyframe_stride = static_cast<std::size_t>(std::atol(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: %s --trajectories DIR --data DIR [--radius-m 10] [--stride 1]\n", argv[0]);
      return 2;
    }
  }
  if (trajectories.empty() || data.empty()) {
    std::fprintf(stderr, "path_agreement: --trajectories and --data are required\n");
    return 2;
  }
  std::vector<std::vector<Eigen::Isometry3d>> world, truth;
  std::vector<int> ids;
  for (int r = 0;; ++r) {
    const std::string robot_dir = data + "/robot_" + std::to_string(r);
    if (!std::filesystem::is_directory(robot_dir)) break;
    const std::string tum = trajectories + "/robot_" + std::to_string(r) + "_world.tum";
    if (!std::filesystem::exists(tum)) continue;
    auto est = commerge::platform::ReadTumPoses(tum);
    auto gt = commerge::platform::ReadKittiPoses(robot_dir + "/poses_gt.txt");
    auto start = commerge::platform::ReadKittiPoses(robot_dir + "/T_gt_robotstart.txt");
    for (const commerge::Status& st : {est.status(), gt.status(), start.status()}) {
      if (!st.ok()) {
        std::fprintf(stderr, "path_agreement: robot %d: %s\n", r, st.message().c_str());
        return 2;
      }
    }
    if (start->size() != 1) {
      std::fprintf(stderr, "path_agreement: %s/T_gt_robotstart.txt: expected 1 pose, found %zu\n", robot_dir.c_str(),
                   start->size());
      return 2;
    }
    std::vector<Eigen::Isometry3d> w, t;
    for (const commerge::platform::StampedPose& p : *est) {
      const double k = std::round(p.time_s);
      if (std::abs(p.time_s - k) > 1e-6 || k < 0.0 || k >= static_cast<double>(gt->size())) {
        std::fprintf(stderr, "path_agreement: %s: time stamp %.6f is not a keyframe index below %zu\n", tum.c_str(),
                     p.time_s, gt->size());
        return 2;
      }
      w.push_back(p.T_frame_sensor);
      t.push_back(start->front() * (*gt)[static_cast<std::size_t>(k)]);
    }
    world.push_back(std::move(w));
    truth.push_back(std::move(t));
    ids.push_back(r);
  }
  std::vector<commerge::RobotPathTruth> robots;
  for (std::size_t i = 0; i < world.size(); ++i) {
    robots.push_back({commerge::Span<const Eigen::Isometry3d>(world[i]), commerge::Span<const Eigen::Isometry3d>(truth[i])});
  }
  auto a = commerge::MeasurePathAgreement(commerge::Span<const commerge::RobotPathTruth>(robots), params);
  if (!a.ok()) {
    std::fprintf(stderr, "path_agreement: %s\n", a.status().message().c_str());
    return 2;
  }
  std::printf("robots placed with truth: %zu; keyframe pairs within %.1f m: %zu", ids.size(), params.radius_m, a->pairs);
  if (a->pairs > 0) {
    std::printf("; relative position against the truth: %.3f m RMS, %.3f m at the 95th percentile, %.3f m at most",
                a->rms_m, a->p95_m, a->max_m);
  }
  std::printf("\n");
  return 0;
}
