// SPDX-License-Identifier: BSD-3-Clause
#include "core/merge/joint_graph.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/solvers/max_clique.hpp"

namespace commerge {
namespace {

double AngleDeg(const Eigen::Matrix3d& R) { return LogSO3(R).norm() / kDegToRad; }

Matrix6d Information(double sigma_m, double sigma_deg) {
  Matrix6d info = Matrix6d::Zero();
  const double sigma_rad = sigma_deg * kDegToRad;
  info.diagonal() << 1.0 / (sigma_m * sigma_m), 1.0 / (sigma_m * sigma_m), 1.0 / (sigma_m * sigma_m),
      1.0 / (sigma_rad * sigma_rad), 1.0 / (sigma_rad * sigma_rad), 1.0 / (sigma_rad * sigma_rad);
  return info;
}

// An input edge read from the lower-index robot to the higher.
struct Oriented {
  std::size_t input = 0;
  std::uint32_t k_lo = 0, k_hi = 0;
  Eigen::Isometry3d T_lo_hi = Eigen::Isometry3d::Identity();
  double weight = 1.0;
};

}  // namespace

InterRobotEdge EdgeFromMapTransform(int robot_a, std::uint32_t keyframe_a, const Eigen::Isometry3d& T_mapa_ka,
                                    int robot_b, std::uint32_t keyframe_b, const Eigen::Isometry3d& T_mapb_kb,
                                    const Eigen::Isometry3d& T_mapa_mapb) {
  InterRobotEdge e;
  e.robot_a = robot_a;
  e.robot_b = robot_b;
  e.keyframe_a = keyframe_a;
  e.keyframe_b = keyframe_b;
  e.T_a_b = T_mapa_ka.inverse() * T_mapa_mapb * T_mapb_kb;
  return e;
}

Status ValidateJointGraphParams(const JointGraphParams& p) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  const auto nonnegative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  const std::pair<const char*, bool> checks[] = {
      {"chain_sigma_m", positive(p.chain_sigma_m)},
      {"chain_sigma_deg", positive(p.chain_sigma_deg)},
      {"edge_sigma_m", positive(p.edge_sigma_m)},
      {"edge_sigma_deg", positive(p.edge_sigma_deg)},
      {"consistency_m", positive(p.consistency_m)},
      {"consistency_deg", positive(p.consistency_deg)},
      {"drift_per_m", nonnegative(p.drift_per_m)},
      {"drift_deg_per_m", nonnegative(p.drift_deg_per_m)},
      {"max_edges_per_pair", p.max_edges_per_pair >= 1 && p.max_edges_per_pair <= 4096},
      {"max_nodes", p.max_nodes >= 1},
      {"node_stride", p.node_stride >= 1},
  };
  for (const auto& [name, ok] : checks) {
    if (!ok) return InvalidArgument(std::string("joint graph: ") + name + " is out of range");
  }
  return Status::Ok();
}

const char* JointEdgeVerdictName(JointEdgeVerdict verdict) noexcept {
  switch (verdict) {
    case JointEdgeVerdict::kUsed: return "used";
    case JointEdgeVerdict::kInconsistent: return "inconsistent";
    case JointEdgeVerdict::kNotConnected: return "not connected";
  }
  return "unknown";
}

