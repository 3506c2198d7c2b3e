// SPDX-License-Identifier: BSD-3-Clause
// commerge: the inter-robot edges a merge round gives the joint pose graph (core/merge/joint_graph.hpp; issue 57
// item 2). An accepted pair's final refinement registered each of its places on its own (PairRefinement::places:
// one scan of each robot, spread along the path they share). At each place the graph gets two measurements of the
// same relative pose: the pair's transform from the spread submaps (all places at once) and, where it succeeded,
// that place's own registration. The first holds the team to the rigid merge; the second lets the maps bend where
// they drifted apart. Their relative weight: JointEdgeParams.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "core/agent/pair_registrar.hpp"
#include "core/common/span.hpp"
#include "core/merge/joint_graph.hpp"

namespace commerge {

struct JointEdgeParams {
  /// Weight of the pair's transform read at a place (InterRobotEdge::weight), a place's own registration weighing
  /// 1; finite, > 0. Decision 032.
  double spread_fit_weight = 3.0;
};

/// The edges of `pairs` that are merged and whose robots are both in `placed` (per robot, non-zero: in the world
/// frame). Per pair and place (in PairRefinement::places' order): the pair's final transform at the place's two
/// keyframes (weight spread_fit_weight), then, when the place succeeded, PlaceRegistration::T_alpha_beta there
/// (weight 1). A pair refined nowhere gives its final transform at beta's middle keyframe and alpha's keyframe
/// nearest to it under that transform (weight spread_fit_weight). `T_map_keyframe[r]`: robot r's keyframe poses in
/// its map frame (index = keyframe); places whose keyframes are out of range are skipped.
std::vector<InterRobotEdge> JointEdgesOf(Span<const PairMergeResult> pairs,
                                         Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe,
                                         Span<const std::uint8_t> placed, const JointEdgeParams& params = {});

}  // namespace commerge
