// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/path_agreement.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace commerge {
namespace {

struct CellHash {
  std::size_t operator()(const Eigen::Vector3i& c) const noexcept {
    return static_cast<std::size_t>(c.x()) * 73856093u ^ static_cast<std::size_t>(c.y()) * 19349663u ^
           static_cast<std::size_t>(c.z()) * 83492791u;
  }
};
struct CellEqual {
  bool operator()(const Eigen::Vector3i& a, const Eigen::Vector3i& b) const noexcept { return a == b; }
};

Eigen::Vector3i CellOf(const Eigen::Vector3d& p, double size) {
  return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / size)), static_cast<int>(std::floor(p.y() / size)),
                         static_cast<int>(std::floor(p.z() / size)));
}

}  // namespace

Result<PathAgreement> MeasurePathAgreement(Span<const RobotPathTruth> robots, const PathAgreementParams& params) {
  if (!(std::isfinite(params.radius_m) && params.radius_m > 0.0)) {
    return InvalidArgument("path agreement: radius_m must be > 0");
  }
  if (params.keyframe_stride < 1) return InvalidArgument("path agreement: keyframe_stride must be >= 1");
  std::vector<std::size_t> used;  // robots placed with truth
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const RobotPathTruth& t = robots[r];
    if (t.T_world_keyframe.empty() || t.T_gt_keyframe.empty()) continue;
    if (t.T_world_keyframe.size() != t.T_gt_keyframe.size()) {
      return InvalidArgument("path agreement: robot " + std::to_string(r) + " has " +
                             std::to_string(t.T_world_keyframe.size()) + " placed poses and " +
                             std::to_string(t.T_gt_keyframe.size()) + " true ones");
    }
    for (std::size_t k = 0; k < t.T_world_keyframe.size(); ++k) {
      if (!t.T_world_keyframe[k].matrix().allFinite() || !t.T_gt_keyframe[k].matrix().allFinite()) {
        return InvalidArgument("path agreement: robot " + std::to_string(r) + " keyframe " + std::to_string(k) +
                               " has a non-finite pose");
      }
    }
    used.push_back(r);
  }
  const double radius = params.radius_m, radius2 = radius * radius;
  const std::size_t stride = params.keyframe_stride;
  std::vector<float> errors;
  double sum2 = 0.0;
  for (std::size_t ia = 0; ia < used.size(); ++ia) {
    for (std::size_t ib = ia + 1; ib < used.size(); ++ib) {
      const RobotPathTruth& a = robots[used[ia]];
      const RobotPathTruth& b = robots[used[ib]];
      // Robot b's true positions in cells of radius_m: a's neighbours within radius_m are in the 27 cells around.
      std::unordered_map<Eigen::Vector3i, std::vector<std::uint32_t>, CellHash, CellEqual> cells;
      for (std::size_t j = 0; j < b.T_gt_keyframe.size(); j += stride) {
        cells[CellOf(b.T_gt_keyframe[j].translation(), radius)].push_back(static_cast<std::uint32_t>(j));
      }
      for (std::size_t i = 0; i < a.T_gt_keyframe.size(); i += stride) {
        const Eigen::Isometry3d gt_inv = a.T_gt_keyframe[i].inverse();
        const Eigen::Isometry3d est_inv = a.T_world_keyframe[i].inverse();
        const Eigen::Vector3d p = a.T_gt_keyframe[i].translation();
        const Eigen::Vector3i c = CellOf(p, radius);
        for (int dx = -1; dx <= 1; ++dx) {
          for (int dy = -1; dy <= 1; ++dy) {
            for (int dz = -1; dz <= 1; ++dz) {
              const auto it = cells.find(c + Eigen::Vector3i(dx, dy, dz));
              if (it == cells.end()) continue;
              for (std::uint32_t j : it->second) {
                if ((b.T_gt_keyframe[j].translation() - p).squaredNorm() > radius2) continue;
                const Eigen::Vector3d truth = gt_inv * b.T_gt_keyframe[j].translation();
                const Eigen::Vector3d got = est_inv * b.T_world_keyframe[j].translation();
                const double e = (got - truth).norm();
                sum2 += e * e;
                errors.push_back(static_cast<float>(e));
              }
            }
          }
        }
      }
    }
  }
  PathAgreement out;
  out.pairs = errors.size();
  if (errors.empty()) return out;
  out.rms_m = std::sqrt(sum2 / static_cast<double>(errors.size()));
  const std::size_t rank = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(errors.size()))) - 1;
  std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(rank), errors.end());
  out.p95_m = static_cast<double>(errors[rank]);
  out.max_m = static_cast<double>(*std::max_element(errors.begin(), errors.end()));
  return out;
}

}  // namespace commerge
