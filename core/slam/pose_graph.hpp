// SPDX-License-Identifier: BSD-3-Clause
// commerge: SE(3) pose graph of one robot's keyframes (paper, section "Intra-Robot SLAM for Local Mapping").
//
// Nodes are keyframe poses T_map_node (map = the robot's own map frame), numbered 0..N-1 in insertion order. An
// edge (from, to) measures T_from_to with an information matrix Omega (6x6, twist order [rho; phi] as in
// core/geometry/se3.hpp). Its residual is
//     e = LogSE3(T_from_to^-1 * T_map_from^-1 * T_map_to) = (T_from^-1 T_to) [-] T_from_to
// and the cost is sum_edges rho(e^T Omega e), with rho(s) = s unless a robust kernel is set for loop edges.
// Optimize() runs Levenberg-Marquardt on right perturbations T <- T * ExpSE3(delta) with analytic Jacobians
// and a sparse Cholesky (LDL^T) factorisation. Node 0 is held fixed (gauge).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

enum class EdgeKind : std::uint8_t {
  kOdometry,  ///< between consecutive keyframes
  kLoop,      ///< loop closure (descriptor match verified by ICP); the robust kernel applies to these only
};

enum class RobustKernel : std::uint8_t {
  kNone,    ///< rho(s) = s (least squares)
  kHuber,   ///< rho(s) = s for s <= k^2, else 2 k sqrt(s) - k^2
  kCauchy,  ///< rho(s) = k^2 log(1 + s / k^2)
};

struct PoseGraphParams {
  /// Most Levenberg-Marquardt iterations (linearisations); >= 0.
  int max_iterations = 20;
  /// Converged when the largest component of a step is below this [m or rad]; >= 0.
  double convergence_step = 1e-6;
  /// Converged when an accepted step lowers the cost by less than this fraction of it; >= 0.
  double relative_cost_tolerance = 1e-10;
  /// Initial damping lambda: the normal equations are solved with H_ii * (1 + lambda) on the diagonal; > 0.
  double lm_initial_lambda = 1e-4;
  /// Kernel applied to loop edges (odometry edges always use least squares).
  RobustKernel loop_kernel = RobustKernel::kNone;
  /// Kernel width k on the Mahalanobis distance sqrt(e^T Omega e) [unitless]; > 0.
  double loop_kernel_width = 3.0;
  /// A node is reported in PoseGraphResult::changed_nodes when Optimize() moved it by more than this [m] ...
  double changed_translation_m = 0.01;
  /// ... or rotated it by more than this [rad] (0.1 deg).
  double changed_rotation_rad = 0.1 * kPi / 180.0;
};

struct PoseGraphEdge {
  std::uint32_t from = 0;  ///< node index
  std::uint32_t to = 0;    ///< node index, != from
  /// Measured pose of node `to` in the frame of node `from`.
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();
  /// Information (inverse covariance) of the measurement, twist order [rho; phi]; symmetric PSD.
  Matrix6d information = Matrix6d::Identity();
  EdgeKind kind = EdgeKind::kOdometry;
};

struct PoseGraphResult {
  int iterations = 0;         ///< linearisations performed
  double initial_cost = 0.0;  ///< cost before Optimize() (see the file comment)
  double final_cost = 0.0;    ///< cost after Optimize(); never above initial_cost
  bool converged = false;     ///< a stopping criterion was met before max_iterations (or nothing to do)
  /// Nodes whose pose moved by more than changed_translation_m or changed_rotation_rad, ascending: the poses
  /// the robot has to send as a pose update.
  std::vector<std::uint32_t> changed_nodes;
  /// Bytes held by the solver workspace after this call (sparse system and factor, trial poses).
  std::size_t workspace_bytes = 0;
};

/// Residual of one edge, e = LogSE3(T_from_to^-1 * T_map_from^-1 * T_map_to), and optionally its
/// Jacobians with respect to right perturbations of the two poses (T_map_x <- T_map_x * ExpSE3(d_x)):
///   J_to = RightJacobianInverseSE3(e),  J_from = -J_to * AdjointSE3(T_map_to^-1 * T_map_from).
Vector6d PoseGraphEdgeResidual(const Eigen::Isometry3d& T_map_from, const Eigen::Isometry3d& T_map_to,
                               const Eigen::Isometry3d& T_from_to, Matrix6d* J_from = nullptr,
                               Matrix6d* J_to = nullptr);