namespace {

using PairEdges = std::map<std::pair<int, int>, std::vector<Oriented>>;

// The inputs checked (values named) and the edges grouped by robot pair, read from the lower robot to the higher.
Status CheckAndGroup(Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe, Span<const InterRobotEdge> edges,
                     const JointGraphParams& params, PairEdges* by_pair) {
  if (Status st = ValidateJointGraphParams(params); !st.ok()) return st;
  const int robots = static_cast<int>(T_map_keyframe.size());
  if (robots == 0) return InvalidArgument("joint graph: no robot");
  if (T_map_keyframe[0].empty()) return InvalidArgument("joint graph: robot 0 has no keyframe");
  std::size_t total = 0;
  for (int r = 0; r < robots; ++r) {
    const std::vector<Eigen::Isometry3d>& poses = T_map_keyframe[static_cast<std::size_t>(r)];
    total += poses.size();
    for (std::size_t k = 0; k < poses.size(); ++k) {
      if (!IsValidRigidTransform(poses[k])) {
        return InvalidArgument("joint graph: robot " + std::to_string(r) + " keyframe " + std::to_string(k) +
                               ": pose is not finite and rigid");
      }
    }
  }
  if (total > params.max_nodes) {
    return ResourceExhausted("joint graph: " + std::to_string(total) + " keyframes, above max_nodes " +
                             std::to_string(params.max_nodes));
  }
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const InterRobotEdge& e = edges[i];
    const std::string name = "joint graph: edge " + std::to_string(i);
    const bool a_ok = e.robot_a >= 0 && e.robot_a < robots, b_ok = e.robot_b >= 0 && e.robot_b < robots;
    if (!a_ok || !b_ok) {
      return InvalidArgument(name + ": robot " + std::to_string(a_ok ? e.robot_b : e.robot_a) + " out of range (" +
                             std::to_string(robots) + " robots)");
    }
    if (e.robot_a == e.robot_b) return InvalidArgument(name + ": both ends are robot " + std::to_string(e.robot_a));
    if (e.keyframe_a >= T_map_keyframe[static_cast<std::size_t>(e.robot_a)].size() ||
        e.keyframe_b >= T_map_keyframe[static_cast<std::size_t>(e.robot_b)].size()) {
      return InvalidArgument(name + ": keyframe " + std::to_string(e.keyframe_a) + " of robot " +
                             std::to_string(e.robot_a) + " or " + std::to_string(e.keyframe_b) + " of robot " +
                             std::to_string(e.robot_b) + " out of range");
    }
    if (!IsValidRigidTransform(e.T_a_b)) return InvalidArgument(name + ": T_a_b is not finite and rigid");
    if (!(std::isfinite(e.weight) && e.weight > 0.0)) {
      return InvalidArgument(name + ": weight " + std::to_string(e.weight) + " is not finite and > 0");
    }
    Oriented o;
    o.input = i;
    const bool flip = e.robot_a > e.robot_b;
    o.k_lo = flip ? e.keyframe_b : e.keyframe_a;
    o.k_hi = flip ? e.keyframe_a : e.keyframe_b;
    o.T_lo_hi = flip ? e.T_a_b.inverse() : e.T_a_b;
    o.weight = e.weight;
    const int lo = std::min(e.robot_a, e.robot_b), hi = std::max(e.robot_a, e.robot_b);
    std::vector<Oriented>& list = (*by_pair)[{lo, hi}];
    list.push_back(o);
    if (list.size() > params.max_edges_per_pair) {
      return ResourceExhausted("joint graph: robots " + std::to_string(lo) + " and " + std::to_string(hi) +
                               " have more than " + std::to_string(params.max_edges_per_pair) +
                               " edges (max_edges_per_pair)");
    }
  }
  return Status::Ok();
}

