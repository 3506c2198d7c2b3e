// SPDX-License-Identifier: BSD-3-Clause
// commerge: a synthetic team for the joint pose graph (core/merge/joint_graph.hpp), its tests and benchmark: robots
// walking one winding route (x = s, y = A sin(s / W), z = 0, heading along it), keyframes 1 m apart. Robot 0 starts at
// s = 0; odd robots walk it backwards from s = keyframes - 1, 1 m to its left; even robots r > 0 start at s = 40 r.
// Each robot's map (its odometry from identity) chains the true steps times a yaw bias (+bias for even robots, -bias
// for odd) and noise; inter-robot edges are the truth's relative poses with noise, every `edge_every` keyframes of
// each pair's lower robot to the other's nearest keyframe within edge_max_distance_m. Wrong edges, alternately: a
// look-alike place (random keyframes of a random pair more than 20 m apart, related by a transform within 5 m and any
// yaw, as a registration of two alike places gives) and the right place with a wrong transform (keyframes within
// 10 m, 3-15 m and any yaw off the truth). Deterministic in the seed with every standard library (SimRandom).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/merge/joint_graph.hpp"
#include "core/sim/sim_random.hpp"

namespace commerge {

struct SyntheticTeamParams {
  int robots = 3;
  int keyframes = 300;
  double route_amplitude_m = 20.0;
  double route_wavelength_m = 30.0;
  double yaw_bias_deg_per_m = 0.005;
  double step_noise_m = 0.005;
  double step_noise_deg = 0.01;
  int edge_every = 15;
  double edge_max_distance_m = 3.0;
  double edge_noise_m = 0.02;
  double edge_noise_deg = 0.1;
  std::uint32_t seed = 1;
};

struct SyntheticTeam {
  std::vector<std::vector<Eigen::Isometry3d>> T_gt_keyframe;   ///< per robot, the truth
  std::vector<std::vector<Eigen::Isometry3d>> T_map_keyframe;  ///< per robot, its drifted map
  std::vector<InterRobotEdge> right_edges;
};

/// ExpSE3 of a twist with independent normal components: sigma_m per axis [m], sigma_deg per axis [deg].
Eigen::Isometry3d RandomPerturbation(SimRandom& rng, double sigma_m, double sigma_deg);

/// The pose at (x, y, 0) turned by yaw_rad about z.
Eigen::Isometry3d PlanarPose(double x, double y, double yaw_rad);

/// The team (precondition: robots >= 2, keyframes >= 2, edge_every >= 1).
SyntheticTeam MakeSyntheticTeam(const SyntheticTeamParams& params);

/// `count` wrong edges for `team` (fewer when a million draws do not find them), deterministic in `seed`.
std::vector<InterRobotEdge> MakeWrongEdges(const SyntheticTeam& team, std::size_t count, std::uint32_t seed);

}  // namespace commerge
