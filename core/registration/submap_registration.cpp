// SPDX-License-Identifier: BSD-3-Clause
// Coarse-to-fine submap registration pipeline (../shared/spec/REGISTRATION.md §1.2 "Pipeline", §2 "GICP (fine),
// small_gicp style", §3 "How the authors chain the two").
#include "core/registration/submap_registration.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace commerge {
namespace {

class StageScope {
 public:
  StageScope(RegistrationStageObserver* observer, RegistrationStage stage) : observer_(observer), stage_(stage) {
    if (observer_) observer_->OnStageBegin(stage_);
  }
  ~StageScope() {
    if (observer_) observer_->OnStageEnd(stage_);
  }
  StageScope(const StageScope&) = delete;
  StageScope& operator=(const StageScope&) = delete;

 private:
  RegistrationStageObserver* observer_;
  RegistrationStage stage_;
};

bool AllFinite(const SubmapView& v) {
  for (const PointXYZI& p : v.points) {
    if (!IsFinite(p)) return false;
  }
  for (const Eigen::Vector3d& o : v.sensor_origins_m) {
    if (!o.allFinite()) return false;
  }
  return true;
}

}  // namespace

const char* RegistrationVerdictName(RegistrationVerdict verdict) noexcept {
  switch (verdict) {
    case RegistrationVerdict::kSuccess: return "success";
    case RegistrationVerdict::kNonFiniteInput: return "non-finite input";
    case RegistrationVerdict::kTooFewPoints: return "too few points";
    case RegistrationVerdict::kTooManyPoints: return "too many points";
    case RegistrationVerdict::kTooFewKeypoints: return "too few keypoints";
    case RegistrationVerdict::kTooFewCorrespondences: return "too few correspondences";
    case RegistrationVerdict::kTooFewInliersAfterPruning: return "too few inliers after pruning";
    case RegistrationVerdict::kGncFailed: return "GNC failed";
    case RegistrationVerdict::kTooFewCoarseInliers: return "too few coarse inliers";
    case RegistrationVerdict::kNotConverged: return "not converged";
    case RegistrationVerdict::kOverlapTooLow: return "overlap too low";
    case RegistrationVerdict::kDegenerate: return "degenerate";
    case RegistrationVerdict::kCoarseFineDisagree: return "coarse and fine disagree";
  }
  return "unknown";
}

const char* RegistrationStageName(RegistrationStage stage) noexcept {
  switch (stage) {
    case RegistrationStage::kNormals: return "normals";
    case RegistrationStage::kFeatures: return "features";
    case RegistrationStage::kMatching: return "matching";
    case RegistrationStage::kPruning: return "pruning";
    case RegistrationStage::kSolver: return "gnc";
    case RegistrationStage::kFine: return "gicp";
    case RegistrationStage::kGlobalSearch: return "global";
  }
  return "unknown";
}

SubmapRegistrationParams MakeSubmapRegistrationParams(double v) {
  SubmapRegistrationParams p;
  p.voxel_size_m = v;
  p.features.normal_radius_m = 3.0 * v;
  p.features.fpfh_radius_m = 5.0 * v;
  p.pruning.noise_bound_m = std::min(1.0 * v, 1.0);
  p.solver.noise_bound_m = std::min(0.75 * v, 1.0);
  p.fine.max_correspondence_distance_m = 5.0 * v;
  p.fine.refine_correspondence_distance_m = 1.5 * v;
  p.fine.inlier_distance_m = 1.0 * v;
  p.fine.inlier_plane_distance_m = 0.3 * v;
  p.gates.max_fine_correction_m = 3.0 * v;
  p.global_search.cell_size_m = v;
  p.global_search.min_vertical_extent_m = 0.5 * v;
  p.global_search.min_separation_m = 4.0 * v;
  return p;
}