// Defence 1: each pair's heaviest set of mutually agreeing edges (by InterRobotEdge::weight; a lone edge is kept; a
// pair whose edges all disagree keeps none).
Status KeepConsistent(Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe, const PairEdges& by_pair,
                      const JointGraphParams& params, PairEdges* kept) {
  // Chain length along each robot's keyframes (the drift allowance).
  std::vector<std::vector<double>> along(T_map_keyframe.size());
  for (std::size_t r = 0; r < T_map_keyframe.size(); ++r) {
    const std::vector<Eigen::Isometry3d>& poses = T_map_keyframe[r];
    along[r].resize(poses.size(), 0.0);
    for (std::size_t k = 1; k < poses.size(); ++k) {
      along[r][k] = along[r][k - 1] + (poses[k].translation() - poses[k - 1].translation()).norm();
    }
  }
  for (const auto& [pair, list] : by_pair) {
    if (list.size() == 1) {
      (*kept)[pair] = list;
      continue;
    }
    const auto& Pa = T_map_keyframe[static_cast<std::size_t>(pair.first)];
    const auto& Pb = T_map_keyframe[static_cast<std::size_t>(pair.second)];
    const auto& La = along[static_cast<std::size_t>(pair.first)];
    const auto& Lb = along[static_cast<std::size_t>(pair.second)];
    auto graph = CliqueGraph::Create(static_cast<int>(list.size()), false);
    if (!graph.ok()) return graph.status();
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (Status st = graph->SetVertexWeight(static_cast<int>(i), list[i].weight); !st.ok()) return st;
    }
    for (std::size_t i = 0; i < list.size(); ++i) {
      for (std::size_t j = i + 1; j < list.size(); ++j) {
        const Oriented& e = list[i];
        const Oriented& f = list[j];
        const Eigen::Isometry3d cycle =
            e.T_lo_hi.inverse() * (Pa[e.k_lo].inverse() * Pa[f.k_lo]) * f.T_lo_hi * (Pb[f.k_hi].inverse() * Pb[e.k_hi]);
        const double length = std::abs(La[e.k_lo] - La[f.k_lo]) + std::abs(Lb[e.k_hi] - Lb[f.k_hi]);
        if (cycle.translation().norm() <= params.consistency_m + params.drift_per_m * length &&
            AngleDeg(cycle.linear()) <= params.consistency_deg + params.drift_deg_per_m * length) {
          if (Status st = graph->AddEdge(static_cast<int>(i), static_cast<int>(j)); !st.ok()) return st;
        }
      }
    }
    CliqueSearchParams search;
    search.objective = CliqueObjective::kVertexWeight;
    search.lp_bound = false;
    auto clique = SolveMaxClique(*graph, search);
    if (!clique.ok()) return clique.status();
    if (clique->clique.size() < 2) continue;  // nothing agrees with anything: none is verified
    std::vector<Oriented>& k = (*kept)[pair];
    for (int v : clique->clique) k.push_back(list[static_cast<std::size_t>(v)]);
  }
  return Status::Ok();
}

// The rigid placement from robot 0 through kept edges (breadth first; each pair's first kept edge).
void Place(Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe, const PairEdges& kept, JointGraphResult* out) {
  const std::size_t robots = T_map_keyframe.size();
  out->T_world_map.assign(robots, Eigen::Isometry3d::Identity());
  out->placed.assign(robots, 0);
  out->placed[0] = 1;
  std::deque<int> frontier{0};
  while (!frontier.empty()) {
    const int r = frontier.front();
    frontier.pop_front();
    for (const auto& [pair, list] : kept) {
      if (list.empty() || (pair.first != r && pair.second != r)) continue;
      const int other = pair.first == r ? pair.second : pair.first;
      if (out->placed[static_cast<std::size_t>(other)]) continue;
      const Oriented& e = list.front();
      const Eigen::Isometry3d T_lomap_himap = T_map_keyframe[static_cast<std::size_t>(pair.first)][e.k_lo] * e.T_lo_hi *
                                              T_map_keyframe[static_cast<std::size_t>(pair.second)][e.k_hi].inverse();
      const Eigen::Isometry3d& T_world_r = out->T_world_map[static_cast<std::size_t>(r)];
      out->T_world_map[static_cast<std::size_t>(other)] =
          pair.first == r ? T_world_r * T_lomap_himap : T_world_r * T_lomap_himap.inverse();
      out->placed[static_cast<std::size_t>(other)] = 1;
      frontier.push_back(other);
    }
  }
}

