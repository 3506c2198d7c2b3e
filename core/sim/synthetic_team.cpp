// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/synthetic_team.hpp"

#include <cmath>
#include <random>
#include <utility>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {
namespace {

Eigen::Isometry3d Noise(std::mt19937& rng, double sigma_m, double sigma_deg) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  xi << sigma_m * n(rng), sigma_m * n(rng), sigma_m * n(rng), sigma_deg * kDegToRad * n(rng),
      sigma_deg * kDegToRad * n(rng), sigma_deg * kDegToRad * n(rng);
  return ExpSE3(xi);
}

Eigen::Isometry3d PlanarPose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

Eigen::Isometry3d RoutePose(const SyntheticTeamParams& p, double s, double lateral_m, bool backwards) {
  const double heading =
      std::atan2(p.route_amplitude_m / p.route_wavelength_m * std::cos(s / p.route_wavelength_m), 1.0);
  const Eigen::Vector2d left(-std::sin(heading), std::cos(heading));
  const Eigen::Vector2d at = Eigen::Vector2d(s, p.route_amplitude_m * std::sin(s / p.route_wavelength_m)) + lateral_m * left;
  return PlanarPose(at.x(), at.y(), backwards ? heading + kPi : heading);
}

}  // namespace

SyntheticTeam MakeSyntheticTeam(const SyntheticTeamParams& p) {
  std::mt19937 rng(p.seed);
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
      map.push_back(map.back() * truth[k - 1].inverse() * truth[k] * bias * Noise(rng, p.step_noise_m, p.step_noise_deg));
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
        e.T_a_b = A[i].inverse() * B[best] * Noise(rng, p.edge_noise_m, p.edge_noise_deg);
        team.right_edges.push_back(e);
      }
    }
  }
  return team;
}

std::vector<InterRobotEdge> MakeWrongEdges(const SyntheticTeam& team, std::size_t count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const int robots = static_cast<int>(team.T_gt_keyframe.size());
  std::uniform_int_distribution<int> robot(0, robots - 1);
  std::uniform_real_distribution<double> near(0.0, 5.0), off(3.0, 15.0), angle(-kPi, kPi);
  std::vector<InterRobotEdge> out;
  for (int attempt = 0; out.size() < count && attempt < 1000000; ++attempt) {
    InterRobotEdge e;
    e.robot_a = robot(rng);
    e.robot_b = robot(rng);
    if (e.robot_a == e.robot_b) continue;
    const auto& A = team.T_gt_keyframe[static_cast<std::size_t>(e.robot_a)];
    const auto& B = team.T_gt_keyframe[static_cast<std::size_t>(e.robot_b)];
    e.keyframe_a = std::uniform_int_distribution<std::uint32_t>(0, static_cast<std::uint32_t>(A.size() - 1))(rng);
    e.keyframe_b = std::uniform_int_distribution<std::uint32_t>(0, static_cast<std::uint32_t>(B.size() - 1))(rng);
    const double apart_m = (A[e.keyframe_a].translation() - B[e.keyframe_b].translation()).norm();
    const double dir = angle(rng);
    if (out.size() % 2 == 0) {
      // A look-alike place: keyframes more than 20 m apart, registered as if they were within a few metres.
      if (apart_m <= 20.0) continue;
      const double d = near(rng);
      e.T_a_b = PlanarPose(d * std::cos(dir), d * std::sin(dir), angle(rng));
    } else {
      // The right place, a wrong transform: keyframes within 10 m, the truth's relative pose 3-15 m and any yaw off.
      if (apart_m > 10.0) continue;
      const double d = off(rng);
      e.T_a_b = A[e.keyframe_a].inverse() * B[e.keyframe_b] * PlanarPose(d * std::cos(dir), d * std::sin(dir), angle(rng));
    }
    out.push_back(e);
  }
  return out;
}

}  // namespace commerge