Status ValidateSubmapRegistrationParams(const SubmapRegistrationParams& p) {
  if (!(std::isfinite(p.voxel_size_m) && p.voxel_size_m >= 5e-3)) {
    return InvalidArgument("registration: voxel_size_m must be finite and >= 5e-3");
  }
  if (p.max_hypotheses < 1 || p.max_hypotheses > 8) {
    return InvalidArgument("registration: max_hypotheses must be in [1, 8]");
  }
  Status s = ValidateSubmapFeatureParams(p.features);
  if (s.ok()) s = ValidateFeatureMatchingParams(p.matching);
  if (s.ok()) s = ValidatePruningParams(p.pruning);
  if (s.ok()) s = ValidateRobustSolverParams(p.solver);
  if (s.ok()) s = ValidateGicpParams(p.fine);
  if (s.ok()) s = ValidateBevSearchParams(p.global_search);
  if (!s.ok()) return s;
  if (p.pruning.noise_bound_m < p.solver.noise_bound_m) {
    return InvalidArgument("registration: pruning.noise_bound_m (epsilon_R) must be >= solver.noise_bound_m (epsilon_S)");
  }
  const RegistrationGates& g = p.gates;
  if (g.min_points < 10 || g.max_points < g.min_points || g.max_points > 4'000'000) {
    return InvalidArgument("registration gates: need 10 <= min_points <= max_points <= 4000000");
  }
  if (g.min_correspondences < 3 || g.min_pruned_inliers < 3 || g.min_rotation_inliers < 2 || g.min_coarse_inliers < 3) {
    return InvalidArgument(
        "registration gates: min_correspondences, min_pruned_inliers, min_coarse_inliers must be >= 3, "
        "min_rotation_inliers >= 2");
  }
  if (!(g.min_overlap_ratio >= 0.0 && g.min_overlap_ratio <= 1.0) ||
      !(g.min_directional_overlap >= 0.0 && g.min_directional_overlap <= 1.0) ||
      !(g.min_overlap_score >= 0.0 && g.min_overlap_score <= 1.0) ||
      !(g.min_information_ratio >= 0.0 && g.min_information_ratio <= 1.0)) {
    return InvalidArgument("registration gates: overlap and information ratios must be in [0, 1]");
  }
  if (!(g.max_fine_correction_rad > 0.0) || !(g.max_fine_correction_m > 0.0)) {
    return InvalidArgument("registration gates: max_fine_correction_rad and max_fine_correction_m must be > 0");
  }
  return Status::Ok();
}

