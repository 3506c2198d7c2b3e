// SPDX-License-Identifier: BSD-3-Clause
// Pose-graph optimisation (paper eq. "pose graph optimization"): Levenberg-Marquardt over right perturbations,
// normal equations H dx = -b assembled block-wise into a fixed sparse pattern, sparse LDL^T.
//
// The system has one 6x6 block row/column per free node (every node but node 0). Once per Optimize() call the
// free nodes are ordered by approximate minimum degree on the node graph (fill-reducing, and 36x smaller than
// ordering the scalar matrix), the pattern (upper triangle: diagonal blocks plus one block per edge between
// free nodes) is laid out in that order and analysed symbolically. Each iteration then only refills the values
// in place and refactorises numerically; because the matrix is already permuted, Eigen factorises it without
// copying it.
#include "core/slam/pose_graph.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/OrderingMethods>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <utility>

#include "core/common/number_text.hpp"

namespace commerge {
// Types held by PoseGraph::Workspace: a named namespace, because a class member may not use a type of an
// anonymous namespace when this file is compiled inside a unity batch.
namespace pose_graph_detail {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// LDL^T of a matrix that is already in fill-reducing order. Eigen's public analyzePattern() copies the matrix
// twice (a symmetric copy for the ordering, then the permuted copy) even with NaturalOrdering; the symbolic
// analysis proper (protected, stable since Eigen 3.2) needs neither. With no permutation set, factorize()
// reads the upper triangle in place.
class PreorderedLdlt : public Eigen::SimplicialLDLT<SparseMatrix, Eigen::Upper, Eigen::NaturalOrdering<int>> {
 public:
  void AnalyzePreordered(const SparseMatrix& upper) {
    m_P.resize(0);
    m_Pinv.resize(0);
    analyzePattern_preordered(upper, /*doLDLT=*/true);
  }
};

// A 6x6 block of H: entry (i, j) lives at values[outer[column + j] + offset + i]. Diagonal blocks store only
// their upper triangle (i <= j).
struct BlockSlot {
  int column = -1;  // first scalar column of the block, -1: no block
  int offset = 0;   // 6 * (position of the block among its column's blocks)
};

}  // namespace pose_graph_detail

namespace {

using pose_graph_detail::BlockSlot;
using pose_graph_detail::PreorderedLdlt;
using pose_graph_detail::SparseMatrix;

constexpr double kMaxLambda = 1e12;
constexpr double kMinLambda = 1e-12;
constexpr double kMinDiagonal = 1e-12;  // damping floor for an information-free direction

std::string EdgeName(std::size_t index, const PoseGraphEdge& e) {
  return "pose graph: edge " + std::to_string(index) + " (" + std::to_string(e.from) + " -> " +
         std::to_string(e.to) + (e.kind == EdgeKind::kLoop ? ", loop)" : ", odometry)");
}

// rho(s) and rho'(s) of the kernel at squared Mahalanobis distance s.
double KernelCost(RobustKernel kernel, double k, double s) {
  switch (kernel) {
    case RobustKernel::kHuber: return s <= k * k ? s : 2.0 * k * std::sqrt(s) - k * k;
    case RobustKernel::kCauchy: return k * k * std::log1p(s / (k * k));
    case RobustKernel::kNone: break;
  }
  return s;
}

double KernelWeight(RobustKernel kernel, double k, double s) {
  switch (kernel) {
    case RobustKernel::kHuber: return s <= k * k ? 1.0 : k / std::sqrt(s);
    case RobustKernel::kCauchy: return 1.0 / (1.0 + s / (k * k));
    case RobustKernel::kNone: break;
  }
  return 1.0;
}

template <bool kUpperOnly>
void AddBlock(double* values, const int* outer, BlockSlot slot, const Matrix6d& block) {
  for (int j = 0; j < 6; ++j) {
    double* column = values + outer[slot.column + j] + slot.offset;
    for (int i = 0; i < (kUpperOnly ? j + 1 : 6); ++i) column[i] += block(i, j);
  }
}

std::uint32_t FindRoot(std::vector<std::uint32_t>& parent, std::uint32_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];  // path halving
  return i;
}

Status ValidateParams(const PoseGraphParams& p) {
  const auto bad = [](const char* name, double value, const char* range) {
    return InvalidArgument(std::string("pose graph: ") + name + " must be " + range + ", got " +
                           FormatNumber(value, 6));
  };
  if (p.max_iterations < 0) return bad("max_iterations", p.max_iterations, ">= 0");
  if (!(p.convergence_step >= 0.0) || !std::isfinite(p.convergence_step)) {
    return bad("convergence_step", p.convergence_step, "finite and >= 0");
  }
  if (!(p.relative_cost_tolerance >= 0.0) || !std::isfinite(p.relative_cost_tolerance)) {
    return bad("relative_cost_tolerance", p.relative_cost_tolerance, "finite and >= 0");
  }
  if (!(p.lm_initial_lambda > 0.0) || !std::isfinite(p.lm_initial_lambda)) {
    return bad("lm_initial_lambda", p.lm_initial_lambda, "finite and > 0");
  }
  if (!(p.loop_kernel_width > 0.0) || !std::isfinite(p.loop_kernel_width)) {
    return bad("loop_kernel_width", p.loop_kernel_width, "finite and > 0");
  }
  if (!(p.changed_translation_m >= 0.0)) return bad("changed_translation_m", p.changed_translation_m, ">= 0");
  if (!(p.changed_rotation_rad >= 0.0)) return bad("changed_rotation_rad", p.changed_rotation_rad, ">= 0");
  return Status::Ok();
}

}  // namespace

