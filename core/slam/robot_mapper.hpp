// SPDX-License-Identifier: BSD-3-Clause
// commerge: the robot side of the paper's pipeline (Section "Intra-Robot SLAM for Local Mapping"), one call
// per LiDAR scan:
//   1. keyframe selection every keyframe_spacing_m (Delta d = 1 m) or keyframe_rotation_deg;
//   2. the place descriptor on the RAW scan (the paper: SOLiD), or on its descriptor input (DescriptorInputParams,
//      ours): the scan levelled by the odometry's gravity and joined by the keyframes of the last few metres;
//   3. the scan voxelised to voxel_size_m (Delta nu = 1 m; finer in small scenes when voxel.min_points asks for
//      it, AdaptiveVoxelParams), encoded (int16 cm) into the fixed-size scan store;
//   4. a pose-graph node with an odometry edge;
//   5. intra-robot loop closure: descriptor nearest neighbour outside tau_window, gate tau_intra, ICP check
//      with tau_ICP; an accepted loop is an edge and triggers pose-graph optimisation, whose moved keyframes
//      are reported so the server's copy of the poses can be updated.
// Everything the robot streams to the server (descriptor, pose) and later sends (scans) comes from here.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/descriptor/place_descriptor.hpp"
#include "core/slam/ground_up.hpp"
#include "core/slam/keyframe_graph_distance.hpp"
#include "core/slam/keyframer.hpp"
#include "core/slam/loop_detector.hpp"
#include "core/slam/pose_graph.hpp"
#include "core/slam/scan_store.hpp"

