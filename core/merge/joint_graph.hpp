// SPDX-License-Identifier: BSD-3-Clause
// commerge: the joint multi-robot pose graph (ours; issue 57). One SE(3) graph over every keyframe of the robots
// placed with robot 0: each robot's keyframe chain (relative poses of consecutive keyframes, from the poses it
// streamed, which already hold its own loop closures) and the inter-robot edges (a registration anchored at one
// keyframe of each robot; several per pair where the robots shared a long path). Solving it lets the robots'
// maps bend where their odometry drifted, where one rigid transform per robot cannot.
//
// Wrong inter-robot edges must not bend the team's map. Two defences, in order:
//  1. Pairwise consistency per robot pair: edges e = (a_i, b_j, T_e) and f = (a_k, b_l, T_f) agree when the cycle
//     a_i -> a_k (robot a's chain) -> b_l (T_f) -> b_j (robot b's chain) -> a_i (T_e^-1) closes within
//     consistency_m + drift_per_m * L and consistency_deg + drift_deg_per_m * L, L the chain length between the
//     two edges' keyframes on both robots. The heaviest set of mutually agreeing edges (maximum vertex-weighted
//     clique, each edge weighing its InterRobotEdge::weight; core/solvers/max_clique.hpp) is kept; a pair with several edges none of which agrees with another keeps
//     none (nothing verifies any); a pair with a single edge keeps it (as the rigid merge does).
//  2. The kept edges enter the graph with a Cauchy kernel (PoseGraph's loop kernel), chain edges by least squares,
//     after a least-squares pass over all of them from the rigid placement.
// The graph's nodes are every node_stride-th keyframe (and every used edge's anchor, each robot's last); the
// keyframes between take the SE(3) interpolation of their two nodes' corrections.
// Robots reached from robot 0 through kept edges are solved; the others are left out (empty trajectories). The
// gauge is robot 0's first keyframe, held where robot 0's map has it: the world frame is robot 0's map frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/slam/pose_graph.hpp"

namespace commerge {

/// One inter-robot measurement, anchored at one keyframe of each robot.
struct InterRobotEdge {
  int robot_a = 0;
  int robot_b = 1;
  std::uint32_t keyframe_a = 0;
  std::uint32_t keyframe_b = 0;
  /// Pose of keyframe_b in keyframe_a's frame: p_keyframe_a = T_a_b p_keyframe_b.
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  /// The edge's information is weight times that of JointGraphParams::edge_sigma_m / edge_sigma_deg; finite, > 0.
  double weight = 1.0;
};

/// The inter-robot edge a registration gives: T_mapa_mapb (p_mapa = T p_mapb) read at keyframe_a of robot a
/// (pose T_mapa_ka) and keyframe_b of robot b (pose T_mapb_kb): T_a_b = T_mapa_ka^-1 T_mapa_mapb T_mapb_kb.
InterRobotEdge EdgeFromMapTransform(int robot_a, std::uint32_t keyframe_a, const Eigen::Isometry3d& T_mapa_ka,
                                    int robot_b, std::uint32_t keyframe_b, const Eigen::Isometry3d& T_mapb_kb,
                                    const Eigen::Isometry3d& T_mapa_mapb);

/// The joint graph's solver: Levenberg-Marquardt with a Cauchy kernel of width 3 on the inter-robot edges.
inline PoseGraphParams DefaultJointSolverParams() {
  PoseGraphParams p;
  p.loop_kernel = RobustKernel::kCauchy;
  p.loop_kernel_width = 3.0;
  p.max_iterations = 30;
  p.convergence_step = 1e-3;
  p.relative_cost_tolerance = 1e-4;
  return p;
}

struct JointGraphParams {
  /// Standard deviations of a chain edge (consecutive keyframes of one robot) [m, deg]; > 0.
  double chain_sigma_m = 0.02;
  double chain_sigma_deg = 0.05;
  /// Standard deviations of an inter-robot edge [m, deg]; > 0.
  double edge_sigma_m = 0.1;
  double edge_sigma_deg = 0.5;
  /// Pairwise consistency (defence 1): the cycle's allowance at zero chain length [m, deg], > 0 ...
  double consistency_m = 0.5;
  double consistency_deg = 2.0;
  /// ... plus this much per metre of chain between the two edges' keyframes (odometry drift) [m/m, deg/m], >= 0.
  double drift_per_m = 0.02;
  double drift_deg_per_m = 0.02;
  /// Edges per robot pair at most (the consistency graph is dense: n^2 / 8 bytes), in [1, 4096].
  std::size_t max_edges_per_pair = 1024;
  /// Keyframes of all robots at most, >= 1.
  std::size_t max_nodes = 200000;
  /// The graph's nodes: every node_stride-th keyframe of each robot, its last and the used edges' anchors (>= 1; 1 =
  /// every keyframe). A chain edge spans the keyframes between two nodes (information divided by their count); a
  /// keyframe between nodes takes the SE(3) interpolation of its two nodes' corrections.
  std::size_t node_stride = 5;
  /// Solver; its loop_kernel / loop_kernel_width apply to the inter-robot edges (default Cauchy, width 3).
  PoseGraphParams solver = DefaultJointSolverParams();
};

/// InvalidArgument naming the first field out of range.
Status ValidateJointGraphParams(const JointGraphParams& params);

enum class JointEdgeVerdict : std::uint8_t {
  kUsed = 0,          ///< in its pair's largest agreeing set, and its robots are solved
  kInconsistent,      ///< outside its pair's largest agreeing set (or its pair's edges all disagree)
  kNotConnected,      ///< its pair's robots are not both reached from robot 0
};

const char* JointEdgeVerdictName(JointEdgeVerdict verdict) noexcept;

struct JointGraphResult {
  /// Per robot (the input's order): its keyframes' poses in the world frame (robot 0's map frame) after the
  /// solve; empty for a robot not reached from robot 0 through used edges.
  std::vector<std::vector<Eigen::Isometry3d>> T_world_keyframe;
  /// Per robot: the rigid placement T_world_map the solve started from (identity for robot 0; identity and
  /// placed false for a robot not reached).
  std::vector<Eigen::Isometry3d> T_world_map;
  std::vector<std::uint8_t> placed;
  /// Per input edge.
  std::vector<JointEdgeVerdict> verdicts;
  /// Per input edge: its whitened residual sqrt(e^T Omega e) after the solve (-1 when not used).
  std::vector<double> residuals;
  /// The solve (its iterations: both phases; initial_cost: before the first).
  PoseGraphResult solve;
  int least_squares_iterations = 0;  ///< of solve.iterations, those of the first phase (no kernel)
  std::size_t nodes = 0, chain_edges = 0, used_edges = 0;  ///< the graph's (nodes: see node_stride)
};

/// Solves the joint graph. `T_map_keyframe[r]`: robot r's keyframe poses in its own map frame (robot 0 first;
/// index = keyframe index). Errors (InvalidArgument, naming the value): bad params, no robot, an edge's robot or
/// keyframe out of range, robot_a == robot_b, a non-finite or non-rigid pose or edge, a weight not finite and > 0;
/// ResourceExhausted: more
/// keyframes than max_nodes or more edges in a pair than max_edges_per_pair (counts named). The solver's own
/// errors are passed on.
Result<JointGraphResult> SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe,
                                         Span<const InterRobotEdge> edges, const JointGraphParams& params = {});

}  // namespace commerge