// Every keyframe of one robot in the world frame from its solved nodes: a node as solved; a keyframe between nodes p
// and q with the correction C = T_world_node T_map_node^-1 interpolated on SE(3) between theirs (by index).
void InterpolateKeyframes(const std::vector<Eigen::Isometry3d>& T_map_keyframe, const std::vector<std::uint32_t>& nodes,
                          Span<const Eigen::Isometry3d> T_world_node, std::vector<Eigen::Isometry3d>* out) {
  out->clear();
  out->reserve(T_map_keyframe.size());
  std::size_t i = 0;  // nodes[i] <= k < nodes[i + 1]
  for (std::size_t k = 0; k < T_map_keyframe.size(); ++k) {
    while (i + 1 < nodes.size() && nodes[i + 1] <= k) ++i;
    if (nodes[i] == k || i + 1 == nodes.size()) {
      out->push_back(T_world_node[i] * T_map_keyframe[nodes[i]].inverse() * T_map_keyframe[k]);
      continue;
    }
    const Eigen::Isometry3d C_p = T_world_node[i] * T_map_keyframe[nodes[i]].inverse();
    const Eigen::Isometry3d C_q = T_world_node[i + 1] * T_map_keyframe[nodes[i + 1]].inverse();
    const double alpha = static_cast<double>(k - nodes[i]) / static_cast<double>(nodes[i + 1] - nodes[i]);
    out->push_back(C_p * ExpSE3(alpha * LogSE3(C_p.inverse() * C_q)) * T_map_keyframe[k]);
  }
}

}  // namespace

