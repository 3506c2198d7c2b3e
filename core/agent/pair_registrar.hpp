// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's pair registrar (budget modules "submaps" and "registration"): builds the two submaps of a
// pair from the received scans (paper eqs. M_alpha, M_beta), registers them coarse to fine, measures the evidence
// that only a registered transform gives (the gap to the consensus placement, the descriptors' agreement where it
// joins the robots), asks DecideAccept, and combines accepted pairs into one frame per robot.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/exchange_planner.hpp"
#include "core/agent/keyframe_database.hpp"
#include "core/agent/merge_server_params.hpp"
#include "core/agent/pair_decision.hpp"
#include "core/agent/scan_inbox.hpp"
#include "core/cloud/point.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/merge/frame_solver.hpp"
#include "core/registration/submap_registration.hpp"

namespace commerge {

/// The final refinement of an accepted pair (core/agent/pair_refinement.hpp).
/// One place along the shared path registered on its own (one scan of each robot, the fine stage alone from the
/// pair's final transform): an inter-robot edge for the joint pose graph (core/merge/joint_graph.hpp). Where the
/// robots' maps drift apart along their shared path, the places' transforms differ from the pair's one.
struct PlaceRegistration {
  std::uint32_t alpha_keyframe = 0, beta_keyframe = 0;
  bool success = false;  ///< both scans held, the fine stage's gates passed, moved within the refinement's bounds
  RegistrationVerdict verdict = RegistrationVerdict::kTooFewPoints;
  /// T_alpha_beta measured at this place (p_alpha = T p_beta); the pair's final transform when not success.
  Eigen::Isometry3d T_alpha_beta = Eigen::Isometry3d::Identity();
  double moved_m = 0.0, moved_deg = 0.0;  ///< against the pair's final transform
};

struct PairRefinement {
  bool attempted = false;  ///< spread scans were received and the fine stage ran on them
  bool taken = false;      ///< its transform replaced the registered one (gates passed, moved within bounds)
  std::size_t alpha_scans = 0, beta_scans = 0;  ///< spread scans used (on top of the registered selection)
  std::size_t alpha_missing = 0, beta_missing = 0;  ///< spread scans asked for and not received
  RegistrationVerdict verdict = RegistrationVerdict::kTooFewPoints;  ///< the fine stage's on the refined submaps
  double overlap_ratio = 0.0;
  double moved_m = 0.0;    ///< beta's map origin moved by the refined transform against the registered one
  double moved_deg = 0.0;  ///< rotation between the two
  /// The registered transform (before refinement; registration.T_target_source holds the refined one when taken).
  Eigen::Isometry3d T_target_source_registered = Eigen::Isometry3d::Identity();
  /// The spread places registered one by one (the anchor first), when the refinement ran.
  std::vector<PlaceRegistration> places;
};

/// What registering one pair produced.
struct PairMergeResult {
  int alpha = 0, beta = 0;
  bool attempted = false;           ///< false: nothing selected or no scan received (see stop and reason)
  /// Where the pair stopped (kNone: accepted); `reason` in words (the failed verdict, the figures behind a check,
  /// or why it was not attempted).
  PairStop stop = PairStop::kNothingSelected;
  std::string reason;
  std::size_t alpha_scans = 0, beta_scans = 0;        ///< received scans used
  std::size_t alpha_missing = 0, beta_missing = 0;    ///< selected but not received
  std::size_t alpha_submap_points = 0, beta_submap_points = 0;
  double voxel_size_m = 0.0;        ///< of the submaps
  RegistrationResult registration;  ///< T_target_source = T_alpha_beta (p_alpha = T p_beta); geometry verdict only
  /// > 0: this round could not register the pair for missing scans (reason says why); the result is the one
  /// that round verified for the same two robot sessions (ServerLink keeps it; see KeepVerifiedPairs).
  int kept_from_round = 0;
  /// Descriptor agreement of a registered transform (decision.max_colocated_chance): beta keyframes outside stage
  /// A's cluster it places on top of alpha's, and their median chance (-1 when not measured).
  std::size_t colocated_keyframes = 0;
  double colocated_chance = -1.0;
  PairRefinement refinement;
  /// Registered and accepted (DecideAccept): the transform joins the two maps.
  bool merged() const noexcept { return attempted && stop == PairStop::kNone; }
  /// Registered, with a transform (accepted, or refused by a check after registration's gates passed).
  bool has_transform() const noexcept { return attempted && registration.success(); }
};

/// The verdict of an attempted pair for messages and logs: "success", the registration verdict's name, or the
/// stop's name for a check after registration (PairStopName).
const char* PairVerdictName(const PairMergeResult& result) noexcept;

class PairRegistrar {
 public:
  /// Parameters as MergeServer holds them (checked by ValidateMergeServerParams).
  explicit PairRegistrar(const MergeServerParams& params) : params_(params) {}

