// SPDX-License-Identifier: BSD-3-Clause
// commerge: coarse-to-fine submap registration, the last stage of the server (paper "Submap-Based Map
// Merging"; ../shared/spec/REGISTRATION.md). Coarse: normals -> FPFH descriptors -> mutual ratio-test matching ->
// compatibility graph + maximum k-core -> GNC-TLS rotation + adaptive-voting translation (KISS-Matcher-style).
// Fine: GICP from the coarse estimate. T_final = T_fine * T_coarse (paper eq. "final transformation"; here
// the fine stage starts from T_coarse, so its output already is the composition).
// Success is gated conservatively: a wrong transform reported as success is the worst failure.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/registration/bev_search.hpp"
#include "core/registration/correspondence_pruning.hpp"
#include "core/registration/feature_matching.hpp"
#include "core/registration/gicp.hpp"
#include "core/registration/robust_solver.hpp"
#include "core/registration/submap_features.hpp"

namespace commerge {

/// Acceptance gates, checked in this order after each stage; the first that fails names the verdict.
struct RegistrationGates {
  std::size_t min_points = 100;           ///< per submap (finite points)
  /// Per submap: bounds memory. The buffers take about 0.85 KB per point and submap (neighbour lists 384 B,
  /// SPFH + descriptor 276 B, covariance 72 B, GICP factor 80 B), i.e. about 170 MB for two 100 k-point submaps.
  std::size_t max_points = 100000;
  std::size_t min_keypoints = 30;         ///< points with a descriptor, per submap
  std::size_t min_correspondences = 10;   ///< after mutual + ratio test
  std::size_t min_pruned_inliers = 10;    ///< maximum k-core (or clique) size
  std::size_t min_rotation_inliers = 8;   ///< GNC-TLS inliers
  std::size_t min_coarse_inliers = 10;    ///< translation-consistent final coarse inliers
  /// overlap_ratio = GICP inliers (GicpParams::inlier_distance_m and inlier_plane_distance_m) / source points.
  double min_overlap_ratio = 0.35;
  /// GicpResult::directional_overlap: matched share of the weakest direction the source constrains.
  double min_directional_overlap = 0.15;
  /// overlap_ratio x directional_overlap. A wrong alignment of two streets matches the road (high overlap) but
  /// not the facades across and along it (low directional overlap) (core/agent/decisions/014-registration-overlap-score.md).
  double min_overlap_score = 0.11;
  /// Translation block of the information: smallest / largest eigenvalue (1e-3 for one plane).
  double min_information_ratio = 0.005;
  /// The fine stage may move the coarse estimate at most this much; more means the coarse answer was not
  /// in the fine basin or the fine stage slid along a degenerate direction.
  double max_fine_correction_rad = 10.0 * kPi / 180.0;
  double max_fine_correction_m = 3.0;
};

struct SubmapRegistrationParams {
  /// Voxel size the submaps were downsampled with [m] (paper Delta-nu = 1 m); the other lengths scale with it.
  double voxel_size_m = 1.0;
  /// Coarse hypotheses tried: when the first one reaches the fine stage but fails verification, its pruned
  /// correspondences are removed and pruning + solver + GICP run again on the rest (1 = reference behaviour).
  int max_hypotheses = 2;
  /// Fallback coarse stage for gravity-aligned submaps (bev_search.hpp): when every feature hypothesis fails,
  /// the best bird's-eye-view (yaw, shift) candidates go through the same fine stage and gates.
  BevSearchParams global_search;
  SubmapFeatureParams features;
  FeatureMatchingParams matching;
  PruningParams pruning;
  RobustSolverParams solver;
  GicpParams fine;
  RegistrationGates gates;
};

/// Defaults of ../shared/spec/REGISTRATION.md §1.1 "Parameters, all scaled by the voxel size v" and §2.4
/// "Project configuration (our choice)" scaled by the voxel size v (>= 5e-3 m): normal radius 3v, FPFH
/// radius 5v, graph bound min(v, 1 m), solver bound min(0.75 v, 1 m), GICP gate 5v, overlap inlier distance v,
/// fine correction 3v; global search cell v, vertical extent 0.5v, candidate separation 4v.
SubmapRegistrationParams MakeSubmapRegistrationParams(double voxel_size_m);

/// InvalidArgument naming the first field out of range (every component validated, plus the spec's
/// epsilon_R >= epsilon_S and voxel_size_m >= 5e-3).
Status ValidateSubmapRegistrationParams(const SubmapRegistrationParams& params);

/// One submap: voxelised points in the submap frame and the sensor positions of the scans it was built from
/// (same frame; used to orient normals; empty = the frame origin).
struct SubmapView {
  Span<const PointXYZI> points;
  Span<const Eigen::Vector3d> sensor_origins_m;
};

enum class RegistrationVerdict : std::uint8_t {
  kSuccess = 0,
  kNonFiniteInput,            ///< a point (or sensor origin) has a NaN / inf coordinate
  kTooFewPoints,              ///< a submap has fewer than gates.min_points points
  kTooManyPoints,             ///< a submap has more than gates.max_points points
  kTooFewKeypoints,           ///< a submap has fewer than gates.min_keypoints descriptors
  kTooFewCorrespondences,     ///< descriptor matching kept too few pairs
  kTooFewInliersAfterPruning, ///< the maximum k-core / clique is too small
  kGncFailed,                 ///< GNC-TLS rotation: too few inliers or no valid rotation
  kTooFewCoarseInliers,       ///< too few translation-consistent correspondences
  kNotConverged,              ///< GICP did not converge (LM stalled or iteration limit)
  kOverlapTooLow,             ///< overlap_ratio, directional_overlap or their product below its gate
  kDegenerate,                ///< the information leaves a translation direction unconstrained
  kCoarseFineDisagree,        ///< the fine stage moved the coarse estimate too far
};

/// "success", "non-finite input", "too few points", ... (stable, for logs and tables).
const char* RegistrationVerdictName(RegistrationVerdict verdict) noexcept;

struct RegistrationResult {
  RegistrationVerdict verdict = RegistrationVerdict::kTooFewPoints;
  bool success() const noexcept { return verdict == RegistrationVerdict::kSuccess; }

