// SPDX-License-Identifier: BSD-3-Clause
// commerge: intra-robot loop closure (paper, Section "Intra-Robot SLAM for Local Mapping"):
//   1. candidate b = argmin over keyframes 0 .. a - tau_window of the descriptor distance (Eq. "past-nn"),
//      an exact linear scan (no approximate retrieval);
//   2. accepted as a candidate when the distance <= tau_intra (Eq. "intra-gate");
//   3. verified by point-to-point ICP on the voxelised scans: mean squared residual <= tau_ICP
//      (Eq. "icp-accept"); the loop edge carries an information matrix from the ICP residuals;
//   4. (ours) the accepted loop's transform is refined by GICP (LoopDetectorParams::refine_with_gicp).
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/descriptor/place_descriptor.hpp"
#include "core/memory/fixed_vector.hpp"
#include "core/registration/gicp.hpp"
#include "core/registration/submap_features.hpp"
#include "core/slam/icp.hpp"

namespace commerge {

/// Feature parameters for the loop refinement: normals and covariances from 10 neighbours within 3 m.
inline SubmapFeatureParams DefaultLoopRefineFeatures() {
  SubmapFeatureParams p;
  p.normal_radius_m = 3.0;
  p.fpfh_radius_m = 3.0;  // the neighbour search radius (no descriptors are computed)
  p.max_neighbors = 10;
  p.covariance_neighbors = 10;
  return p;
}

struct LoopDetectorParams {
  /// tau_window: the query and the last tau_window - 1 keyframes are never candidates.
  std::uint32_t window_keyframes = 100;
  /// tau_intra: descriptor distance gate (SOLiD unit L2: 0.05 spinning, 0.01 Livox).
  double max_descriptor_distance = 0.05;
  /// tau_ICP: mean squared ICP residual gate [m^2] (paper: "0.3 m / 2.0 m", spinning / non-repetitive).
  double max_icp_mean_squared_residual_m2 = 0.3;
  /// ICP restarts at yaw = k * 360 / yaw_hypotheses (plus the odometry guess): robust to any heading.
  int yaw_hypotheses = 12;
  /// The yaw restarts are skipped when ICP from the trajectory's prediction already converged with at least
  /// this inlier ratio and passed the residual gate (a revisit the odometry predicts well: the common case on
  /// repeated laps, where the restarts would cost 12 more ICP runs per keyframe). > 1 disables the shortcut.
  double prediction_accept_inlier_ratio = 0.6;
  /// Yaw restarts run this many ICP iterations each; only the best `yaw_refinements` of them (most inliers,
  /// then lowest residual) continue with the full IcpParams::max_iterations. 0 = every restart runs in full.
  int yaw_screening_iterations = 8;
  int yaw_refinements = 2;
  /// Fewer inliers / source points than this fails the check (the residual alone can be small on a
  /// sliver of overlap).
  double min_inlier_ratio = 0.3;
  /// ICP's information treats thousands of inliers as independent; scale it down to an effective count.
  double effective_correspondences = 50.0;
  /// Odometry plausibility (ours, not in the paper): a verified loop is refused when it disagrees with what
  /// the robot already knows by more than drift allows. For a prior T (match to query) over a path of d
  /// metres, with C = T^-1 T_match_query_icp, the loop must satisfy
  ///   |translation of C| <= max_correction_m + max_correction_per_travelled * d   and
  ///   |rotation of C|    <= max_correction_deg + max_correction_deg_per_travelled_m * d,
  /// twice (robot_mapper.cpp):
  ///   1. T from the odometry chain alone (never the optimised graph), d = the whole path since the match
  ///      (keyframes between them x spacing; more keyframes per metre when turning, so it errs on the
  ///      lenient side);
  ///   2. T from the optimised graph, d = the shortest path through the loops already optimised into it
  ///      (KeyframeGraphDistance): where earlier loops tie the two places together, little drift is left.
  /// Why: descriptor search ignores position, so repetitive places verify by ICP at the wrong copy; check 1
  /// cannot be bent by any loop, check 2 is the tight one once loops are closed. The defaults are the upper end
  /// of LiDAR odometry drift (core/agent/decisions/018-loop-odometry-plausibility.md). Raise them for worse
  /// odometry (wheels: 2-5 %); huge values disable the checks.
  double max_correction_m = 2.0;
  double max_correction_per_travelled = 0.02;
  double max_correction_deg = 5.0;
  double max_correction_deg_per_travelled_m = 0.1;
  IcpParams icp;
  /// Loop refinement (ours, not the paper's, which uses the ICP result as the loop measurement): after the
  /// point-to-point ICP passed the paper's checks, GICP (core/registration) refines the loop transform from the
  /// ICP result; the checks and the information matrix stay the ICP's. Why: on 1 m voxel scans point-to-point
  /// ICP is biased towards the scans' own sensor-centred sampling, and hundreds of such loops shrink and bend a
  /// map (core/agent/decisions/019-gicp-loop-refinement.md). The refinement is kept only when GICP converged and
  /// moved the ICP result by at most max_refinement_m / max_refinement_deg (otherwise the ICP result stands and
  /// the check says so).
  bool refine_with_gicp = true;
  double max_refinement_m = 1.0;
  double max_refinement_deg = 3.0;
  /// Normals and covariances of the two voxelised scans: 10 neighbours within 3 m (three voxels).
  SubmapFeatureParams refine_features = DefaultLoopRefineFeatures();
  GicpParams refine_gicp;
};

Status ValidateLoopDetectorParams(const LoopDetectorParams& params);

/// Descriptors of one robot's keyframes, in keyframe order, with a fixed capacity (memory budget).
class DescriptorDatabase {
 public:
  DescriptorDatabase(const PlaceDescriptor& descriptor, std::size_t max_keyframes);