  /// Submap of one robot (map frame points) from received scans of `keyframes`, voxelised at voxel_size_m.
  /// Returns the number of scans used; missing ones are counted in *missing. `note_memory` is called at the end.
  std::size_t BuildSubmap(const KeyframeDatabase& db, const ScanInbox& inbox, int robot,
                          Span<const std::uint32_t> keyframes, double voxel_size_m, std::vector<PointXYZI>* points,
                          std::vector<Eigen::Vector3d>* sensor_origins, std::size_t* missing,
                          const std::function<void()>& note_memory);

  /// Builds the two submaps of `pair`, registers beta's onto alpha's, and asks DecideAccept. `cascade` and
  /// `evidence`: the pair's from the last cascades (nullptr when it has none: no placement or descriptor check).
  /// `note_memory` is called after each submap and after registration.
  Result<PairMergeResult> MergePair(const KeyframeDatabase& db, const ScanInbox& inbox, const PairSelection& pair,
                                    const ExchangeCascadeResult* cascade, const PairEvidence* evidence,
                                    RegistrationStageObserver* observer, const std::function<void()>& note_memory);

  /// The final refinement of an accepted `result` (pair_refinement.hpp): beta's submap onto alpha's from the scans of
  /// `spread` (the pair's registered selection plus the spread keyframes) by the fine stage alone from the registered
  /// transform; fills result->refinement and, when taken, result->registration.T_target_source. A pair not merged,
  /// or whose spread scans all went missing, is left as it is. Then each of `places` (alpha's keyframe, beta's)
  /// is registered on its own from the final transform (result->refinement.places).
  Status RefinePair(const KeyframeDatabase& db, const ScanInbox& inbox, const PairSelection& spread,
                    std::size_t spread_alpha, std::size_t spread_beta,
                    Span<const std::pair<std::uint32_t, std::uint32_t>> places, PairMergeResult* result,
                    const std::function<void()>& note_memory);

  /// Combines accepted pairwise results into one frame per robot (world = robot 0's map frame).
  Result<FrameSolution> SolveFrames(int max_robots, Span<const PairMergeResult> pairs) const;

  /// Bytes of the decoded scan, union and both submaps, sensor origins and the voxel grid's workspace (module
  /// "submaps"); of SubmapRegistration::workspace_bytes (module "registration").
  std::size_t SubmapBytes() const;
  std::size_t RegistrationBytes() const { return registration_.workspace_bytes(); }

 private:
  // Both submaps of `pair` at voxel_size_m (BuildSubmap each); true when both fit max_submap_points.
  bool BuildBoth(const KeyframeDatabase& db, const ScanInbox& inbox, const PairSelection& pair, double voxel_size_m,
                 std::size_t* alpha_scans, std::size_t* beta_scans, std::size_t* alpha_missing,
                 std::size_t* beta_missing, const std::function<void()>& note_memory);
  // After build_both(*voxel_size_m) did not fit: the voxel grows by 25 % steps, at most 8, until both fit (the last
  // size taken stays built).
  static void GrowUntilFits(const std::function<bool(double)>& build_both, double* voxel_size_m);
  // The registration parameters at a submap voxel: MakeSubmapRegistrationParams with the server's gates (max_points
  // at least max_submap_points).
  SubmapRegistrationParams SubmapParams(double voxel_size_m) const;
  // How far T_new moved from T_old: translation [m] and the angle of the rotation between them [deg].
  static void Moved(const Eigen::Isometry3d& T_new, const Eigen::Isometry3d& T_old, double* moved_m,
                    double* moved_deg);
  // A refinement's correction within refine.max_correction_m / max_correction_deg.
  bool WithinCorrection(double moved_m, double moved_deg) const;
  // Registers each place on its own (one scan per robot) from result's final transform into
  // result->refinement.places.
  Status RegisterPlaces(const KeyframeDatabase& db, const ScanInbox& inbox, int alpha, int beta,
                        Span<const std::pair<std::uint32_t, std::uint32_t>> places, double voxel_size_m,
                        PairMergeResult* result, const std::function<void()>& note_memory);
  // Fills result's colocated_keyframes / colocated_chance for its registered transform.
  void MeasureColocation(const KeyframeDatabase& db, const ExchangeCascadeResult& cascade,
                         PairMergeResult* result) const;

  MergeServerParams params_;
  SubmapRegistration registration_;
  VoxelGrid voxel_grid_;
  std::vector<PointXYZI> scan_points_, union_points_, alpha_points_, beta_points_;
  std::vector<Eigen::Vector3d> alpha_origins_, beta_origins_;
};

}  // namespace commerge
