// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/synthetic_team.hpp"

#include <cmath>
#include <utility>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

Eigen::Isometry3d RandomPerturbation(SimRandom& rng, double sigma_m, double sigma_deg) {
  Vector6d xi;
  for (int i = 0; i < 3; ++i) xi(i) = sigma_m * rng.Gaussian();
  for (int i = 3; i < 6; ++i) xi(i) = sigma_deg * kDegToRad * rng.Gaussian();
  return ExpSE3(xi);
}

Eigen::Isometry3d PlanarPose(double x, double y, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

namespace {

Eigen::Isometry3d RoutePose(const SyntheticTeamParams& p, double s, double lateral_m, bool backwards) {
  const double heading =
      std::atan2(p.route_amplitude_m / p.route_wavelength_m * std::cos(s / p.route_wavelength_m), 1.0);
  const Eigen::Vector2d left(-std::sin(heading), std::cos(heading));
  const Eigen::Vector2d at = Eigen::Vector2d(s, p.route_amplitude_m * std::sin(s / p.route_wavelength_m)) + lateral_m * left;
  return PlanarPose(at.x(), at.y(), backwards ? heading + kPi : heading);
}

}  // namespace

SyntheticTeam MakeSyntheticTeam(const SyntheticTeamParams& p) {
  SimRandom rng(p.seed);
  SyntheticTeam team;
  const int n = p.keyframes;
  for (int r = 0; r < p.robots; ++r) {
    const bool back = r % 2 == 1;
    const double start = back ? n - 1.0 : 40.0 * r;
    std::vector<Eigen::Isometry3d> truth, map;
    for (int k = 0; k < n; ++k) truth.push_back(RoutePose(p, back ? start - k : start + k, back ? 1.0 : 0.0, back));
    const Eigen::Isometry3d bias = PlanarPose(0.0, 0.0, (back ? -1.0 : 1.0) * p.yaw_bias_deg_per_m * kDegToRad);
    map.push_back(Eigen::Isometry3d::Identity());
    for (std::size_t k = 1; k < truth.size(); ++k) {
      map.push_back(map.back() * truth[k - 1].inverse() * truth[k] * bias * RandomPerturbation(rng, p.step_noise_m, p.step_noise_deg));
    }
    team.T_gt_keyframe.push_back(std::move(truth));
    team.T_map_keyframe.push_back(std::move(map));
  }
  for (int a = 0; a < p.robots; ++a) {
    for (int b = a + 1; b < p.robots; ++b) {
      const auto& A = team.T_gt_keyframe[static_cast<std::size_t>(a)];
      const auto& B = team.T_gt_keyframe[static_cast<std::size_t>(b)];
      for (std::size_t i = 0; i < A.size(); i += static_cast<std::size_t>(p.edge_every)) {
        std::size_t best = B.size();
        double best_d = p.edge_max_distance_m;
        for (std::size_t j = 0; j < B.size(); ++j) {
          const double d = (A[i].translation() - B[j].translation()).norm();
          if (d < best_d) {
            best_d = d;
            best = j;
          }
        }
        if (best == B.size()) continue;
        InterRobotEdge e;
        e.robot_a = a;
        e.robot_b = b;
        e.keyframe_a = static_cast<std::uint32_t>(i);
        e.keyframe_b = static_cast<std::uint32_t>(best);
        e.T_a_b = A[i].inverse() * B[best] * RandomPerturbation(rng, p.edge_noise_m, p.edge_noise_deg);
        team.right_edges.push_back(e);
      }
    }
  }
  return team;
}

std::vector<InterRobotEdge> MakeWrongEdges(const SyntheticTeam& team, std::size_t count, std::uint32_t seed) {
  SimRandom rng(seed);
  const std::uint64_t robots = team.T_gt_keyframe.size();
  std::vector<InterRobotEdge> out;
  for (int attempt = 0; out.size() < count && attempt < 1000000; ++attempt) {
    InterRobotEdge e;
    e.robot_a = static_cast<int>(rng.Below(robots));
    e.robot_b = static_cast<int>(rng.Below(robots));
    if (e.robot_a == e.robot_b) continue;
    const auto& A = team.T_gt_keyframe[static_cast<std::size_t>(e.robot_a)];
    const auto& B = team.T_gt_keyframe[static_cast<std::size_t>(e.robot_b)];
    e.keyframe_a = static_cast<std::uint32_t>(rng.Below(A.size()));
    e.keyframe_b = static_cast<std::uint32_t>(rng.Below(B.size()));
    const double apart_m = (A[e.keyframe_a].translation() - B[e.keyframe_b].translation()).norm();
    const double dir = rng.Uniform(-kPi, kPi);
    if (out.size() % 2 == 0) {
      // A look-alike place: keyframes more than 20 m apart, registered as if they were within a few metres.
      if (apart_m <= 20.0) continue;
      const double d = rng.Uniform(0.0, 5.0);
      e.T_a_b = PlanarPose(d * std::cos(dir), d * std::sin(dir), rng.Uniform(-kPi, kPi));
    } else {
      // The right place, a wrong transform: keyframes within 10 m, the truth's relative pose 3-15 m and any yaw off.
      if (apart_m > 10.0) continue;
      const double d = rng.Uniform(3.0, 15.0);
      e.T_a_b = A[e.keyframe_a].inverse() * B[e.keyframe_b] * PlanarPose(d * std::cos(dir), d * std::sin(dir), rng.Uniform(-kPi, kPi));
    }
    out.push_back(e);
  }
  return out;
}

}  // namespace commerge