  /// Final estimate p_target = T_target_source p_source: the fine result when the fine stage ran, else the
  /// coarse one when it exists, else identity. Meaningful only on success.
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_target_source_coarse = Eigen::Isometry3d::Identity();

  std::size_t num_source_points = 0;
  std::size_t num_target_points = 0;
  std::size_t num_source_keypoints = 0;
  std::size_t num_target_keypoints = 0;
  std::size_t num_correspondences = 0;    ///< after matching (mutual, ratio test, cap)
  std::size_t num_pruned_inliers = 0;     ///< after the maximum k-core / clique
  std::size_t num_rotation_inliers = 0;   ///< after GNC-TLS (chained measurements)
  std::size_t num_coarse_inliers = 0;     ///< translation-consistent (the coarse stage's final inliers)
  std::size_t num_fine_correspondences = 0;  ///< GICP pairs within the correspondence gate
  std::size_t num_fine_inliers = 0;       ///< GICP pairs within inlier_distance_m (after GICP)
  double overlap_ratio = 0.0;             ///< num_fine_inliers / num_source_points
  double directional_overlap = 0.0;       ///< GicpResult::directional_overlap
  double fitness_rmse_m = 0.0;            ///< RMS distance of the fine inliers [m]
  int hypotheses = 0;                     ///< feature hypotheses tried (see SubmapRegistrationParams)
  int global_candidates = 0;              ///< bird's-eye-view candidates verified by GICP and the gates
  /// Best global-search score / best distinct runner-up (0: the search did not run or found nothing; a single
  /// candidate counts as infinitely distinct). Below BevSearchParams::min_peak_ratio nothing is verified.
  double global_peak_ratio = 0.0;
  /// The success came from a global search candidate (the feature-stage counts above then describe the failed
  /// feature attempt). A failure always reports the feature attempt's verdict and estimate.
  bool from_global_search = false;
  int gnc_iterations = 0;
  int gicp_iterations = 0;
  bool gicp_converged = false;
  double information_ratio = 0.0;         ///< smallest / largest eigenvalue of H's translation block
  Matrix6d information = Matrix6d::Zero();  ///< GICP H, order [translation; rotation] (se3's twists)
  double fine_correction_rad = 0.0;       ///< rotation between the coarse and the final estimate
  double fine_correction_m = 0.0;         ///< translation between them (source origin displacement)
};

/// Pipeline stages, reported to a RegistrationStageObserver (the benchmark times them; core has no clock).
enum class RegistrationStage : std::uint8_t {
  kNormals,   ///< neighbour lists, normals, covariances (both submaps)
  kFeatures,  ///< keypoints and descriptors (both submaps)
  kMatching,
  kPruning,
  kSolver,    ///< GNC-TLS rotation + translation
  kFine,      ///< the target's k-d tree (first run only), GICP and the final evaluation
  kGlobalSearch,  ///< the bird's-eye-view fallback search (its candidates' GICP runs are timed as kFine)
};
inline constexpr int kNumRegistrationStages = 7;
const char* RegistrationStageName(RegistrationStage stage) noexcept;

/// Optional hook called around every stage that runs.
class RegistrationStageObserver {
 public:
  virtual ~RegistrationStageObserver() = default;
  virtual void OnStageBegin(RegistrationStage stage) = 0;
  virtual void OnStageEnd(RegistrationStage stage) = 0;
};

/// Reusable coarse-to-fine registration. Keeps every per-call buffer (features, trees, correspondences) so
/// that repeated calls on similar sizes allocate little; stateless otherwise (no result carries over between
/// calls). Single-threaded and deterministic: the same inputs give a bit-identical result. Not thread-safe.
class SubmapRegistration {
 public:
  SubmapRegistration() = default;

