// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/merge_judgement.hpp"

#include <algorithm>

namespace commerge {

namespace {

// Robot r of `items`, or nullptr outside them.
template <class T>
const T* JudgedRobotAt(Span<const T> items, int r) {
  return r >= 0 && static_cast<std::size_t>(r) < items.size() ? &items[static_cast<std::size_t>(r)] : nullptr;
}

// T_world_map of robot r: identity when it is not placed (or not in `placements`).
Eigen::Isometry3d JudgedWorldFromMap(Span<const RobotPlacement> placements, int r) {
  const RobotPlacement* p = JudgedRobotAt(placements, r);
  return p != nullptr && p->placed ? p->T_world_map : Eigen::Isometry3d::Identity();
}

bool JudgedPlaced(Span<const RobotPlacement> placements, int r) {
  const RobotPlacement* p = JudgedRobotAt(placements, r);
  return p != nullptr && p->placed;
}

}  // namespace

bool IsWrongMerge(const TransformError& e, const WrongMergeCriterion& criterion) {
  return e.translation_m > criterion.max_translation_m || e.rotation_deg > criterion.max_rotation_deg;
}

double WrongMergeScore(const TransformError& e, const WrongMergeCriterion& criterion) {
  return std::max(e.translation_m / criterion.max_translation_m, e.rotation_deg / criterion.max_rotation_deg);
}

std::vector<SharedPlace> MeasurePairSharedPlaces(Span<const RobotTrajectoryTruth> robots, Span<const JudgedPair> pairs,
                                                 const SharedPlaceParams& params) {
  std::vector<SharedPlace> out;
  for (const JudgedPair& p : pairs) {
    const RobotTrajectoryTruth* a = JudgedRobotAt(robots, p.alpha);
    const RobotTrajectoryTruth* b = JudgedRobotAt(robots, p.beta);
    if (a == nullptr || b == nullptr || a->ground_truth.empty() || b->ground_truth.empty()) return {};
    out.push_back(MeasureSharedPlace(a->ground_truth, b->ground_truth, params));
  }
  return out;
}

Span<const std::uint32_t> RegisteredKeyframes(Span<const JudgedPair> pairs, int robot, int partner) {
  for (const JudgedPair& p : pairs) {
    if (!((p.alpha == robot && p.beta == partner) || (p.alpha == partner && p.beta == robot))) continue;
    if (!p.registered) return {};
    return p.alpha == robot ? p.alpha_keyframes : p.beta_keyframes;
  }
  return {};
}

PlaceJudgement JudgeAtSharedPlace(Span<const RobotTrajectoryTruth> robots, Span<const RobotPlacement> placements,
                                  Span<const JudgedPair> pairs, int robot, const MergeJudgementParams& params) {
  PlaceJudgement out;
  const RobotTrajectoryTruth* tr = JudgedRobotAt(robots, robot);
  if (tr == nullptr) return out;
  double best = 0.0;
  for (int q = 0; q < static_cast<int>(robots.size()); ++q) {
    if (q == robot || !JudgedPlaced(placements, q)) continue;
    const RobotTrajectoryTruth& tq = robots[static_cast<std::size_t>(q)];
    const auto truth_at = [&](Span<const std::uint32_t> keyframes) {
      return TruthAtSharedPlace(tq.estimated, tq.ground_truth, tr->estimated, tr->ground_truth, params.shared_place,
                                params.min_registered_keyframes, keyframes);
    };
    const Span<const std::uint32_t> registered = RegisteredKeyframes(pairs, robot, q);
    Result<SharedPlaceTruth> truth = truth_at(registered);
    if (!registered.empty() && !truth.ok()) truth = truth_at({});
    if (!truth.ok()) continue;
    const TransformError e = ErrorAtSharedPlace(
        JudgedWorldFromMap(placements, q).inverse() * JudgedWorldFromMap(placements, robot), *truth);
    const double score = WrongMergeScore(e, params.wrong);
    if (!out.judged || score < best) {
      out.judged = true;
      out.error = e;
      out.partner = q;
      best = score;
    }
  }
  return out;
}

std::vector<RobotVerdict> JudgeRobots(Span<const RobotTrajectoryTruth> robots, Span<const RobotPlacement> placements,
                                      Span<const JudgedPair> pairs, const MergeJudgementParams& params) {
  const int n = static_cast<int>(robots.size());
  const std::vector<SharedPlace> shared = MeasurePairSharedPlaces(robots, pairs, params.shared_place);
  std::vector<bool> shared_pairs;  // (0,1), (0,2), .., (1,2), ..: ReachableFromRobot0's order
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      bool s = false;
      for (std::size_t i = 0; i < shared.size(); ++i) {
        if (pairs[i].alpha == a && pairs[i].beta == b) s = shared[i].shared;
      }
      shared_pairs.push_back(s);
    }
  }
  const std::vector<bool> reachable = ReachableFromRobot0(n, shared_pairs);
  std::vector<RobotVerdict> out(robots.size());
  for (int r = 0; r < n; ++r) {
    RobotVerdict& v = out[static_cast<std::size_t>(r)];
    v.has_gt = !shared.empty();
    v.reachable = v.has_gt && reachable[static_cast<std::size_t>(r)];
    v.merged = JudgedPlaced(placements, r);
    if (!v.merged || !v.has_gt) continue;
    const Eigen::Isometry3d truth = robots[0].T_gt_map.inverse() * robots[static_cast<std::size_t>(r)].T_gt_map;
    v.error = ComputeTransformError(JudgedWorldFromMap(placements, r), truth);
    if (r > 0) {
      const PlaceJudgement at_place = JudgeAtSharedPlace(robots, placements, pairs, r, params);
      v.judged_at_place = at_place.judged;
      if (at_place.judged) {
        v.error_at_place = at_place.error;
        v.place_partner = at_place.partner;
      }
    }
    v.wrong = r > 0 && IsWrongMerge(v.judged_at_place ? v.error_at_place : v.error, params.wrong);
  }
  return out;
}

}  // namespace commerge