struct PoseGraph::Workspace {
  SparseMatrix H;  // J^T W J over the free nodes in block order, upper triangle
  PreorderedLdlt solver;
  Eigen::VectorXd b;         // J^T W e
  Eigen::VectorXd dx;        // step
  Eigen::VectorXd diagonal;  // undamped diagonal of H
  std::vector<int> block_of;                  // free node (node - 1) -> block index in H
  std::vector<int> diagonal_index;            // position of H(v, v) in H.valuePtr()
  std::vector<BlockSlot> diagonal_slots;      // per block
  std::vector<BlockSlot> edge_slots;          // per edge: its off-diagonal block (column -1 if none)
  std::vector<std::pair<int, int>> blocks;    // (column, row) block coordinates, row <= column, sorted
  std::vector<std::uint32_t> parent;          // union-find
  std::vector<Eigen::Isometry3d> initial;     // poses before Optimize()
  std::vector<Eigen::Isometry3d> trial;       // poses after a candidate step
  std::size_t factor_nnz = 0;                 // non-zeros of the last LDL^T factor

  std::size_t Bytes() const {
    const auto nnz = static_cast<std::size_t>(H.nonZeros());
    const auto n = static_cast<std::size_t>(H.cols());
    // H and the factor L: values + inner indices; outer indices, D, b, dx, diagonal, solver's per-column arrays.
    return (nnz + factor_nnz) * (sizeof(double) + sizeof(int)) + n * (4 * sizeof(int) + 4 * sizeof(double)) +
           (block_of.capacity() + diagonal_index.capacity()) * sizeof(int) +
           (diagonal_slots.capacity() + edge_slots.capacity()) * sizeof(BlockSlot) +
           blocks.capacity() * sizeof(blocks[0]) + parent.capacity() * sizeof(std::uint32_t) +
           (initial.capacity() + trial.capacity()) * sizeof(Eigen::Isometry3d);
  }
};

Vector6d PoseGraphEdgeResidual(const Eigen::Isometry3d& T_map_from, const Eigen::Isometry3d& T_map_to,
                               const Eigen::Isometry3d& T_from_to, Matrix6d* J_from, Matrix6d* J_to) {
  const Eigen::Isometry3d T_to_from = T_map_to.inverse() * T_map_from;
  const Vector6d e = LogSE3(T_from_to.inverse() * T_to_from.inverse());
  if (J_from != nullptr || J_to != nullptr) {
    const Matrix6d jr_inv = RightJacobianInverseSE3(e);
    if (J_to != nullptr) *J_to = jr_inv;
    if (J_from != nullptr) *J_from = -jr_inv * AdjointSE3(T_to_from);
  }
  return e;
}

PoseGraph::PoseGraph(std::size_t max_nodes, std::size_t max_edges)
    : max_nodes_(max_nodes), max_edges_(max_edges), ws_(std::make_unique<Workspace>()) {
  poses_.reserve(max_nodes);
  edges_.reserve(max_edges);
}

PoseGraph::~PoseGraph() = default;

std::size_t PoseGraph::workspace_bytes() const { return ws_ ? ws_->Bytes() : 0; }
PoseGraph::PoseGraph(PoseGraph&&) noexcept = default;
PoseGraph& PoseGraph::operator=(PoseGraph&&) noexcept = default;

Status PoseGraph::AddNode(const Eigen::Isometry3d& T_map_node) {
  if (poses_.size() >= max_nodes_) {
    return ResourceExhausted("pose graph: node capacity " + std::to_string(max_nodes_) + " reached");
  }
  if (!IsValidRigidTransform(T_map_node)) {
    return InvalidArgument("pose graph: node " + std::to_string(poses_.size()) +
                           ": pose is not finite or its rotation is not orthonormal");
  }
  poses_.push_back(T_map_node);
  return Status::Ok();
}

