// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/pair_exchange.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/common/number_text.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

namespace {

bool Known(const RobotPoses& poses, std::uint32_t k) {
  return k < poses.T_map_sensor.size() && k < poses.pose_known.size() && poses.pose_known[k] != 0;
}

// Largest move of one side's keyframes since `then` (one pose per keyframe).
void AddMotion(Span<const std::uint32_t> keyframes, Span<const Eigen::Isometry3d> then,
               Span<const std::uint8_t> known_then, const RobotPoses& now, RegionMotion* motion) {
  for (std::size_t i = 0; i < keyframes.size() && i < then.size() && i < known_then.size(); ++i) {
    if (!known_then[i] || !Known(now, keyframes[i])) continue;
    const Eigen::Isometry3d& T_now = now.T_map_sensor[keyframes[i]];
    motion->max_translation_m =
        std::max(motion->max_translation_m, (T_now.translation() - then[i].translation()).norm());
    motion->max_rotation_deg = std::max(
        motion->max_rotation_deg, RotationAngleRad(then[i].linear().transpose() * T_now.linear()) * kRadToDeg);
    ++motion->keyframes;
  }
}

// Median over `keyframes` (with a known pose) of the distance to the nearest of `others` (known poses); +inf when
// either side has none.
double MedianNearestM(Span<const std::uint32_t> keyframes, const std::vector<std::uint32_t>& others,
                      const RobotPoses& poses) {
  std::vector<double> nearest;
  for (std::uint32_t k : keyframes) {
    if (!Known(poses, k)) continue;
    double best = std::numeric_limits<double>::infinity();
    for (std::uint32_t o : others) {
      if (!Known(poses, o)) continue;
      best = std::min(best, (poses.T_map_sensor[k].translation() - poses.T_map_sensor[o].translation()).norm());
    }
    if (std::isfinite(best)) nearest.push_back(best);
  }
  if (nearest.empty()) return std::numeric_limits<double>::infinity();
  const auto mid = nearest.begin() + static_cast<std::ptrdiff_t>(nearest.size() / 2);
  std::nth_element(nearest.begin(), mid, nearest.end());
  return *mid;
}

// The keyframes of `keyframes` (known poses) farther than min_m from every one of `others` (known poses).
std::vector<std::uint32_t> FarFrom(Span<const std::uint32_t> keyframes, const std::vector<std::uint32_t>& others,
                                   const RobotPoses& poses, double min_m) {
  std::vector<std::uint32_t> far;
  for (std::uint32_t k : keyframes) {
    if (!Known(poses, k)) continue;
    const bool near = std::any_of(others.begin(), others.end(), [&](std::uint32_t o) {
      return Known(poses, o) &&
             (poses.T_map_sensor[k].translation() - poses.T_map_sensor[o].translation()).norm() <= min_m;
    });
    if (!near) far.push_back(k);
  }
  return far;
}

std::string MotionText(const RegionMotion& m) {
  return FormatFixed(m.max_translation_m, 2) + " m / " + FormatFixed(m.max_rotation_deg, 2) + " deg";
}

std::string BoundText(const PairExchangeParams& p) {
  return FormatNumber(p.moved_m, 3) + " m / " + FormatNumber(p.moved_deg, 3) + " deg";
}

std::string DistanceText(double m) { return std::isfinite(m) ? FormatFixed(m, 1) + " m" : "no comparable keyframes"; }

bool HasSelection(const PairSelection& s) { return !s.alpha_keyframes.empty() || !s.beta_keyframes.empty(); }

// A pair with a verified registration: re-register a moved region, add a second region to a bridge, or keep it.
void DecideVerified(const PairExchangeInput& in, const PairExchangeParams& params, PairExchangeDecision* d) {
  const PairHistory& h = *in.history;
  for (std::size_t i = 0; i < h.verified.size(); ++i) {
    const RegionMotion m = MeasureRegionMotion(h.verified[i].region, in.alpha, in.beta);
    if (i == 0 || m.max_translation_m > d->motion.max_translation_m) d->motion = m;
    if (m.max_translation_m > params.moved_m || m.max_rotation_deg > params.moved_deg) {
      d->reason = PairExchangeReason::kPosesMoved;
      d->region = i;
      d->motion = m;
      d->selection.alpha_keyframes = h.verified[i].region.alpha_keyframes;
      d->selection.beta_keyframes = h.verified[i].region.beta_keyframes;
      d->selection.loops = h.verified[i].region.alpha_keyframes.size();
      d->why = "the poses of the overlap verified in round " + std::to_string(h.verified[i].region.round) +
               " moved up to " + MotionText(m) + " (bound " + BoundText(params) + ")";
      return;
    }
  }
  const bool bridge = std::all_of(h.verified.begin(), h.verified.end(), [](const VerifiedRegion& v) {
    return v.verdict == MeasurementVerdict::kUnverified;
  });
  if (bridge && h.verified.size() < kMaxVerifiedRegions && h.tried.size() < params.max_tried_regions &&
      HasSelection(*in.plan)) {
    d->overlap_distance_m = OverlapDistanceM(*in.plan, Span<const PairRegion>(h.tried), in.alpha, in.beta);
    if (d->overlap_distance_m > params.new_overlap_m) {
      // The second region is the part of the selection away from every place registered: an independent check
      // (scans of both places in one submap pair would also align shifted by one place onto the other).
      std::vector<std::uint32_t> alpha_before, beta_before;
      for (const PairRegion& r : h.tried) {
        alpha_before.insert(alpha_before.end(), r.alpha_keyframes.begin(), r.alpha_keyframes.end());
        beta_before.insert(beta_before.end(), r.beta_keyframes.begin(), r.beta_keyframes.end());
      }
      d->selection.alpha_keyframes = FarFrom(Span<const std::uint32_t>(in.plan->alpha_keyframes), alpha_before,
                                             in.alpha, params.new_overlap_m);
      d->selection.beta_keyframes = FarFrom(Span<const std::uint32_t>(in.plan->beta_keyframes), beta_before, in.beta,
                                            params.new_overlap_m);
      if (!d->selection.alpha_keyframes.empty() && !d->selection.beta_keyframes.empty()) {
        d->reason = PairExchangeReason::kNewOverlap;
        d->region = h.verified.size();
        d->why = "nothing checks its verified transform (a bridge); the cascade selects a place " +
                 DistanceText(d->overlap_distance_m) + " from every overlap registered";
        return;
      }
      d->selection = *in.plan;
    }
  }
  d->reason = PairExchangeReason::kUnchanged;
  d->selection = PairSelection{};
  d->selection.alpha = d->alpha;
  d->selection.beta = d->beta;
  d->why = "verified in round " + std::to_string(h.verified[0].region.round) + "; its overlap moved at most " +
           MotionText(d->motion);
}

// A pair without a verified registration between two placed robots: try the plan's place once, then only places
// far from every one tried.
void DecideUnverified(const PairExchangeInput& in, const PairExchangeParams& params, PairExchangeDecision* d) {
  const PairHistory* h = in.history;
  if (h == nullptr || h->tried.empty()) {
    d->reason = PairExchangeReason::kFirstAttempt;
    d->why = "both robots are placed through other pairs; the pair is registered for the first time";
    return;
  }
  std::string before = h->rejected_round > 0
                           ? "the frame solver rejected its transform in round " + std::to_string(h->rejected_round)
                           : "refused in round " + std::to_string(h->refused_round) +
                                 (h->refused_reason.empty() ? std::string() : " (" + h->refused_reason + ")");
  if (h->tried.size() >= params.max_tried_regions) {
    d->reason = PairExchangeReason::kNothingNew;
    d->why = before + "; tried at " + std::to_string(h->tried.size()) + " places, the most it is";
    return;
  }
  d->overlap_distance_m = OverlapDistanceM(*in.plan, Span<const PairRegion>(h->tried), in.alpha, in.beta);
  if (d->overlap_distance_m > params.new_overlap_m) {
    d->reason = h->rejected_round > 0 ? PairExchangeReason::kVerificationFailed : PairExchangeReason::kNewOverlap;
    d->why = before + "; the cascade selects a place " + DistanceText(d->overlap_distance_m) +
             " from every place tried";
    return;
  }
  d->reason = PairExchangeReason::kNothingNew;
  d->why = before + "; the cascade's selection is " + DistanceText(d->overlap_distance_m) + " from a place tried";
}

}  // namespace

