// SPDX-License-Identifier: BSD-3-Clause
// commerge: the final refinement of an accepted pair (ours; issue 57 item 1). A pair is registered from the scans of
// one place (stage A's cluster, the policy's few keyframes): its transform is right there, but its rotation is
// measured over a few tens of metres, and the robots' maps drift along the rest of the path they share. Once the
// pair is accepted, a few more scans are asked for, spread along that shared path (not more of the same place), and
// the transform is refined on the held scans plus those by the fine stage alone (SubmapRegistration::RefineFrom):
// the longer lever arm fixes the rotation, and the fit spreads the drift over the whole shared path as sending every
// scan does. The refined transform replaces the accepted one only when the fine stage's gates pass and it moved
// less than max_correction_m / max_correction_deg (a refinement corrects, it does not re-decide the place).
// Pure functions and plain data: MergeRound asks for the scans and MergeServer refines.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/merge_server_params.hpp"
#include "core/agent/pair_exchange.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// The keyframes a refinement registers (ascending; some may be held already).
struct SpreadKeyframes {
  std::vector<std::uint32_t> alpha_keyframes, beta_keyframes;
  /// The places in pick order (the anchor first): (alpha's keyframe, beta's keyframe) of each pick.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> places;
};

/// Keyframes spread along the path robots alpha and beta share under T_alpha_beta (p_alpha = T p_beta). Beta's
/// keyframes placed within params.shared_path_m of one of alpha's are on the shared path. The first pick anchors the
/// set where the pair was registered (the held beta keyframe on the path nearest the held ones' centroid); then up
/// to scans_per_robot more by farthest-point sampling, each at least min_spacing_m from every pick; with each pick,
/// alpha's keyframe nearest to it. Scans are weighed by what they see, not by how many of one place the pair
/// holds: the refinement registers these picks alone. Keyframes whose pose is unknown are skipped; empty when
/// scans_per_robot is 0 or nothing is on the shared path. Errors: invalid params, a non-finite transform.
Result<SpreadKeyframes> SpreadAlongSharedPath(const RobotPoses& alpha, const RobotPoses& beta,
                                              const Eigen::Isometry3d& T_alpha_beta,
                                              Span<const std::uint32_t> held_beta, const RefinementParams& params);

}  // namespace commerge