  /// Appends keyframe `size()`'s descriptor (dimension() floats). Invalid descriptors are stored (to keep
  /// indices aligned) but never matched. ResourceExhausted when full; InvalidArgument on a size mismatch.
  Status Add(Span<const float> values, bool valid);

  std::size_t size() const noexcept { return valid_.size(); }
  std::size_t capacity() const noexcept { return valid_.capacity(); }
  /// Floats per descriptor.
  std::size_t dimension() const noexcept { return dimension_; }
  Span<const float> Get(std::size_t keyframe) const;
  bool valid(std::size_t keyframe) const { return valid_[keyframe] != 0; }

  struct Match {
    bool found = false;
    std::uint32_t keyframe = 0;
    double distance = 0.0;
  };
  /// Nearest valid descriptor among keyframes [0, end) to `query` (exact linear scan).
  Match NearestBefore(Span<const float> query, std::size_t end) const;

 private:
  const PlaceDescriptor& descriptor_;
  std::size_t dimension_;
  FixedVector<float> values_;
  FixedVector<std::uint8_t> valid_;
};

struct LoopClosure {
  std::uint32_t query = 0;     ///< the new keyframe a
  std::uint32_t match = 0;     ///< the earlier keyframe b
  double descriptor_distance = 0.0;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();  ///< ICP: query scan into the match's frame
  IcpResult icp;
  /// The GICP refinement replaced ICP's transform in T_match_query (icp.T_target_source keeps ICP's).
  bool refined = false;
  /// Pose-graph information of the loop edge, order [translation; rotation] (core/geometry/se3's twists).
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

/// Why a candidate was or was not accepted (for logs and counters).
enum class LoopVerdict {
  kAccepted,
  kNoCandidate,
  kDescriptorTooFar,
  kIcpFailed,
  kIcpResidualTooLarge,
  kTooFewInliers,
  kCorrectionTooLarge,  ///< verified by ICP, but further from the estimate than odometry can drift (an alias)
};
const char* LoopVerdictName(LoopVerdict verdict);

struct LoopCheck {
  LoopVerdict verdict = LoopVerdict::kNoCandidate;
  LoopClosure loop;  ///< filled from kDescriptorTooFar on (query, match, distance) and fully when accepted
};

/// Geometric verification of a descriptor candidate with multi-hypothesis point-to-point ICP.
class LoopVerifier {
 public:
  LoopVerifier() { screened_.reserve(360); }  // yaw_hypotheses <= 360: Verify() never grows it

  /// `query_scan` and `match_scan` are voxelised scans in their sensor frames; `T_match_query_odom` is the
  /// relative pose the current trajectory estimate predicts (used as one more initial guess).
  Result<LoopCheck> Verify(std::uint32_t query, std::uint32_t match, double descriptor_distance,
                           Span<const PointXYZI> query_scan, Span<const PointXYZI> match_scan,
                           const Eigen::Isometry3d& T_match_query_odom, const LoopDetectorParams& params);

  /// Bytes held: the ICP's k-d tree and scratch, the yaw restarts' results, the refinement's neighbour lists,
  /// normals, covariances, k-d tree and GICP factors (capacities).
  std::size_t workspace_bytes() const {
    return icp_.workspace_bytes() + screened_.capacity() * sizeof(IcpResult) + query_features_.workspace_bytes() +
           match_features_.workspace_bytes() + gicp_.workspace_bytes();
  }

 private:
  void Refine(Span<const PointXYZI> query_scan, Span<const PointXYZI> match_scan, const LoopDetectorParams& params,
              LoopClosure* loop);

  PointToPointIcp icp_;
  std::vector<IcpResult> screened_;  ///< yaw restarts after the screening iterations
  SubmapFeatures query_features_;
  SubmapFeatures match_features_;
  Gicp gicp_;
};

}  // namespace commerge