namespace commerge {

/// What the place descriptor is computed on (ours; the paper's SOLiD takes the raw scan: both off).
struct DescriptorInputParams {
  /// The points of the keyframes of the last local_map_window_m of path (in their odometry poses) join the
  /// keyframe's own scan: a forward-looking or sparse sensor sees more of the place in a few metres than in one
  /// scan. 0: the keyframe's scan alone. [m], in [0, 50].
  double local_map_window_m = 0.0;
  /// Rotate the cloud about the sensor so that its z axis is the odometry frame's z (gravity, in a LIO/VIO or
  /// IMU-aided odometry): roll and pitch out, yaw kept.
  bool level = false;
  /// Voxel size of the past keyframes kept for the local map and of the joined cloud [m], in [0.05, 2].
  double voxel_m = 0.25;
  /// With level: where up is in the odometry frame, from the keyframes' ground (core/slam/ground_up.hpp); a
  /// frame that leans by more than ground_up.min_frame_tilt_deg (a handheld sensor's) is levelled by it.
  GroundUpParams ground_up;
};

struct RobotMapperParams {
  KeyframerParams keyframer;
  DescriptorInputParams descriptor_input;
  /// Stored scans: Delta nu = voxel.voxel_size_m = 1.0 m; with voxel.min_points > 0 (ours) a scan that keeps
  /// fewer points is stored finer, down to voxel.min_voxel_size_m (max_points is the store's
  /// max_points_per_stored_scan whatever is set here).
  AdaptiveVoxelParams voxel;
  LoopDetectorParams loop;
  PoseGraphParams graph;
  /// Odometry uncertainty per keyframe step (information = diag(1/sigma^2); rotation about the sensor's x, y, z).
  double odometry_sigma_translation_m = 0.05;
  /// Yaw (about the sensor's z axis).
  double odometry_sigma_rotation_rad = 0.005;
  /// Roll and pitch (about x and y). The paper's odometry is LiDAR-inertial (FAST-LIO2): gravity keeps its roll and
  /// pitch from drifting, so a step's roll or pitch is known to about 0.01 deg; with the yaw's value the loops' pitch
  /// noise tilts the graph (core/agent/decisions/020-odometry-roll-pitch-sigma.md). Odometry without an IMU drifts
  /// in roll and pitch too: give it the yaw's value.
  double odometry_sigma_roll_pitch_rad = 0.0002;
  /// Optimise at most once per this many keyframes: a revisit yields a loop at almost every keyframe, and
  /// each optimisation of a 20k-node graph costs ~0.3 s on a desktop core. Loops found in between are added
  /// to the graph and optimised with the next one (or by OptimizePending()).
  std::uint32_t min_keyframes_between_optimisations = 10;
};

Status ValidateRobotMapperParams(const RobotMapperParams& params);

/// `descriptor_id` unchanged when both descriptor-input options are off (the paper's SOLiD keeps its id);
/// otherwise FNV-1a of it with the byte 'i', the window and voxel as binary64 and the levelling flag.
std::uint32_t DescriptorInputId(std::uint32_t descriptor_id, const DescriptorInputParams& input) noexcept;

/// Capacities fixed at construction (from the robot's memory budget).
struct RobotMapperCapacity {
  std::size_t max_keyframes = 20000;
  std::size_t max_points_per_raw_scan = 131072;
  std::size_t max_points_per_stored_scan = 8192;
};

/// What one AddScan call did.
struct KeyframeStep {
  bool is_keyframe = false;
  std::uint32_t keyframe = 0;      ///< index of the new keyframe (when is_keyframe)
  DescriptorInfo descriptor;       ///< valid == false: the keyframe's descriptor is never sent or matched
  std::size_t voxel_points = 0;    ///< points of the voxelised scan
  double voxel_size_m = 0.0;       ///< its voxel size (RobotMapperParams::voxel)
  std::size_t encoded_bytes = 0;   ///< bytes of the encoded scan put into the store
  Status store_status;             ///< why the scan is not stored (the keyframe exists anyway)
  ScanPutInfo store;               ///< evictions / spills this keyframe caused
  LoopCheck loop;                  ///< loop closure attempt for this keyframe
  /// Keyframes whose pose the optimisation moved (ascending): send these as a pose update. Empty when no
  /// optimisation ran at this keyframe (see min_keyframes_between_optimisations).
  std::vector<std::uint32_t> changed_keyframes;
};

struct RobotMapperStats {
  std::uint64_t scans = 0;
  std::uint64_t keyframes = 0;
  std::uint64_t invalid_descriptors = 0;
  std::uint64_t scans_not_stored = 0;
  std::uint64_t scans_stored_finer = 0;  ///< keyframe scans voxelised finer than voxel.voxel_size_m
  std::uint64_t loops_accepted = 0;
  std::uint64_t loop_candidates_rejected = 0;  ///< descriptor candidates that failed the ICP check
  std::uint64_t loops_refined = 0;  ///< accepted loops whose transform GICP refined (LoopDetectorParams)
  std::uint64_t loops_implausible = 0;  ///< of those: ICP passed, but the correction exceeded the drift bound
  std::uint64_t optimisations = 0;
  std::uint64_t pending_loops = 0;  ///< loops in the graph not yet optimised
};

class RobotMapper {
 public:
  /// `descriptor` and `store` are not owned and must outlive the mapper. Allocates its workspaces here.
  RobotMapper(const RobotMapperParams& params, const RobotMapperCapacity& capacity, PlaceDescriptor* descriptor,
              ScanStore* store);

  /// Feeds one raw scan (sensor frame) with its odometry pose. Errors: invalid parameters, a scan larger than
  /// max_points_per_raw_scan, the keyframe capacity exhausted; a non-finite pose or an empty scan is not an
  /// error (no keyframe; an empty keyframe scan gets an invalid descriptor).
  Result<KeyframeStep> AddScan(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor);

  /// Optimises loops added since the last optimisation (e.g. at the end of a mission); returns the moved
  /// keyframes (empty when nothing was pending).
  Result<std::vector<std::uint32_t>> OptimizePending();