Status PoseGraph::AddEdge(const PoseGraphEdge& e) {
  const std::size_t index = edges_.size();
  if (index >= max_edges_) {
    return ResourceExhausted(EdgeName(index, e) + ": edge capacity " + std::to_string(max_edges_) + " reached");
  }
  if (e.from >= poses_.size() || e.to >= poses_.size()) {
    return InvalidArgument(EdgeName(index, e) + ": node index out of range (" + std::to_string(poses_.size()) +
                           " nodes)");
  }
  if (e.from == e.to) return InvalidArgument(EdgeName(index, e) + ": connects a node to itself");
  if (!IsValidRigidTransform(e.T_from_to)) {
    return InvalidArgument(EdgeName(index, e) + ": T_from_to is not finite or its rotation is not orthonormal");
  }
  const Matrix6d& omega = e.information;
  if (!omega.allFinite()) return InvalidArgument(EdgeName(index, e) + ": information matrix is not finite");
  const double scale = std::max(1.0, omega.cwiseAbs().maxCoeff());
  if ((omega - omega.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return InvalidArgument(EdgeName(index, e) + ": information matrix is not symmetric");
  }
  const double min_eigenvalue =
      Eigen::SelfAdjointEigenSolver<Matrix6d>(omega, Eigen::EigenvaluesOnly).eigenvalues()(0);
  if (min_eigenvalue < -1e-9 * scale) {
    return InvalidArgument(EdgeName(index, e) + ": information matrix is not positive semi-definite (eigenvalue " +
                           FormatNumber(min_eigenvalue, 6) + ")");
  }
  edges_.push_back(e);
  if (e.kind == EdgeKind::kLoop) ++num_loop_edges_;
  return Status::Ok();
}

double PoseGraph::Cost(const PoseGraphParams& params) const { return CostOf(poses(), params); }

double PoseGraph::CostOf(Span<const Eigen::Isometry3d> poses, const PoseGraphParams& params) const {
  double cost = 0.0;
  for (const PoseGraphEdge& e : edges_) {
    const Vector6d r = PoseGraphEdgeResidual(poses[e.from], poses[e.to], e.T_from_to);
    const double s = r.dot(e.information * r);
    cost += e.kind == EdgeKind::kLoop ? KernelCost(params.loop_kernel, params.loop_kernel_width, s) : s;
  }
  return cost;
}

Status PoseGraph::CheckConnected() {
  std::vector<std::uint32_t>& parent = ws_->parent;
  parent.resize(poses_.size());
  for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  for (const PoseGraphEdge& e : edges_) parent[FindRoot(parent, e.from)] = FindRoot(parent, e.to);
  const std::uint32_t root = FindRoot(parent, 0);
  for (std::uint32_t i = 1; i < parent.size(); ++i) {
    if (FindRoot(parent, i) != root) {
      return InvalidArgument("pose graph: node " + std::to_string(i) +
                             " is not connected to node 0 by any chain of edges (missing odometry edge?)");
    }
  }
  return Status::Ok();
}

Status PoseGraph::BuildPattern() {
  Workspace& ws = *ws_;
  const int free_nodes = static_cast<int>(poses_.size() - 1);
  const std::size_t max_blocks = static_cast<std::size_t>(free_nodes) + edges_.size();
  if (max_blocks * 36 > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    return ResourceExhausted("pose graph: " + std::to_string(max_blocks) +
                             " blocks exceed the 32-bit sparse index range");
  }
  // 1. Fill-reducing order of the free nodes: AMD on the node graph (free node = node - 1).
  {
    std::vector<Eigen::Triplet<double, int>> pattern;
    pattern.reserve(max_blocks);
    for (int c = 0; c < free_nodes; ++c) pattern.emplace_back(c, c, 1.0);
    for (const PoseGraphEdge& e : edges_) {
      if (e.from != 0 && e.to != 0) {
        pattern.emplace_back(static_cast<int>(std::min(e.from, e.to)) - 1, static_cast<int>(std::max(e.from, e.to)) - 1,
                             1.0);
      }
    }
    SparseMatrix node_graph(free_nodes, free_nodes);
    node_graph.setFromTriplets(pattern.begin(), pattern.end());
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> order;  // order(k) = free node eliminated k-th
    Eigen::AMDOrdering<int>()(node_graph, order);
    ws.block_of.resize(static_cast<std::size_t>(free_nodes));
    for (int k = 0; k < free_nodes; ++k) ws.block_of[static_cast<std::size_t>(order.indices()(k))] = k;
  }
  const auto block = [&](std::uint32_t node) { return ws.block_of[node - 1]; };

  // 2. Block coordinates (column, row), row <= column: every diagonal block and one per edge between free nodes.
  ws.blocks.clear();
  ws.blocks.reserve(max_blocks);
  for (int c = 0; c < free_nodes; ++c) ws.blocks.emplace_back(c, c);
  for (const PoseGraphEdge& e : edges_) {
    if (e.from == 0 || e.to == 0) continue;
    ws.blocks.emplace_back(std::max(block(e.from), block(e.to)), std::min(block(e.from), block(e.to)));
  }
  std::sort(ws.blocks.begin(), ws.blocks.end());
  ws.blocks.erase(std::unique(ws.blocks.begin(), ws.blocks.end()), ws.blocks.end());

  // 3. Scalar pattern: in block column c, scalar column 6c + j holds 6 rows per off-diagonal block, then rows
  //    6c .. 6c + j of the diagonal block (the last block of its column).
  const int n = 6 * free_nodes;
  const std::size_t off_diagonal = ws.blocks.size() - static_cast<std::size_t>(free_nodes);
  ws.H.resize(n, n);
  ws.H.resizeNonZeros(static_cast<Eigen::Index>(36 * off_diagonal + 21 * static_cast<std::size_t>(free_nodes)));
  int* outer = ws.H.outerIndexPtr();
  int* inner = ws.H.innerIndexPtr();
  ws.diagonal_slots.assign(static_cast<std::size_t>(free_nodes), BlockSlot{});
  ws.diagonal_index.resize(static_cast<std::size_t>(n));
  int nnz = 0;
  for (std::size_t first = 0; first < ws.blocks.size();) {
    const int c = ws.blocks[first].first;
    std::size_t last = first;
    while (last < ws.blocks.size() && ws.blocks[last].first == c) ++last;
    const std::size_t num_off_diagonal = last - 1 - first;  // the column's last block is the diagonal one
    const int diagonal_offset = static_cast<int>(6 * num_off_diagonal);
    for (int j = 0; j < 6; ++j) {
      outer[6 * c + j] = nnz;
      for (std::size_t t = 0; t < num_off_diagonal; ++t) {
        const int row = 6 * ws.blocks[first + t].second;
        for (int i = 0; i < 6; ++i) inner[nnz++] = row + i;
      }
      for (int i = 0; i <= j; ++i) inner[nnz++] = 6 * c + i;
      ws.diagonal_index[static_cast<std::size_t>(6 * c + j)] = nnz - 1;
    }
    ws.diagonal_slots[static_cast<std::size_t>(c)] = BlockSlot{6 * c, diagonal_offset};
    first = last;
  }
  outer[n] = nnz;

  ws.edge_slots.assign(edges_.size(), BlockSlot{});
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    const PoseGraphEdge& e = edges_[k];
    if (e.from == 0 || e.to == 0) continue;
    const std::pair<int, int> key(std::max(block(e.from), block(e.to)), std::min(block(e.from), block(e.to)));
    const auto column_start = std::lower_bound(ws.blocks.begin(), ws.blocks.end(), std::make_pair(key.first, 0));
    const auto position = std::lower_bound(column_start, ws.blocks.end(), key) - column_start;
    ws.edge_slots[k] = BlockSlot{6 * key.first, 6 * static_cast<int>(position)};
  }
  ws.b.resize(n);
  ws.dx.resize(n);
  ws.diagonal.resize(n);
  return Status::Ok();
}

