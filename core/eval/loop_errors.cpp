// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/loop_errors.hpp"

#include <algorithm>
#include <cstddef>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

Eigen::Isometry3d LoopErrorTransform(const Eigen::Isometry3d& T_match_query, const Eigen::Isometry3d& T_gt_match,
                                     const Eigen::Isometry3d& T_gt_query) {
  return (T_gt_match.inverse() * T_gt_query).inverse() * T_match_query;
}

double RotationAngleDeg(const Eigen::Isometry3d& T) { return RotationAngleRad(T.linear()) * kRadToDeg; }

bool IsFalseLoop(const Eigen::Isometry3d& error, const FalseLoopCriterion& criterion) {
  return error.translation().norm() > criterion.max_translation_m ||
         RotationAngleDeg(error) > criterion.max_rotation_deg;
}

LoopErrors SummarizeLoopErrors(Span<const Eigen::Isometry3d> errors, const FalseLoopCriterion& criterion) {
  LoopErrors out;
  out.checked = 0;
  std::vector<double> translations_m;
  for (const Eigen::Isometry3d& error : errors) {
    ++out.checked;
    out.wrong += IsFalseLoop(error, criterion);
    translations_m.push_back(error.translation().norm());
  }
  if (!translations_m.empty()) {
    const std::size_t mid = translations_m.size() / 2;
    std::nth_element(translations_m.begin(), translations_m.begin() + static_cast<std::ptrdiff_t>(mid),
                     translations_m.end());
    out.median_m = translations_m[mid];
    out.max_m = *std::max_element(translations_m.begin(), translations_m.end());
  }
  return out;
}

}  // namespace commerge