  /// Registers `source` to `target`. Errors (Status): invalid params only. Every data-dependent failure
  /// (empty, NaN, too few points, no overlap, degenerate geometry, ...) is a result with a failure verdict.
  /// The point spans must stay valid for the duration of the call (the inspection accessors below refer to them
  /// until the next call).
  Result<RegistrationResult> Register(const SubmapView& source, const SubmapView& target,
                                      const SubmapRegistrationParams& params,
                                      RegistrationStageObserver* observer = nullptr);

  /// Stage 6 alone (GICP from `T_target_source_guess`, then the same gates as Register) on the submaps of the
  /// last Register call, whose neighbourhoods, normals and covariances it reuses; only `params.fine` and
  /// `params.gates` are read. It answers whether a transform known from elsewhere (ground truth, a chain of
  /// other robot pairs) passes the verification that Register's own estimates must pass. The verdict is
  /// kNotConverged, kOverlapTooLow, kDegenerate, kCoarseFineDisagree or kSuccess; T_target_source_coarse is
  /// the guess. Errors (InvalidArgument): invalid params, a non-finite guess, or no neighbourhoods to reuse
  /// because the last Register call stopped before stage 1 (no call yet, non-finite input, too few or too
  /// many points). The submaps' point spans must still be valid.
  Result<RegistrationResult> VerifyFrom(const SubmapRegistrationParams& params,
                                        const Eigen::Isometry3d& T_target_source_guess);

  /// Stages 1 and 6 alone on new submaps: neighbourhoods, normals and covariances of `source` and `target`, then
  /// GICP from `T_target_source_guess` and the gates, as Register's fine stage. For submaps of a pair registered
  /// before from fewer scans (a final refinement on more of the path the robots share). The input checks are
  /// Register's (kNonFiniteInput, kTooFewPoints, kTooManyPoints), the fine stage's verdicts VerifyFrom's;
  /// T_target_source_coarse is the guess. Errors (InvalidArgument): invalid params or a non-finite guess.
  /// VerifyFrom may follow on these submaps.
  Result<RegistrationResult> RefineFrom(const SubmapView& source, const SubmapView& target,
                                        const SubmapRegistrationParams& params,
                                        const Eigen::Isometry3d& T_target_source_guess,
                                        RegistrationStageObserver* observer = nullptr);

  /// Inspection of the last call (tests, diagnostics).
  const SubmapFeatures& source_features() const noexcept { return source_; }
  const SubmapFeatures& target_features() const noexcept { return target_; }
  const std::vector<Correspondence>& correspondences() const noexcept { return correspondences_; }
  /// Indices into correspondences() kept by pruning (of the last hypothesis tried).
  const std::vector<std::uint32_t>& pruned() const noexcept { return pruned_; }
  /// Bytes every buffer of the registration holds (features and k-d trees of both submaps, matcher, GICP,
  /// global search, correspondences; capacities, kept between calls).
  std::size_t workspace_bytes() const;

 private:
  // Step 0 of Register and RefineFrom: clears the last call's state, fills r's point counts and sets the verdict
  // of a non-finite input or a point count outside the gates (false then).
  bool CheckInputs(const SubmapView& source, const SubmapView& target, const RegistrationGates& gates,
                   RegistrationResult* r);
  // Stages 4-6 (pruning, robust solver, GICP and gates) for one hypothesis; fills *out.
  Status RunHypothesis(const SubmapRegistrationParams& params, RegistrationStageObserver* observer,
                       RegistrationResult* out);
  // Stage 6 (GICP from T_coarse and the gates); fills the fine-stage fields and the verdict of *out.
  void RunFine(const SubmapRegistrationParams& params, const Eigen::Isometry3d& T_coarse,
               RegistrationStageObserver* observer, RegistrationResult* out);
  // The fallback: global search candidates through RunFine; returns the first success or the last failure.
  Status RunGlobalSearch(const SubmapView& source, const SubmapView& target, const SubmapRegistrationParams& params,
                         RegistrationStageObserver* observer, RegistrationResult* inout);

  SubmapFeatures source_;
  SubmapFeatures target_;
  bool geometry_ready_ = false;  // stage 1 ran in the last Register call (VerifyFrom may use it)
  FeatureMatcher matcher_;
  Gicp gicp_;
  BevSearch bev_;
  std::vector<BevCandidate> bev_candidates_;
  std::vector<Correspondence> correspondences_;
  std::vector<std::uint32_t> pruned_;
  std::vector<std::uint8_t> excluded_;
  std::vector<std::uint32_t> active_;
  std::vector<Eigen::Vector3f> corr_a_, corr_b_, active_a_, active_b_;
  std::vector<Eigen::Vector3d> solver_a_, solver_b_;
};

/// One-shot convenience: SubmapRegistration().Register(...).
Result<RegistrationResult> RegisterSubmaps(const SubmapView& source, const SubmapView& target,
                                           const SubmapRegistrationParams& params);

}  // namespace commerge
