// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/stage_a_truth.hpp"

#include <cstddef>

namespace commerge {

double StageATrueFraction(Span<const SequentialLoopCell> cells, Span<const Eigen::Isometry3d> alpha_gt,
                          Span<const Eigen::Isometry3d> beta_gt, const StageATruthParams& params) {
  if (cells.empty() || alpha_gt.empty() || beta_gt.empty()) return -1.0;
  std::size_t near = 0, judged = 0;
  for (const SequentialLoopCell& cell : cells) {
    if (cell.alpha_index >= alpha_gt.size() || cell.beta_index >= beta_gt.size()) continue;
    ++judged;
    const double d = (alpha_gt[cell.alpha_index].translation() - beta_gt[cell.beta_index].translation()).norm();
    if (d <= params.same_place_max_m) ++near;
  }
  return judged == 0 ? -1.0 : static_cast<double>(near) / static_cast<double>(judged);
}

}  // namespace commerge
