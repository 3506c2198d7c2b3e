// SPDX-License-Identifier: BSD-3-Clause
// commerge: stage A's chosen cluster against ground truth. A low fraction of true cells means stage A picked a
// place the robots never shared (aliasing), whatever registration made of it afterwards.
#pragma once

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {

struct StageATruthParams {
  double same_place_max_m = 10.0;  ///< a cell is true when its two keyframes were at most this far apart [m]
};

/// The fraction of `cells` (stage A's chosen cluster, L_seq) whose keyframes alpha_index and beta_index were
/// truly within params.same_place_max_m of each other (ground-truth positions alpha_gt[alpha_index] and
/// beta_gt[beta_index]). Cells outside the ground truth are not judged. -1 when there are no cells, no ground
/// truth for either robot, or no judged cell.
double StageATrueFraction(Span<const SequentialLoopCell> cells, Span<const Eigen::Isometry3d> alpha_gt,
                          Span<const Eigen::Isometry3d> beta_gt, const StageATruthParams& params = {});

}  // namespace commerge
