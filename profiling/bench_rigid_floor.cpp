// SPDX-License-Identifier: BSD-3-Clause
// bench_rigid_floor SIMDIR SERVER_OUT: how close to the truth any rigid merge of the robots' own maps can come.
// For each robot r >= 1 of a `commerge sim` dataset merged by `commerge server --out SERVER_OUT`: the keyframe
// pairs (every 5th of robot r, robot 0's nearest) within 1 m of each other in ground truth are the places the two
// robots share; robot r's map positions there (SERVER_OUT/trajectories, brought back into r's map frame with the
// server's T_world_map) are aligned rigidly (Umeyama) onto robot 0's (each corrected by the true offset between the
// two keyframes). That alignment, against the truth inv(T_gt_start0) * T_gt_start_r, is the floor of a rigid merge:
// the error the robots' own maps carry (odometry scale bias, bends) at the places they share; and the fit over 40
// consecutive shared keyframes (one place, what a registration sees) nearest the truth. Printed beside the
// server's own transform error.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"
#include "platform/io/poses.hpp"

namespace {

using commerge::Span;
using Iso = Eigen::Isometry3d;

// T_world_map of robot r from transforms.txt; false when it is missing or unmerged.
bool ReadWorldMap(const std::string& path, int r, Iso* T) {
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string what, state;
    int id = -1;
    s >> what >> id >> state;
    if (what != "robot" || id != r) continue;
    if (state != "merged") return false;
    *T = Iso::Identity();
    for (int i = 0; i < 3; ++i) {
      for (int c = 0; c < 4; ++c) s >> T->matrix()(i, c);
    }
    return static_cast<bool>(s);
  }
  return false;
}

double AngleDeg(const Iso& a, const Iso& b) { return commerge::RotationAngleRad((a.inverse() * b).linear()) * 180.0 / 3.141592653589793; }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: bench_rigid_floor SIMDIR SERVER_OUT\n");
    return 2;
  }
  const std::string data = argv[1], out = argv[2];
  auto starts = commerge::platform::ReadKittiPoses(data + "/start_transforms.txt");
  auto gt0 = commerge::platform::ReadKittiPoses(data + "/robot_0/poses_gt.txt");
  auto est0 = commerge::platform::ReadTumPoses(out + "/trajectories/robot_0_world.tum");
  for (const commerge::Status& st : {starts.status(), gt0.status(), est0.status()}) {
    if (!st.ok()) {
      std::fprintf(stderr, "bench_rigid_floor: %s\n", st.message().c_str());
      return 1;
    }
  }
  constexpr double kNearM = 1.0;
  for (int r = 1; r < static_cast<int>(starts->size()); ++r) {
    const std::string robot = "robot_" + std::to_string(r);
    auto gtr = commerge::platform::ReadKittiPoses(data + "/" + robot + "/poses_gt.txt");
    auto estr = commerge::platform::ReadTumPoses(out + "/trajectories/" + robot + "_world.tum");
    Iso T_world_map;
    if (!gtr.ok() || !estr.ok() || !ReadWorldMap(out + "/transforms.txt", r, &T_world_map)) {
      std::printf("robot %d: not merged (or its files are missing)\n", r);
      continue;
    }
    const Iso T_true = (*starts)[0].inverse() * (*starts)[static_cast<std::size_t>(r)];
    std::vector<Eigen::Vector3d> source, target;
    for (std::size_t j = 0; j < gtr->size() && j < estr->size(); j += 5) {
      const Eigen::Vector3d p_true = T_true * (*gtr)[j].translation();  // robot 0's start frame
      double best = kNearM;
      std::size_t k_best = gt0->size();
      for (std::size_t k = 0; k < gt0->size() && k < est0->size(); ++k) {
        const double d = ((*gt0)[k].translation() - p_true).norm();
        if (d < best) {
          best = d;
          k_best = k;
        }
      }
      if (k_best == gt0->size()) continue;
      source.push_back((T_world_map.inverse() * (*estr)[j].T_frame_sensor).translation());
      target.push_back((*est0)[k_best].T_frame_sensor.translation() + (p_true - (*gt0)[k_best].translation()));
    }
    auto fit = commerge::AlignRigid(Span<const Eigen::Vector3d>(source), Span<const Eigen::Vector3d>(target));
    if (!fit.ok()) {
      std::printf("robot %d: %zu shared keyframes: %s\n", r, source.size(), fit.status().message().c_str());
      continue;
    }
    // A registration sees one place: the fits over every run of kWindow consecutive shared keyframes, and the
    // one nearest the truth.
    constexpr std::size_t kWindow = 40;
    double best_local_m = -1.0, best_local_deg = 0.0;
    for (std::size_t i = 0; i + kWindow <= source.size(); i += kWindow / 4) {
      auto local = commerge::AlignRigid(Span<const Eigen::Vector3d>(source.data() + i, kWindow),
                                        Span<const Eigen::Vector3d>(target.data() + i, kWindow));
      if (!local.ok()) continue;
      const double e = (local->translation() - T_true.translation()).norm();
      if (best_local_m < 0.0 || e < best_local_m) {
        best_local_m = e;
        best_local_deg = AngleDeg(T_true, *local);
      }
    }
    std::printf("robot %d: %zu shared keyframes; the best rigid fit of the two maps there is %.3f m / %.3f deg from "
                "the truth, over %zu of them at one place at best %.3f m / %.3f deg; the server's transform "
                "%.3f m / %.3f deg\n",
                r, source.size(), (fit->translation() - T_true.translation()).norm(), AngleDeg(T_true, *fit),
                kWindow, best_local_m, best_local_deg, (T_world_map.translation() - T_true.translation()).norm(),
                AngleDeg(T_true, T_world_map));
  }
  return 0;
}