Result<RegistrationResult> SubmapRegistration::Register(const SubmapView& source, const SubmapView& target,
                                                        const SubmapRegistrationParams& params,
                                                        RegistrationStageObserver* observer) {
  const Status valid = ValidateSubmapRegistrationParams(params);
  if (!valid.ok()) return valid;
  const RegistrationGates& gates = params.gates;
  RegistrationResult r;
  // 0. Input checks: bad data is a verdict, never a crash.
  if (!CheckInputs(source, target, gates, &r)) return r;

  // 1. Neighbourhoods, normals, covariances (spec §1.2 steps 2-3, §2.1).
  {
    StageScope scope(observer, RegistrationStage::kNormals);
    source_.ComputeGeometry(source.points, source.sensor_origins_m, params.features);
    target_.ComputeGeometry(target.points, target.sensor_origins_m, params.features);
  }
  geometry_ready_ = true;
  // 2. Keypoints and descriptors (steps 4-7).
  {
    StageScope scope(observer, RegistrationStage::kFeatures);
    source_.ComputeDescriptors(params.features);
    target_.ComputeDescriptors(params.features);
  }
  r.num_source_keypoints = source_.keypoints().size();
  r.num_target_keypoints = target_.keypoints().size();
  if (r.num_source_keypoints < gates.min_keypoints || r.num_target_keypoints < gates.min_keypoints) {
    r.verdict = RegistrationVerdict::kTooFewKeypoints;
    const Status s = RunGlobalSearch(source, target, params, observer, &r);
    if (!s.ok()) return s;
    return r;
  }

  // 3. Mutual ratio-test matching (step 8).
  {
    StageScope scope(observer, RegistrationStage::kMatching);
    matcher_.Match(source_, target_, params.matching, &correspondences_);
  }
  r.num_correspondences = correspondences_.size();
  if (r.num_correspondences < gates.min_correspondences) {
    r.verdict = RegistrationVerdict::kTooFewCorrespondences;
    const Status s = RunGlobalSearch(source, target, params, observer, &r);
    if (!s.ok()) return s;
    return r;
  }

  // Positions of every correspondence (a: source, b: target).
  corr_a_.resize(correspondences_.size());
  corr_b_.resize(correspondences_.size());
  for (std::size_t k = 0; k < correspondences_.size(); ++k) {
    const PointXYZI& a = source.points[correspondences_[k].source_index];
    const PointXYZI& b = target.points[correspondences_[k].target_index];
    corr_a_[k] = Eigen::Vector3f(a.x, a.y, a.z);
    corr_b_[k] = Eigen::Vector3f(b.x, b.y, b.z);
  }

  // Stages 4-6, once per hypothesis: a hypothesis that fails verification (e.g. a street matched to itself
  // turned by 180 deg) removes its pruned correspondences and the next one is tried on the rest. The result of
  // the first hypothesis is reported unless a later one succeeds.
  excluded_.assign(correspondences_.size(), 0);
  RegistrationResult first;
  for (int h = 0; h < params.max_hypotheses; ++h) {
    RegistrationResult attempt = r;
    attempt.hypotheses = h + 1;
    const Status status = RunHypothesis(params, observer, &attempt);
    if (!status.ok()) return status;
    if (attempt.success()) return attempt;
    if (h == 0) first = attempt;
    first.hypotheses = h + 1;
    // Only a hypothesis that reached the fine stage is worth another one; earlier failures are final.
    if (attempt.verdict < RegistrationVerdict::kNotConverged) break;
    for (std::uint32_t k : pruned_) excluded_[k] = 1;
  }
  const Status s = RunGlobalSearch(source, target, params, observer, &first);
  if (!s.ok()) return s;
  return first;
}

bool SubmapRegistration::CheckInputs(const SubmapView& source, const SubmapView& target,
                                     const RegistrationGates& gates, RegistrationResult* r) {
  correspondences_.clear();
  pruned_.clear();
  geometry_ready_ = false;
  r->num_source_points = source.points.size();
  r->num_target_points = target.points.size();
  if (!AllFinite(source) || !AllFinite(target)) {
    r->verdict = RegistrationVerdict::kNonFiniteInput;
  } else if (r->num_source_points < gates.min_points || r->num_target_points < gates.min_points) {
    r->verdict = RegistrationVerdict::kTooFewPoints;
  } else if (r->num_source_points > gates.max_points || r->num_target_points > gates.max_points) {
    r->verdict = RegistrationVerdict::kTooManyPoints;
  } else {
    return true;
  }
  return false;
}

Result<RegistrationResult> SubmapRegistration::RefineFrom(const SubmapView& source, const SubmapView& target,
                                                          const SubmapRegistrationParams& params,
                                                          const Eigen::Isometry3d& T_target_source_guess,
                                                          RegistrationStageObserver* observer) {
  const Status valid = ValidateSubmapRegistrationParams(params);
  if (!valid.ok()) return valid;
  if (!T_target_source_guess.matrix().allFinite()) {
    return InvalidArgument("registration: RefineFrom needs a finite T_target_source_guess");
  }
  RegistrationResult r;
  r.T_target_source_coarse = T_target_source_guess;
  r.T_target_source = T_target_source_guess;
  if (!CheckInputs(source, target, params.gates, &r)) return r;
  {
    StageScope scope(observer, RegistrationStage::kNormals);
    source_.ComputeGeometry(source.points, source.sensor_origins_m, params.features);
    target_.ComputeGeometry(target.points, target.sensor_origins_m, params.features);
  }
  geometry_ready_ = true;
  RunFine(params, T_target_source_guess, observer, &r);
  return r;
}

