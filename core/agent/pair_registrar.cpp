// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/pair_registrar.hpp"

#include <algorithm>
#include <string>

#include "core/cloud/scan_codec.hpp"
#include "core/common/number_text.hpp"
#include "core/exchange/transform_agreement.hpp"
#include "core/geometry/angles.hpp"
#include "core/memory/budget.hpp"

namespace commerge {

const char* PairVerdictName(const PairMergeResult& result) noexcept {
  if (result.stop == PairStop::kNone) return RegistrationVerdictName(RegistrationVerdict::kSuccess);
  if (result.stop == PairStop::kRegistration) return RegistrationVerdictName(result.registration.verdict);
  return PairStopName(result.stop);
}

std::size_t PairRegistrar::BuildSubmap(const KeyframeDatabase& db, const ScanInbox& inbox, int robot,
                                       Span<const std::uint32_t> keyframes, double voxel_size_m,
                                       std::vector<PointXYZI>* points, std::vector<Eigen::Vector3d>* sensor_origins,
                                       std::size_t* missing, const std::function<void()>& note_memory) {
  points->clear();
  sensor_origins->clear();
  union_points_.clear();
  std::size_t used = 0;
  *missing = 0;
  VoxelGridParams v;
  v.voxel_size_m = voxel_size_m;
  // The union is voxelised once it holds more than this many submaps' worth of points: it never holds more than
  // that plus one scan (max_scan_points), and neither do the grid's workspace and the voxelised output. Reserved
  // once, so none of them grows past the submaps budget module (MakeBudgetTable).
  constexpr std::size_t kUnionPointsPerSubmap = BudgetRecordSizes::kSubmapUnionFactor;
  const std::size_t union_capacity = kUnionPointsPerSubmap * params_.max_submap_points + params_.max_scan_points;
  if (union_points_.capacity() < union_capacity) {
    union_points_.reserve(union_capacity);
    voxel_grid_.Reserve(union_capacity);
    scan_points_.reserve(params_.max_scan_points);
  }
  sensor_origins->reserve(keyframes.size());
  const RobotKeyframeDb& kf = db.robot(robot);
  for (std::uint32_t k : keyframes) {
    const std::vector<std::uint8_t>* scan = inbox.scan_bytes(robot, k);
    if (scan == nullptr || k >= kf.size() || !kf.pose_known[k]) {
      ++*missing;
      continue;
    }
    if (!DecodeScan(Span<const std::uint8_t>(*scan), &scan_points_).ok()) {
      ++*missing;
      continue;
    }
    // Paper eq. M_alpha: every point of the scan placed with the keyframe's pose in the robot's map frame.
    const Eigen::Isometry3f T = kf.T_map_sensor[k].cast<float>();
    for (const PointXYZI& p : scan_points_) {
      const Eigen::Vector3f q = T * Eigen::Vector3f(p.x, p.y, p.z);
      union_points_.push_back({q.x(), q.y(), q.z(), p.intensity});
    }
    sensor_origins->push_back(kf.T_map_sensor[k].translation());
    ++used;
    // A large selection (send-all's complete maps) is voxelised as it grows, so the union stays within a few
    // submaps' worth of points whatever the number of scans.
    if (union_points_.size() > kUnionPointsPerSubmap * params_.max_submap_points) {
      if (!voxel_grid_.Downsample(Span<const PointXYZI>(union_points_), v, points).ok()) points->clear();
      union_points_.assign(points->begin(), points->end());
      // Still more than that once voxelised: at this voxel size the submap cannot fit max_submap_points (the
      // union's voxels only grow as scans are added), so the caller will voxelise coarser. Stop adding scans, so
      // the union, the grid and the submaps stay within their module (a last, coarsest attempt that still does
      // not fit registers the scans taken so far).
      if (union_points_.size() > kUnionPointsPerSubmap * params_.max_submap_points) break;
    }
  }
  if (!voxel_grid_.Downsample(Span<const PointXYZI>(union_points_), v, points).ok()) points->clear();
  note_memory();
  return used;
}

bool PairRegistrar::BuildBoth(const KeyframeDatabase& db, const ScanInbox& inbox, const PairSelection& pair,
                              double voxel_size_m, std::size_t* alpha_scans, std::size_t* beta_scans,
                              std::size_t* alpha_missing, std::size_t* beta_missing,
                              const std::function<void()>& note_memory) {
  *alpha_scans = BuildSubmap(db, inbox, pair.alpha, Span<const std::uint32_t>(pair.alpha_keyframes), voxel_size_m,
                             &alpha_points_, &alpha_origins_, alpha_missing, note_memory);
  *beta_scans = BuildSubmap(db, inbox, pair.beta, Span<const std::uint32_t>(pair.beta_keyframes), voxel_size_m,
                            &beta_points_, &beta_origins_, beta_missing, note_memory);
  return alpha_points_.size() <= params_.max_submap_points && beta_points_.size() <= params_.max_submap_points;
}

void PairRegistrar::GrowUntilFits(const std::function<bool(double)>& build_both, double* voxel_size_m) {
  for (int step = 1; step <= 8; ++step) {
    *voxel_size_m *= 1.25;
    if (build_both(*voxel_size_m)) return;
  }
}

Result<PairMergeResult> PairRegistrar::MergePair(const KeyframeDatabase& db, const ScanInbox& inbox,
                                                 const PairSelection& pair, const ExchangeCascadeResult* cascade,
                                                 const PairEvidence* evidence, RegistrationStageObserver* observer,
                                                 const std::function<void()>& note_memory) {
  PairMergeResult out;
  out.alpha = pair.alpha;
  out.beta = pair.beta;
  if (pair.alpha_keyframes.empty() || pair.beta_keyframes.empty()) {
    out.stop = pair.stop != PairStop::kNone ? pair.stop : PairStop::kNothingSelected;
    out.reason = pair.no_selection_reason.empty() ? "no scans selected" : pair.no_selection_reason;
    return out;
  }
  // Both submaps at one voxel size; grown until both fit max_submap_points.
  auto build_both = [&](double voxel_size_m) {
    return BuildBoth(db, inbox, pair, voxel_size_m, &out.alpha_scans, &out.beta_scans, &out.alpha_missing,
                     &out.beta_missing, note_memory);
  };
  double voxel = params_.submap_voxel_size_m;
  const bool grown = !build_both(voxel);
  if (grown) GrowUntilFits(build_both, &voxel);
  if (!grown && params_.min_submap_points > 0) {
    // Small scene: finer while the smaller submap gains (the scans may be stored no finer than the grid).
    std::size_t smaller = std::min(alpha_points_.size(), beta_points_.size());
    for (int k = 1; smaller < params_.min_submap_points; ++k) {
      const double finer = AdaptiveVoxelStep(params_.submap_voxel_size_m, k);
      if (finer < params_.min_submap_voxel_size_m * (1.0 - 1e-9)) break;
      const bool fits = build_both(finer);
      const std::size_t now = std::min(alpha_points_.size(), beta_points_.size());
      if (!fits || 10 * now < 11 * smaller) {
        build_both(voxel);  // back to the last size taken
        break;
      }
      voxel = finer;
      smaller = now;
    }
  }
  out.alpha_submap_points = alpha_points_.size();
  out.beta_submap_points = beta_points_.size();
  out.voxel_size_m = voxel;
  if (out.alpha_scans == 0 || out.beta_scans == 0) {
    out.stop = PairStop::kScansMissing;
    out.reason = "no selected scan was received (" + std::to_string(out.alpha_missing) + " of robot " +
                 std::to_string(pair.alpha) + " and " + std::to_string(out.beta_missing) + " of robot " +
                 std::to_string(pair.beta) + " missing)";
    return out;
  }
  SubmapRegistrationParams reg = SubmapParams(voxel);
  reg.max_hypotheses = params_.registration_hypotheses;
  SubmapView source{Span<const PointXYZI>(beta_points_), Span<const Eigen::Vector3d>(beta_origins_)};
  SubmapView target{Span<const PointXYZI>(alpha_points_), Span<const Eigen::Vector3d>(alpha_origins_)};
  auto result = registration_.Register(source, target, reg, observer);
  note_memory();
  if (!result.ok()) return result.status();
  out.attempted = true;
  out.registration = *result;
  PairEvidence e = evidence != nullptr ? *evidence : PairEvidence{};
  e.registered = true;
  e.verdict = result->verdict;
  if (!result->success()) {
    out.stop = PairStop::kRegistration;
    out.reason = RegistrationVerdictName(result->verdict);
    return out;
  }
  // The evidence a transform gives, measured as far as DecideAccept needs it. A pair at a confirmed ambiguous place
  // may have been widened until something aligned: it merges only where its place consensus places it. The
  // transform stays in the result for the report.
  const PlaceConsensusParams& agreement = params_.cascade.consensus;
  if (evidence != nullptr && AmbiguousPlaceConfirmed(e, params_.decision) && e.placement.valid) {
    e.gap = GapToPlacement(e.placement, result->T_target_source);
    e.gap_measured = true;
  }
  out.stop = DecideAccept(e, params_.decision, agreement).stop;
  if (out.stop == PairStop::kOffConfirmedPlace) {
    out.reason = std::string(PairStopName(out.stop)) + " (" + FormatNumber(e.gap.distance_m, 3) + " m and " +
                 FormatNumber(e.gap.yaw_deg, 3) + " deg from the place consensus's placement, tolerance " +
                 FormatNumber(agreement.agree_m, 3) + " m and " + FormatNumber(agreement.agree_deg, 3) + " deg)";
    return out;
  }
  if (cascade != nullptr) {
    MeasureColocation(db, *cascade, &out);
    e.colocation_measured = true;
    e.colocated_keyframes = out.colocated_keyframes;
    e.colocated_chance = out.colocated_chance;
  }
  out.stop = DecideAccept(e, params_.decision, agreement).stop;
  if (out.stop == PairStop::kDescriptorsDisagree) {
    out.reason = std::string(PairStopName(out.stop)) + " (" + std::to_string(out.colocated_keyframes) +
                 " keyframes of robot " + std::to_string(pair.beta) + " placed on robot " + std::to_string(pair.alpha) +
                 "'s away from stage A's cluster, median chance " + FormatNumber(out.colocated_chance, 3) + " >= " +
                 FormatNumber(params_.decision.max_colocated_chance, 3) + ")";
  }
  return out;
}

Status PairRegistrar::RefinePair(const KeyframeDatabase& db, const ScanInbox& inbox, const PairSelection& spread,
                                 std::size_t spread_alpha, std::size_t spread_beta,
                                 Span<const std::pair<std::uint32_t, std::uint32_t>> places, PairMergeResult* result,
                                 const std::function<void()>& note_memory) {
  if (!result->merged() || result->alpha != spread.alpha || result->beta != spread.beta) return Status::Ok();
  PairRefinement& r = result->refinement;
  r = PairRefinement{};
  r.T_target_source_registered = result->registration.T_target_source;
  std::size_t alpha_missing = 0, beta_missing = 0;
  auto build_both = [&](double voxel_size_m) {
    return BuildBoth(db, inbox, spread, voxel_size_m, &r.alpha_scans, &r.beta_scans, &alpha_missing, &beta_missing,
                     note_memory);
  };
  double voxel = params_.submap_voxel_size_m;
  if (!build_both(voxel)) GrowUntilFits(build_both, &voxel);
  r.alpha_missing = std::min(alpha_missing, spread_alpha);
  r.beta_missing = std::min(beta_missing, spread_beta);
  // Spread scans were asked for and none arrived: nothing to refine on (picks that were all held cost nothing).
  if (spread_alpha + spread_beta > 0 && r.alpha_missing == spread_alpha && r.beta_missing == spread_beta) {
    return Status::Ok();
  }
  SubmapRegistrationParams reg = SubmapParams(voxel);
  const SubmapView source{Span<const PointXYZI>(beta_points_), Span<const Eigen::Vector3d>(beta_origins_)};
  const SubmapView target{Span<const PointXYZI>(alpha_points_), Span<const Eigen::Vector3d>(alpha_origins_)};
  auto fine = registration_.RefineFrom(source, target, reg, r.T_target_source_registered);
  note_memory();
  if (!fine.ok()) return fine.status();
  r.attempted = true;
  r.verdict = fine->verdict;
  r.overlap_ratio = fine->overlap_ratio;
  Moved(fine->T_target_source, r.T_target_source_registered, &r.moved_m, &r.moved_deg);
  r.taken = fine->success() && WithinCorrection(r.moved_m, r.moved_deg);
  if (r.taken) result->registration.T_target_source = fine->T_target_source;
  return RegisterPlaces(db, inbox, spread.alpha, spread.beta, places, voxel, result, note_memory);
}

SubmapRegistrationParams PairRegistrar::SubmapParams(double voxel_size_m) const {
  SubmapRegistrationParams reg = MakeSubmapRegistrationParams(voxel_size_m);
  reg.gates = params_.gates;
  reg.gates.max_points = std::max(reg.gates.max_points, params_.max_submap_points);
  return reg;
}

void PairRegistrar::Moved(const Eigen::Isometry3d& T_new, const Eigen::Isometry3d& T_old, double* moved_m,
                          double* moved_deg) {
  *moved_m = (T_new.translation() - T_old.translation()).norm();
  *moved_deg = RotationAngleRad((T_new * T_old.inverse()).linear()) * 180.0 / kPi;
}

bool PairRegistrar::WithinCorrection(double moved_m, double moved_deg) const {
  return moved_m <= params_.refine.max_correction_m && moved_deg <= params_.refine.max_correction_deg;
}

Status PairRegistrar::RegisterPlaces(const KeyframeDatabase& db, const ScanInbox& inbox, int alpha, int beta,
                                     Span<const std::pair<std::uint32_t, std::uint32_t>> places,
                                     double voxel_size_m, PairMergeResult* result,
                                     const std::function<void()>& note_memory) {
  const Eigen::Isometry3d T_final = result->registration.T_target_source;
  const SubmapRegistrationParams reg = SubmapParams(voxel_size_m);
  for (const auto& [alpha_keyframe, beta_keyframe] : places) {
    PlaceRegistration place;
    place.alpha_keyframe = alpha_keyframe;
    place.beta_keyframe = beta_keyframe;
    place.T_alpha_beta = T_final;
    PairSelection one;
    one.alpha = alpha;
    one.beta = beta;
    one.alpha_keyframes = {alpha_keyframe};
    one.beta_keyframes = {beta_keyframe};
    std::size_t alpha_scans = 0, beta_scans = 0, alpha_missing = 0, beta_missing = 0;
    BuildBoth(db, inbox, one, voxel_size_m, &alpha_scans, &beta_scans, &alpha_missing, &beta_missing, note_memory);
    if (alpha_scans == 1 && beta_scans == 1) {
      const SubmapView source{Span<const PointXYZI>(beta_points_), Span<const Eigen::Vector3d>(beta_origins_)};
      const SubmapView target{Span<const PointXYZI>(alpha_points_), Span<const Eigen::Vector3d>(alpha_origins_)};
      auto fine = registration_.RefineFrom(source, target, reg, T_final);
      note_memory();
      if (!fine.ok()) return fine.status();
      place.verdict = fine->verdict;
      Moved(fine->T_target_source, T_final, &place.moved_m, &place.moved_deg);
      place.success = fine->success() && WithinCorrection(place.moved_m, place.moved_deg);
      if (place.success) place.T_alpha_beta = fine->T_target_source;
    }
    result->refinement.places.push_back(place);
  }
  return Status::Ok();
}

void PairRegistrar::MeasureColocation(const KeyframeDatabase& db, const ExchangeCascadeResult& cascade,
                                      PairMergeResult* result) const {
  const RobotKeyframeDb& A = db.robot(result->alpha);
  const RobotKeyframeDb& B = db.robot(result->beta);
  // Stage A's cluster is where the descriptors chose the place: only the rest of the co-located keyframes is
  // independent evidence.
  const SequentialMatchResult& a = cascade.stage_a;
  const std::uint32_t from = a.found ? static_cast<std::uint32_t>(a.best.col_min) : 1;
  const std::uint32_t to = a.found ? static_cast<std::uint32_t>(a.best.col_max) : 0;
  std::size_t colocated_keyframes = 0;
  auto colocated = ColocatedKeyframes(
      {Span<const float>(A.descriptors), Span<const std::uint8_t>(A.valid), Span<const Eigen::Isometry3d>(A.T_map_sensor)},
      {Span<const float>(B.descriptors), Span<const std::uint8_t>(B.valid), Span<const Eigen::Isometry3d>(B.T_map_sensor)},
      A.dim, result->registration.T_target_source, params_.colocation, from, to, &colocated_keyframes,
      params_.cascade.metric);
  if (!colocated.ok()) return;
  result->colocated_keyframes = colocated_keyframes;
  result->colocated_chance = MedianChance(Span<const ColocatedKeyframe>(*colocated), 1, 0, nullptr);
}

Result<FrameSolution> PairRegistrar::SolveFrames(int max_robots, Span<const PairMergeResult> pairs) const {
  std::vector<FrameMeasurement> measurements;
  for (const PairMergeResult& p : pairs) {
    if (!p.merged()) continue;
    FrameMeasurement m;
    m.robot_a = p.alpha;
    m.robot_b = p.beta;
    m.T_a_b = p.registration.T_target_source;
    m.weight = static_cast<double>(std::max<std::size_t>(1, p.registration.num_fine_inliers));
    measurements.push_back(m);
  }
  return SolveRobotFrames(max_robots, Span<const FrameMeasurement>(measurements), params_.frames);
}

std::size_t PairRegistrar::SubmapBytes() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return held(scan_points_) + held(union_points_) + held(alpha_points_) + held(beta_points_) + held(alpha_origins_) +
         held(beta_origins_) + voxel_grid_.workspace_capacity_bytes();
}

}  // namespace commerge