void PoseGraph::Linearize(const PoseGraphParams& params) {
  Workspace& ws = *ws_;
  double* values = ws.H.valuePtr();
  const int* outer = ws.H.outerIndexPtr();
  std::fill(values, values + ws.H.nonZeros(), 0.0);
  ws.b.setZero();
  Matrix6d J_from, J_to;
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    const PoseGraphEdge& e = edges_[k];
    const Vector6d r = PoseGraphEdgeResidual(poses_[e.from], poses_[e.to], e.T_from_to, &J_from, &J_to);
    double weight = 1.0;
    if (e.kind == EdgeKind::kLoop) {
      weight = KernelWeight(params.loop_kernel, params.loop_kernel_width, r.dot(e.information * r));
    }
    const Matrix6d W = weight * e.information;
    const Matrix6d WJ_from = W * J_from;
    const Matrix6d WJ_to = W * J_to;
    const Vector6d Wr = W * r;
    const int f = e.from != 0 ? ws.block_of[e.from - 1] : -1;
    const int t = e.to != 0 ? ws.block_of[e.to - 1] : -1;
    if (f >= 0) {
      AddBlock<true>(values, outer, ws.diagonal_slots[static_cast<std::size_t>(f)], J_from.transpose() * WJ_from);
      ws.b.segment<6>(6 * f) += J_from.transpose() * Wr;
    }
    if (t >= 0) {
      AddBlock<true>(values, outer, ws.diagonal_slots[static_cast<std::size_t>(t)], J_to.transpose() * WJ_to);
      ws.b.segment<6>(6 * t) += J_to.transpose() * Wr;
    }
    if (f >= 0 && t >= 0) {
      // Upper block: rows of the smaller block index, columns of the larger.
      if (f < t) {
        AddBlock<false>(values, outer, ws.edge_slots[k], J_from.transpose() * WJ_to);
      } else {
        AddBlock<false>(values, outer, ws.edge_slots[k], J_to.transpose() * WJ_from);
      }
    }
  }
}