Status SubmapRegistration::RunGlobalSearch(const SubmapView& source, const SubmapView& target,
                                           const SubmapRegistrationParams& params, RegistrationStageObserver* observer,
                                           RegistrationResult* inout) {
  if (!params.global_search.enabled) return Status::Ok();
  {
    StageScope scope(observer, RegistrationStage::kGlobalSearch);
    const Status s = bev_.Search(source.points, target.points, params.global_search, &bev_candidates_);
    if (!s.ok()) return s;
  }
  if (bev_candidates_.empty()) return Status::Ok();
  const BevCandidate& best = bev_candidates_.front();
  inout->global_peak_ratio = bev_candidates_.size() < 2 || !(bev_candidates_[1].score > 0.0)
                                 ? std::numeric_limits<double>::infinity()
                                 : best.score / bev_candidates_[1].score;
  if (!(inout->global_peak_ratio >= params.global_search.min_peak_ratio)) return Status::Ok();
  RegistrationResult attempt = *inout;
  attempt.global_candidates = 1;
  attempt.from_global_search = true;
  attempt.T_target_source_coarse = best.T_target_source;
  RunFine(params, best.T_target_source, observer, &attempt);
  if (attempt.success()) {
    *inout = attempt;
  } else {
    inout->global_candidates = 1;
  }
  return Status::Ok();
}

Status SubmapRegistration::RunHypothesis(const SubmapRegistrationParams& params, RegistrationStageObserver* observer,
                                         RegistrationResult* out) {
  const RegistrationGates& gates = params.gates;
  RegistrationResult& r = *out;
  // 4. Compatibility graph + maximum k-core (steps 9-10) over the correspondences not yet excluded.
  {
    StageScope scope(observer, RegistrationStage::kPruning);
    active_.clear();
    active_a_.clear();
    active_b_.clear();
    for (std::size_t k = 0; k < correspondences_.size(); ++k) {
      if (excluded_[k]) continue;
      active_.push_back(static_cast<std::uint32_t>(k));
      active_a_.push_back(corr_a_[k]);
      active_b_.push_back(corr_b_[k]);
    }
    auto pruning = PruneCorrespondences(active_a_, active_b_, params.pruning, &pruned_);
    if (!pruning.ok()) return pruning.status();
    for (std::uint32_t& k : pruned_) k = active_[k];  // back to indices into correspondences()
  }
  r.num_pruned_inliers = pruned_.size();
  if (r.num_pruned_inliers < gates.min_pruned_inliers) {
    r.verdict = RegistrationVerdict::kTooFewInliersAfterPruning;
    return Status::Ok();
  }

  // 5. GNC-TLS rotation + per-axis TLS translation (steps 11-12).
  RobustRegistrationResult coarse;
  {
    StageScope scope(observer, RegistrationStage::kSolver);
    solver_a_.resize(pruned_.size());
    solver_b_.resize(pruned_.size());
    for (std::size_t k = 0; k < pruned_.size(); ++k) {
      solver_a_[k] = corr_a_[pruned_[k]].cast<double>();
      solver_b_[k] = corr_b_[pruned_[k]].cast<double>();
    }
    coarse = SolveRobustRegistration(solver_a_, solver_b_, params.solver);
  }
  r.num_rotation_inliers = coarse.num_rotation_inliers;
  r.num_coarse_inliers = coarse.num_final_inliers;
  r.gnc_iterations = coarse.gnc_iterations;
  if (coarse.num_rotation_inliers < gates.min_rotation_inliers || coarse.num_rotation_inliers < 2 ||
      !coarse.T_target_source.matrix().allFinite()) {
    r.verdict = RegistrationVerdict::kGncFailed;
    return Status::Ok();
  }
  r.T_target_source_coarse = coarse.T_target_source;
  r.T_target_source = coarse.T_target_source;
  if (!coarse.valid || r.num_coarse_inliers < gates.min_coarse_inliers) {
    r.verdict = RegistrationVerdict::kTooFewCoarseInliers;
    return Status::Ok();
  }

  RunFine(params, coarse.T_target_source, observer, out);
  return Status::Ok();
}