  std::size_t num_keyframes() const noexcept { return graph_.num_nodes(); }
  /// Optimised pose of keyframe k, T_map_sensor (map = the robot's own map frame: its first keyframe's frame).
  const Eigen::Isometry3d& pose(std::size_t k) const { return graph_.pose(k); }
  Span<const float> descriptor(std::size_t k) const { return db_.Get(k); }
  bool descriptor_valid(std::size_t k) const { return db_.valid(k); }
  const RobotMapperStats& stats() const noexcept { return stats_; }
  const PoseGraph& graph() const noexcept { return graph_; }
  const DescriptorDatabase& descriptor_db() const noexcept { return db_; }
  /// Id of the descriptors this mapper computes: PlaceDescriptor::parameter_id(), with the descriptor input's
  /// parameters mixed in when levelling or the local map is on (DescriptorInputId).
  std::uint32_t descriptor_parameter_id() const noexcept;
  /// Up in the odometry frame as the keyframes' ground gives it so far, and whether levelling uses it.
  const GroundUpEstimate& ground_up() const noexcept { return ground_up_; }
  bool levels_by_ground() const noexcept;
  /// Kind of the descriptor this mapper computes (SOLiD, Scan Context, ring occupancy).
  DescriptorKind descriptor_kind() const noexcept { return descriptor_->kind(); }
  /// Bytes of the per-scan buffers (capacities): the voxel grid's sort workspace, the voxelised and the encoded
  /// scan, the descriptor scratch, and the descriptor input (the past keyframes of the local map, the joined
  /// and levelled cloud, the ground fit's z values).
  std::size_t scan_workspace_bytes() const;
  /// Bytes of the loop-closure buffers (capacities): the match's decoded scan and spill buffer, the verifier's
  /// k-d tree, ICP scratch and yaw restarts.
  std::size_t loop_closure_workspace_bytes() const;

 private:
  Status FindLoop(std::uint32_t query, Span<const float> query_descriptor, KeyframeStep* step);
  /// The cloud the descriptor sees for a keyframe with this scan and odometry pose (DescriptorInputParams);
  /// the raw scan itself when neither option is on.
  Result<Span<const PointXYZI>> DescriptorInput(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor);
  /// Keeps this keyframe's scan for the next keyframes' local maps; drops those beyond the window.
  Status RememberForLocalMap(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor);

  /// A past keyframe of the local map: its odometry pose, its path position and its voxelised points (a range
  /// of local_points_).
  struct LocalKeyframe {
    Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
    double path_m = 0.0;
    std::size_t begin = 0, end = 0;
  };

  RobotMapperParams params_;
  RobotMapperCapacity capacity_;
  PlaceDescriptor* descriptor_;
  ScanStore* store_;
  Status params_status_;
  Keyframer keyframer_;
  DescriptorDatabase db_;
  PoseGraph graph_;
  VoxelGrid voxel_grid_;
  LoopVerifier verifier_;
  Eigen::Isometry3d T_odom_last_keyframe_ = Eigen::Isometry3d::Identity();
  /// The odometry pose of every keyframe as it came in (loops never change it); reserved to max_keyframes.
  std::vector<Eigen::Isometry3d> T_odom_keyframes_;
  /// Path lengths through the loops already optimised into the graph (the graph check's drift bound), and
  /// how many graph edges it has seen.
  KeyframeGraphDistance graph_distance_;
  std::size_t linked_edges_ = 0;
  bool optimised_once_ = false;
  std::uint32_t last_optimisation_keyframe_ = 0;
  std::vector<float> descriptor_scratch_;
  std::vector<PointXYZI> voxels_, voxel_scratch_, match_points_;
  std::vector<LocalKeyframe> local_keyframes_;        ///< oldest first
  std::vector<PointXYZI> local_points_, local_cloud_, local_scratch_;
  GroundUpEstimate ground_up_;      ///< up in the odometry frame, from the keyframes' ground
  std::vector<float> ground_z_;     ///< FitGroundNormal's scratch
  double path_m_ = 0.0;                               ///< odometry path length up to the last keyframe
  std::vector<std::uint8_t> encoded_, spill_buffer_;
  RobotMapperStats stats_;
};

}  // namespace commerge
