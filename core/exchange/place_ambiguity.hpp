// SPDX-License-Identifier: BSD-3-Clause
// commerge: how ambiguous the place of a stage A cluster is (ours, not in the paper). A keyframe of the cluster
// is ambiguous when its own robot's map holds a keyframe far from it (more than far_m apart, the robot's own
// poses) whose descriptor is at least as close as the cluster's match on the other robot: the descriptor cannot
// tell that place from another one the robot knows. The cascade flags a cluster above
// ExchangeCascadeParams::max_ambiguous_fraction and the server registers it once, never widened, unless the place
// consensus confirms it (then only a registration where the consensus places it is accepted). Why: look-alike
// clusters, widened until something aligned, merged repeated corridors; true clusters there are ambiguous too, so
// ambiguity alone never refuses a pair (core/agent/decisions/003-ambiguous-places.md).
#pragma once

#include <cstddef>

#include <Eigen/Core>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {

struct PlaceAmbiguity {
  std::size_t alpha_keyframes = 0, beta_keyframes = 0;  ///< the cluster's distinct valid keyframes per robot
  std::size_t alpha_ambiguous = 0, beta_ambiguous = 0;  ///< of those, ambiguous ones
  double alpha_fraction() const noexcept {
    return alpha_keyframes == 0 ? 0.0 : static_cast<double>(alpha_ambiguous) / static_cast<double>(alpha_keyframes);
  }
  double beta_fraction() const noexcept {
    return beta_keyframes == 0 ? 0.0 : static_cast<double>(beta_ambiguous) / static_cast<double>(beta_keyframes);
  }
  double max_fraction() const noexcept { return alpha_fraction() > beta_fraction() ? alpha_fraction() : beta_fraction(); }
};

/// For every distinct alpha keyframe i of `l_seq` (valid descriptor): cross_i = the smallest SolidDistance to a
/// beta keyframe it is paired with in l_seq, self_i = the smallest SolidDistance to an alpha keyframe whose
/// position is more than far_m from i's; i is ambiguous when self_i <= cross_i. The same for beta. Positions are
/// each robot's own map frame (one per descriptor). O(|distinct keyframes| x N x D). Errors: malformed
/// descriptor sets, different dims, positions count != descriptor count, far_m not finite or negative, a cell
/// outside the sets.
Result<PlaceAmbiguity> MeasurePlaceAmbiguity(const DescriptorSetView& alpha, Span<const Eigen::Vector3d> alpha_positions_m,
                                             const DescriptorSetView& beta, Span<const Eigen::Vector3d> beta_positions_m,
                                             Span<const SequentialLoopCell> l_seq, double far_m,
                                             const DescriptorMetric& metric = {});

}  // namespace commerge