void SubmapRegistration::RunFine(const SubmapRegistrationParams& params, const Eigen::Isometry3d& T_coarse,
                                 RegistrationStageObserver* observer, RegistrationResult* out) {
  const RegistrationGates& gates = params.gates;
  RegistrationResult& r = *out;
  // 6. GICP from the coarse estimate (spec §2.2, §2.4), then the acceptance gates (§1.3, §3).
  GicpResult fine;
  {
    StageScope scope(observer, RegistrationStage::kFine);
    fine = gicp_.Align(source_, target_, T_coarse, params.fine);
  }
  r.T_target_source = fine.T_target_source;
  r.gicp_iterations = fine.iterations;
  r.gicp_converged = fine.converged;
  r.num_fine_correspondences = fine.num_correspondences;
  r.num_fine_inliers = fine.num_inliers;
  r.overlap_ratio = static_cast<double>(fine.num_inliers) / static_cast<double>(r.num_source_points);
  r.directional_overlap = fine.directional_overlap;
  r.fitness_rmse_m = fine.inlier_rmse_m;
  r.information = fine.H;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> info(fine.H.topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly);
  const double info_max = info.eigenvalues()(2);
  r.information_ratio = info_max > 0.0 ? std::max(0.0, info.eigenvalues()(0)) / info_max : 0.0;
  const Eigen::Isometry3d correction = fine.T_target_source * T_coarse.inverse();
  r.fine_correction_rad = RotationAngleRad(correction.linear());
  r.fine_correction_m = (fine.T_target_source.translation() - T_coarse.translation()).norm();

  if (!fine.converged || !fine.T_target_source.matrix().allFinite()) {
    r.verdict = RegistrationVerdict::kNotConverged;
  } else if (r.overlap_ratio < gates.min_overlap_ratio || r.directional_overlap < gates.min_directional_overlap ||
             r.overlap_ratio * r.directional_overlap < gates.min_overlap_score) {
    r.verdict = RegistrationVerdict::kOverlapTooLow;
  } else if (!(r.information_ratio >= gates.min_information_ratio)) {
    r.verdict = RegistrationVerdict::kDegenerate;
  } else if (r.fine_correction_rad > gates.max_fine_correction_rad || r.fine_correction_m > gates.max_fine_correction_m) {
    r.verdict = RegistrationVerdict::kCoarseFineDisagree;
  } else {
    r.verdict = RegistrationVerdict::kSuccess;
  }
}

Result<RegistrationResult> SubmapRegistration::VerifyFrom(const SubmapRegistrationParams& params,
                                                          const Eigen::Isometry3d& T_target_source_guess) {
  const Status valid = ValidateSubmapRegistrationParams(params);
  if (!valid.ok()) return valid;
  if (!T_target_source_guess.matrix().allFinite()) {
    return InvalidArgument("registration: VerifyFrom needs a finite T_target_source_guess");
  }
  if (!geometry_ready_) {
    return InvalidArgument(
        "registration: VerifyFrom needs a previous Register call that reached stage 1 (finite inputs with "
        "gates.min_points to gates.max_points points)");
  }
  RegistrationResult r;
  r.num_source_points = source_.points().size();
  r.num_target_points = target_.points().size();
  r.T_target_source_coarse = T_target_source_guess;
  RunFine(params, T_target_source_guess, nullptr, &r);
  return r;
}

Result<RegistrationResult> RegisterSubmaps(const SubmapView& source, const SubmapView& target,
                                           const SubmapRegistrationParams& params) {
  SubmapRegistration registration;
  return registration.Register(source, target, params);
}

std::size_t SubmapRegistration::workspace_bytes() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return source_.workspace_bytes() + target_.workspace_bytes() + matcher_.workspace_bytes() + gicp_.workspace_bytes() +
         bev_.workspace_bytes() + held(bev_candidates_) + held(correspondences_) + held(pruned_) + held(excluded_) +
         held(active_) + held(corr_a_) + held(corr_b_) + held(active_a_) + held(active_b_) + held(solver_a_) +
         held(solver_b_);
}

}  // namespace commerge