Result<PoseGraphResult> PoseGraph::Optimize(const PoseGraphParams& params) {
  if (Status s = ValidateParams(params); !s.ok()) return s;
  PoseGraphResult result;
  result.initial_cost = result.final_cost = Cost(params);
  Workspace& ws = *ws_;
  if (poses_.size() > 1) {
    if (Status s = CheckConnected(); !s.ok()) return s;
  }
  if (poses_.size() <= 1 || result.initial_cost == 0.0) {
    result.converged = true;
    result.workspace_bytes = ws.Bytes();
    return result;
  }
  if (Status s = BuildPattern(); !s.ok()) return s;
  ws.solver.AnalyzePreordered(ws.H);  // symbolic factorisation: depends on the pattern only
  ws.initial.assign(poses_.begin(), poses_.end());
  ws.trial.assign(poses_.begin(), poses_.end());

  double cost = result.initial_cost;
  double lambda = params.lm_initial_lambda;
  while (result.iterations < params.max_iterations && !result.converged) {
    ++result.iterations;
    Linearize(params);
    double* values = ws.H.valuePtr();
    for (Eigen::Index v = 0; v < ws.diagonal.size(); ++v) ws.diagonal(v) = values[ws.diagonal_index[v]];

    bool accepted = false;
    while (!accepted && lambda <= kMaxLambda) {
      for (Eigen::Index v = 0; v < ws.diagonal.size(); ++v) {
        values[ws.diagonal_index[v]] = ws.diagonal(v) + lambda * std::max(ws.diagonal(v), kMinDiagonal);
      }
      ws.solver.factorize(ws.H);
      if (ws.solver.info() == Eigen::Success) {
        ws.factor_nnz = static_cast<std::size_t>(ws.solver.matrixL().nestedExpression().nonZeros());
        ws.dx = ws.solver.solve(-ws.b);
      }
      if (ws.solver.info() != Eigen::Success || !ws.dx.allFinite()) {
        lambda *= 10.0;
        continue;
      }
      const double step = ws.dx.size() > 0 ? ws.dx.cwiseAbs().maxCoeff() : 0.0;
      for (std::size_t i = 1; i < poses_.size(); ++i) {
        ws.trial[i] = poses_[i] * ExpSE3(ws.dx.segment<6>(6 * ws.block_of[i - 1]));
      }
      const double trial_cost = CostOf(Span<const Eigen::Isometry3d>(ws.trial.data(), ws.trial.size()), params);
      if (trial_cost < cost) {
        std::copy(ws.trial.begin(), ws.trial.end(), poses_.begin());
        accepted = true;
        result.converged = step < params.convergence_step ||
                           cost - trial_cost < params.relative_cost_tolerance * cost;
        cost = trial_cost;
        lambda = std::max(lambda * 0.1, kMinLambda);
      } else if (step < params.convergence_step) {
        result.converged = true;  // at the minimum up to rounding: the step cannot lower the cost
        break;
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted) break;  // converged, or no damping makes progress (converged stays false)
  }
  result.final_cost = cost;

  for (std::size_t i = 1; i < poses_.size(); ++i) {
    const double moved_m = (poses_[i].translation() - ws.initial[i].translation()).norm();
    const double rotated_rad = RotationAngleRad(ws.initial[i].linear().transpose() * poses_[i].linear());
    if (moved_m > params.changed_translation_m || rotated_rad > params.changed_rotation_rad) {
      result.changed_nodes.push_back(static_cast<std::uint32_t>(i));
    }
  }
  result.workspace_bytes = ws.Bytes();
  return result;
}

}  // namespace commerge