Result<JointGraphResult> SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe,
                                         Span<const InterRobotEdge> edges, const JointGraphParams& params) {
  PairEdges by_pair, kept;
  if (Status st = CheckAndGroup(T_map_keyframe, edges, params, &by_pair); !st.ok()) return st;
  if (Status st = KeepConsistent(T_map_keyframe, by_pair, params, &kept); !st.ok()) return st;
  JointGraphResult out;
  out.verdicts.assign(edges.size(), JointEdgeVerdict::kInconsistent);
  out.residuals.assign(edges.size(), -1.0);
  Place(T_map_keyframe, kept, &out);
  const int robots = static_cast<int>(T_map_keyframe.size());
  // The graph's nodes: per placed robot, every node_stride-th keyframe, its last and the used edges' anchors.
  for (const auto& [pair, list] : kept) {
    const bool both = out.placed[static_cast<std::size_t>(pair.first)] && out.placed[static_cast<std::size_t>(pair.second)];
    for (const Oriented& o : list) {
      out.verdicts[o.input] = both ? JointEdgeVerdict::kUsed : JointEdgeVerdict::kNotConnected;
      out.used_edges += both ? 1 : 0;
    }
  }
  std::vector<std::vector<std::uint32_t>> node_keyframes(static_cast<std::size_t>(robots));
  std::vector<std::size_t> offset(static_cast<std::size_t>(robots), 0);
  for (int r = 0; r < robots; ++r) {
    if (!out.placed[static_cast<std::size_t>(r)]) continue;
    std::vector<std::uint32_t>& nk = node_keyframes[static_cast<std::size_t>(r)];
    const std::size_t n = T_map_keyframe[static_cast<std::size_t>(r)].size();
    for (std::size_t k = 0; k < n; k += params.node_stride) nk.push_back(static_cast<std::uint32_t>(k));
    nk.push_back(static_cast<std::uint32_t>(n - 1));
    for (const auto& [pair, list] : kept) {
      for (const Oriented& o : list) {
        if (out.verdicts[o.input] != JointEdgeVerdict::kUsed) continue;
        if (pair.first == r) nk.push_back(o.k_lo);
        if (pair.second == r) nk.push_back(o.k_hi);
      }
    }
    std::sort(nk.begin(), nk.end());
    nk.erase(std::unique(nk.begin(), nk.end()), nk.end());
    offset[static_cast<std::size_t>(r)] = out.nodes;
    out.nodes += nk.size();
    out.chain_edges += nk.size() - 1;
  }
  const auto node_of = [&](int r, std::uint32_t k) {
    const std::vector<std::uint32_t>& nk = node_keyframes[static_cast<std::size_t>(r)];
    return static_cast<std::uint32_t>(offset[static_cast<std::size_t>(r)] +
                                      static_cast<std::size_t>(std::lower_bound(nk.begin(), nk.end(), k) - nk.begin()));
  };
  PoseGraph graph(out.nodes, out.chain_edges + out.used_edges);
  const Matrix6d chain_info = Information(params.chain_sigma_m, params.chain_sigma_deg);
  const Matrix6d edge_info = Information(params.edge_sigma_m, params.edge_sigma_deg);
  for (int r = 0; r < robots; ++r) {
    const std::vector<Eigen::Isometry3d>& poses = T_map_keyframe[static_cast<std::size_t>(r)];
    const std::vector<std::uint32_t>& nk = node_keyframes[static_cast<std::size_t>(r)];
    for (std::uint32_t k : nk) {
      if (Status st = graph.AddNode(out.T_world_map[static_cast<std::size_t>(r)] * poses[k]); !st.ok()) return st;
    }
  }
  for (int r = 0; r < robots; ++r) {
    const std::vector<Eigen::Isometry3d>& poses = T_map_keyframe[static_cast<std::size_t>(r)];
    const std::vector<std::uint32_t>& nk = node_keyframes[static_cast<std::size_t>(r)];
    for (std::size_t i = 0; i + 1 < nk.size(); ++i) {
      PoseGraphEdge e;  // the chain between two nodes: its steps' covariances add up
      e.from = static_cast<std::uint32_t>(offset[static_cast<std::size_t>(r)] + i);
      e.to = e.from + 1;
      e.T_from_to = poses[nk[i]].inverse() * poses[nk[i + 1]];
      e.information = chain_info / static_cast<double>(nk[i + 1] - nk[i]);
      e.kind = EdgeKind::kOdometry;
      if (Status st = graph.AddEdge(e); !st.ok()) return st;
    }
  }
  std::vector<std::pair<std::size_t, PoseGraphEdge>> inter;  // (input edge, graph edge)
  for (const auto& [pair, list] : kept) {
    for (const Oriented& o : list) {
      if (out.verdicts[o.input] != JointEdgeVerdict::kUsed) continue;
      PoseGraphEdge e;
      e.from = node_of(pair.first, o.k_lo);
      e.to = node_of(pair.second, o.k_hi);
      e.T_from_to = o.T_lo_hi;
      e.information = o.weight * edge_info;
      e.kind = EdgeKind::kLoop;
      if (Status st = graph.AddEdge(e); !st.ok()) return st;
      inter.emplace_back(o.input, e);
    }
  }
  // From the rigid placement, far from the solution where the maps drifted, the kernel would discount the very edges
  // that must pull: least squares first over the edges that passed the consistency test, then the kernel.
  PoseGraphParams first = params.solver;
  first.loop_kernel = RobustKernel::kNone;
  auto coarse = graph.Optimize(first);
  if (!coarse.ok()) return coarse.status();
  auto solved = graph.Optimize(params.solver);
  if (!solved.ok()) return solved.status();
  out.solve = std::move(*solved);
  out.solve.initial_cost = coarse->initial_cost;
  out.solve.iterations += coarse->iterations;
  out.least_squares_iterations = coarse->iterations;
  out.T_world_keyframe.resize(static_cast<std::size_t>(robots));
  for (int r = 0; r < robots; ++r) {
    if (!out.placed[static_cast<std::size_t>(r)]) continue;
    InterpolateKeyframes(T_map_keyframe[static_cast<std::size_t>(r)], node_keyframes[static_cast<std::size_t>(r)],
                         graph.poses().subspan(offset[static_cast<std::size_t>(r)], node_keyframes[static_cast<std::size_t>(r)].size()),
                         &out.T_world_keyframe[static_cast<std::size_t>(r)]);
  }
  for (const auto& [input, e] : inter) {
    const Vector6d res = PoseGraphEdgeResidual(graph.pose(e.from), graph.pose(e.to), e.T_from_to);
    out.residuals[input] = std::sqrt(std::max(0.0, res.dot(e.information * res)));
  }
  return out;
}

}  // namespace commerge