Status ValidatePairExchangeParams(const PairExchangeParams& params) {
  const std::pair<const char*, double> non_negative[] = {
      {"moved_m", params.moved_m}, {"moved_deg", params.moved_deg}, {"new_overlap_m", params.new_overlap_m}};
  for (const auto& [name, value] : non_negative) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      return InvalidArgument(std::string("pair exchange: ") + name + " = " + FormatNumber(value, 6) +
                             " must be finite and >= 0");
    }
  }
  if (params.max_tried_regions < 1 || params.max_tried_regions > 64) {
    return InvalidArgument("pair exchange: max_tried_regions = " + std::to_string(params.max_tried_regions) +
                           " is outside 1..64");
  }
  return Status::Ok();
}

const char* PairExchangeReasonName(PairExchangeReason reason) noexcept {
  switch (reason) {
    case PairExchangeReason::kEveryRound: return "every_round";
    case PairExchangeReason::kRobotNotPlaced: return "robot_not_placed";
    case PairExchangeReason::kRobotRestarted: return "robot_restarted";
    case PairExchangeReason::kFirstAttempt: return "first_attempt";
    case PairExchangeReason::kPosesMoved: return "poses_moved";
    case PairExchangeReason::kNewOverlap: return "new_overlap";
    case PairExchangeReason::kVerificationFailed: return "verification_failed";
    case PairExchangeReason::kUnchanged: return "unchanged";
    case PairExchangeReason::kNothingNew: return "nothing_new";
  }
  return "?";
}

