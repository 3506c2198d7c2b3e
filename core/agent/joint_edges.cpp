// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/joint_edges.hpp"

#include <cstddef>
#include <cstdint>
#include <limits>

namespace commerge {

namespace {

// Alpha's keyframe nearest to p_alpha (brute force: once per pair).
std::uint32_t NearestAlphaKeyframe(const std::vector<Eigen::Isometry3d>& alpha, const Eigen::Vector3d& p_alpha) {
  std::uint32_t best = 0;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < alpha.size(); ++k) {
    const double d2 = (alpha[k].translation() - p_alpha).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = static_cast<std::uint32_t>(k);
    }
  }
  return best;
}

}  // namespace

std::vector<InterRobotEdge> JointEdgesOf(Span<const PairMergeResult> pairs,
                                         Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe,
                                         Span<const std::uint8_t> placed, const JointEdgeParams& params) {
  std::vector<InterRobotEdge> edges;
  const auto robot_ok = [&](int r) {
    return r >= 0 && static_cast<std::size_t>(r) < T_map_keyframe.size() &&
           static_cast<std::size_t>(r) < placed.size() && placed[static_cast<std::size_t>(r)] != 0 &&
           !T_map_keyframe[static_cast<std::size_t>(r)].empty();
  };
  for (const PairMergeResult& p : pairs) {
    if (!p.merged() || !robot_ok(p.alpha) || !robot_ok(p.beta)) continue;
    const std::vector<Eigen::Isometry3d>& A = T_map_keyframe[static_cast<std::size_t>(p.alpha)];
    const std::vector<Eigen::Isometry3d>& B = T_map_keyframe[static_cast<std::size_t>(p.beta)];
    const auto edge = [&](std::uint32_t ka, std::uint32_t kb, const Eigen::Isometry3d& T_alpha_beta, double weight) {
      edges.push_back(EdgeFromMapTransform(p.alpha, ka, A[ka], p.beta, kb, B[kb], T_alpha_beta));
      edges.back().weight = weight;
    };
    const Eigen::Isometry3d& T = p.registration.T_target_source;
    bool refined = false;
    for (const PlaceRegistration& place : p.refinement.places) {
      if (place.alpha_keyframe >= A.size() || place.beta_keyframe >= B.size()) continue;
      refined = true;
      edge(place.alpha_keyframe, place.beta_keyframe, T, params.spread_fit_weight);
      if (place.success) edge(place.alpha_keyframe, place.beta_keyframe, place.T_alpha_beta, 1.0);
    }
    if (!refined) {
      const auto kb = static_cast<std::uint32_t>(B.size() / 2);
      edge(NearestAlphaKeyframe(A, T * B[kb].translation()), kb, T, params.spread_fit_weight);
    }
  }
  return edges;
}

}  // namespace commerge
