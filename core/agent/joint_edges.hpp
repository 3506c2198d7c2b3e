// SPDX-License-Identifier: BSD-3-Clause
// commerge: the inter-robot edges a merge round gives the joint pose graph (core/merge/joint_graph.hpp; issue 57
// item 2). An accepted pair contributes each place its final refinement registered on its own (PairRefinement::
// places: one scan of each robot, spread along the path they share), so where the robots' maps drift apart the
// graph sees it; a pair with no such place contributes its one transform, read at one place.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "core/agent/pair_registrar.hpp"
#include "core/common/span.hpp"
#include "core/merge/joint_graph.hpp"

namespace commerge {

/// The edges of `pairs` that are merged and whose robots are both in `placed` (per robot, non-zero: in the world
/// frame). Per pair: an edge for each successful place (PlaceRegistration::T_alpha_beta at its two keyframes);
/// when none succeeded, the pair's final transform at its first place, or, refined nowhere, at beta's middle
/// keyframe and alpha's keyframe nearest to it under that transform. `T_map_keyframe[r]`: robot r's keyframe
/// poses in its map frame (index = keyframe); places whose keyframes are out of range are skipped.
std::vector<InterRobotEdge> JointEdgesOf(Span<const PairMergeResult> pairs,
                                         Span<const std::vector<Eigen::Isometry3d>> T_map_keyframe,
                                         Span<const std::uint8_t> placed);

}  // namespace commerge