bool RegistersPair(PairExchangeReason reason) noexcept {
  return reason != PairExchangeReason::kUnchanged && reason != PairExchangeReason::kNothingNew;
}

RegionMotion MeasureRegionMotion(const PairRegion& region, const RobotPoses& alpha, const RobotPoses& beta) {
  RegionMotion m;
  AddMotion(Span<const std::uint32_t>(region.alpha_keyframes), Span<const Eigen::Isometry3d>(region.alpha_poses),
            Span<const std::uint8_t>(region.alpha_known), alpha, &m);
  AddMotion(Span<const std::uint32_t>(region.beta_keyframes), Span<const Eigen::Isometry3d>(region.beta_poses),
            Span<const std::uint8_t>(region.beta_known), beta, &m);
  return m;
}

double OverlapDistanceM(const PairSelection& selection, Span<const PairRegion> regions, const RobotPoses& alpha,
                        const RobotPoses& beta) {
  std::vector<std::uint32_t> alpha_before, beta_before;
  for (const PairRegion& r : regions) {
    alpha_before.insert(alpha_before.end(), r.alpha_keyframes.begin(), r.alpha_keyframes.end());
    beta_before.insert(beta_before.end(), r.beta_keyframes.begin(), r.beta_keyframes.end());
  }
  const double a = MedianNearestM(Span<const std::uint32_t>(selection.alpha_keyframes), alpha_before, alpha);
  const double b = MedianNearestM(Span<const std::uint32_t>(selection.beta_keyframes), beta_before, beta);
  return std::min(a, b);
}

PairRegion MakePairRegion(const PairSelection& selection, const RobotPoses& alpha, const RobotPoses& beta,
                          int round) {
  PairRegion r;
  r.round = round;
  r.alpha_keyframes = selection.alpha_keyframes;
  r.beta_keyframes = selection.beta_keyframes;
  for (std::uint32_t k : r.alpha_keyframes) {
    r.alpha_known.push_back(Known(alpha, k) ? 1 : 0);
    r.alpha_poses.push_back(Known(alpha, k) ? alpha.T_map_sensor[k] : Eigen::Isometry3d::Identity());
  }
  for (std::uint32_t k : r.beta_keyframes) {
    r.beta_known.push_back(Known(beta, k) ? 1 : 0);
    r.beta_poses.push_back(Known(beta, k) ? beta.T_map_sensor[k] : Eigen::Isometry3d::Identity());
  }
  return r;
}

PairExchangeDecision DecidePairExchange(const PairExchangeInput& in, const PairExchangeParams& params) {
  PairExchangeDecision d;
  d.alpha = in.plan->alpha;
  d.beta = in.plan->beta;
  d.selection = *in.plan;
  if (!params.enabled) {
    d.reason = PairExchangeReason::kEveryRound;
    d.why = "every pair every round";
    return d;
  }
  if (in.history != nullptr && !in.history->verified.empty()) {
    DecideVerified(in, params, &d);
    return d;
  }
  if (in.restarted) {
    d.reason = PairExchangeReason::kRobotRestarted;
    d.why = "a robot restarted: its map frame is new";
  } else if (!in.alpha_placed || !in.beta_placed) {
    d.reason = PairExchangeReason::kRobotNotPlaced;
    d.why = "robot " + std::to_string(!in.alpha_placed ? d.alpha : d.beta) + " is not placed";
  } else if (!HasSelection(*in.plan)) {
    d.reason = PairExchangeReason::kNothingNew;
    d.why = "nothing selected: " + in.plan->no_selection_reason;
  } else {
    DecideUnverified(in, params, &d);
  }
  return d;
}

void HoldSecondRegions(std::vector<PairExchangeDecision>* decisions) {
  const bool cycle_pending = std::any_of(decisions->begin(), decisions->end(), [](const PairExchangeDecision& d) {
    return d.reason == PairExchangeReason::kFirstAttempt || d.reason == PairExchangeReason::kVerificationFailed ||
           (d.reason == PairExchangeReason::kNewOverlap && d.region == 0);
  });
  if (!cycle_pending) return;
  for (PairExchangeDecision& d : *decisions) {
    if (d.reason != PairExchangeReason::kNewOverlap || d.region == 0) continue;
    d.reason = PairExchangeReason::kUnchanged;
    d.why = "a bridge; waits for the registration of a pair that may close a cycle over it";
    d.selection = PairSelection{};
    d.selection.alpha = d.alpha;
    d.selection.beta = d.beta;
    d.region = 0;
  }
}

std::string ExchangeDecisionsText(Span<const PairExchangeDecision> decisions) {
  std::string text;
  for (const PairExchangeDecision& d : decisions) {
    if (!text.empty()) text += "; ";
    text += std::to_string(d.alpha) + "-" + std::to_string(d.beta) + " " + PairExchangeReasonName(d.reason) + " " +
            std::to_string(d.scans_requested);
    if (d.scans_widened > 0) text += "+" + std::to_string(d.scans_widened);
  }
  return text;
}

}  // namespace commerge