/// One robot's pose graph, with node and edge capacities fixed at construction (the memory budget). The
/// solver workspace (sparse system and LDL^T factor, ~2.4 kB per node on looped 1 m-keyframe trajectories;
/// PoseGraphResult::workspace_bytes) is allocated by Optimize() and reused by later calls, growing only with
/// the graph. Movable (a moved-from graph may only be destroyed or assigned to), not copyable, not thread-safe.
class PoseGraph {
 public:
  /// Reserves storage for `max_nodes` nodes and `max_edges` edges (start-up allocation).
  PoseGraph(std::size_t max_nodes, std::size_t max_edges);
  ~PoseGraph();
  PoseGraph(PoseGraph&&) noexcept;
  PoseGraph& operator=(PoseGraph&&) noexcept;
  PoseGraph(const PoseGraph&) = delete;
  PoseGraph& operator=(const PoseGraph&) = delete;

  /// Appends node num_nodes() with initial pose `T_map_node` (typically the previous pose composed with the
  /// odometry). Errors: resource exhausted when max_nodes nodes exist; invalid argument when the pose is not
  /// finite or its rotation is not orthonormal with det +1 (tolerance 1e-6).
  Status AddNode(const Eigen::Isometry3d& T_map_node);

  /// Appends an edge between existing nodes. Errors: resource exhausted when max_edges edges exist; invalid
  /// argument (naming the edge) when an index is out of range, from == to, T_from_to is not finite or not
  /// rigid, or the information matrix is not finite, symmetric and positive semi-definite.
  Status AddEdge(const PoseGraphEdge& edge);

  /// Optimises all poses except node 0 (held fixed) and reports which nodes moved. With 0 or 1 nodes, or when
  /// the cost is already 0, returns converged with no iterations. Errors (invalid argument, graph unchanged):
  /// a parameter out of range; a node not connected to node 0 by a chain of edges (named in the message);
  /// too large a system for 32-bit sparse indices (resource exhausted). If no step lowers the cost, returns
  /// converged = false with the best poses found.
  Result<PoseGraphResult> Optimize(const PoseGraphParams& params = {});

  /// Current cost sum rho(e^T Omega e) under `params`' kernel.
  double Cost(const PoseGraphParams& params = {}) const;

  /// Pose of node i (precondition: i < num_nodes()).
  const Eigen::Isometry3d& pose(std::size_t i) const { return poses_[i]; }
  Span<const Eigen::Isometry3d> poses() const { return Span<const Eigen::Isometry3d>(poses_.data(), poses_.size()); }
  /// Edge i in insertion order (precondition: i < num_edges()).
  const PoseGraphEdge& edge(std::size_t i) const { return edges_[i]; }
  std::size_t num_nodes() const { return poses_.size(); }
  std::size_t num_edges() const { return edges_.size(); }
  std::size_t num_loop_edges() const { return num_loop_edges_; }
  std::size_t max_nodes() const { return max_nodes_; }
  std::size_t max_edges() const { return max_edges_; }
  /// Bytes the solver workspace holds now (as PoseGraphResult::workspace_bytes; 0 before the first Optimize()).
  std::size_t workspace_bytes() const;

 private:
  struct Workspace;

  double CostOf(Span<const Eigen::Isometry3d> poses, const PoseGraphParams& params) const;
  Status CheckConnected();
  Status BuildPattern();
  void Linearize(const PoseGraphParams& params);

  std::size_t max_nodes_ = 0;
  std::size_t max_edges_ = 0;
  std::size_t num_loop_edges_ = 0;
  std::vector<Eigen::Isometry3d> poses_;
  std::vector<PoseGraphEdge> edges_;
  std::unique_ptr<Workspace> ws_;
};

}  // namespace commerge
