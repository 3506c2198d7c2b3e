// SPDX-License-Identifier: BSD-3-Clause
// commerge: multi-robot missions for the simulator: a procedural road / path / corridor / tunnel network, two
// to five robots whose routes on it overlap completely, moderately or partially, keyframes every
// `keyframe_spacing_m` of travel, ground-truth poses and drifting odometry.
//
// Frames (see also the dataset writer):
//  * gt: the simulator's common ground-truth frame (z up, ground z = 0).
//  * robot start frame ("robotstart"): the sensor frame of the robot's first keyframe. T_gt_robotstart is
//    the robot's true start pose, unknown to the robot.
//  * gt[k] = T_robotstart_sensor(k): the true sensor pose of keyframe k in the robot's start frame
//    (gt[0] = identity); the pose in gt is T_gt_robotstart * gt[k] = T_gt_sensor(k).
//  * odometry[k] = T_odomstart_sensor(k): what the robot's own odometry reports, in its own start frame
//    (odometry[0] = identity), drifting away from gt[k].
//  * sensor frame: x forward (the direction of travel), y left, z up, mounted sensor_height_m above the
//    ground; the true pose also carries a smooth roll / pitch wobble of roll_pitch_wobble_deg.
//
// Overlap: the routes are built on a grid network. A shared tour (a closed walk in a central block area) is
// driven by every robot, odd robots in the opposite direction; for moderate / partial overlap each robot
// also explores a private region (an angular sector around the shared area, one node of gap) reached by its
// own connector (even robots drive the shared tour first, odd robots their region first). Shared share of each route: complete ~100 %, moderate ~50 %, partial ~15 %. The grid spacing
// shrinks (down to a per-world minimum) for short routes; when even then the shared tour cannot be as short as
// the nominal share (a few hundred keyframes), the share is larger: MeasureOverlap reports the real figures.
// Overlapping robots alternate directions (odd robots drive the shared tour backwards), so shared places are
// revisited in the opposite direction too; tours and private explorations also revisit places of one robot.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/status.hpp"

namespace commerge {

enum class WorldKind { kUrban, kCampus, kIndoor, kCave, kCourtyard };
enum class OverlapMode { kComplete, kModerate, kPartial };

/// "urban", "campus", "indoor", "cave", "courtyard" / "complete", "moderate", "partial".
const char* WorldKindName(WorldKind kind) noexcept;
const char* OverlapModeName(OverlapMode mode) noexcept;
Result<WorldKind> WorldKindFromName(const std::string& name);
Result<OverlapMode> OverlapModeFromName(const std::string& name);

/// Odometry error model. Each keyframe's true relative motion dT = gt[k-1]^-1 gt[k] (rotation dR, translation
/// dt, s = |dt|) is reported as (dR * ExpSO3(e_r), (1 + scale_bias) dt + e_t), every term times `scale`:
///   e_t ~ N(0, (translation_noise_frac s)^2) on x and y, N(0, (z_noise_frac s)^2) on z (frame k-1),
///   e_r = [N(0, rp^2 s), N(0, rp^2 s), yaw_bias s + N(0, yaw_noise^2 s)] (rotation vector, frame k) [rad],
/// with scale_bias ~ N(0, scale_bias_std^2) and yaw_bias ~ N(0, yaw_bias_std^2) drawn once per robot and the
/// odometry chained: odometry[k] = odometry[k-1] * reported motion. The defaults drift like LiDAR odometry
/// without loop closure (about 0.5-2 % of the distance travelled over kilometres).
struct DriftParams {
  double scale = 1.0;                             ///< multiplies every term; 0 = perfect odometry
  double translation_noise_frac = 0.005;          ///< per-axis std of the step error / step length (x, y)
  double z_noise_frac = 0.001;                    ///< same for z
  double scale_bias_std = 0.003;                  ///< per-robot odometry scale error (1 sigma)
  double yaw_noise_deg_per_sqrt_m = 0.01;         ///< yaw random walk [deg / sqrt(m)]
  double yaw_bias_std_deg_per_m = 0.0005;         ///< per-robot yaw drift rate (1 sigma) [deg / m]
  double roll_pitch_noise_deg_per_sqrt_m = 0.002; ///< roll / pitch random walk [deg / sqrt(m)]
};

struct MissionParams {
  WorldKind world = WorldKind::kUrban;
  OverlapMode overlap = OverlapMode::kModerate;
  int robots = 2;                     ///< 2..5
  int keyframes_per_robot = 1000;     ///< 2..1000000
  double keyframe_spacing_m = 1.0;    ///< travel between keyframes (the paper's keyframe spacing)
  std::uint64_t seed = 1;
  DriftParams drift;
  double block_size_m = 0.0;          ///< grid spacing of the network; 0 = the world's default (shrunk for short routes)
  double roll_pitch_wobble_deg = 0.5; ///< amplitude of the smooth true roll / pitch of the vehicle
  /// Shared laps: false = odd robots drive the tour the other way round (revisits in the opposite direction,
  /// on the other lane: the hard case for place recognition), true = every robot in the same direction.
  bool same_direction = false;
};

/// OK or invalid argument naming the field.
Status ValidateMissionParams(const MissionParams& p);

/// The grid network the routes run on: nodes (i, j) at node_xy[j * nx + i], 4-neighbour edges with a
/// polyline each (straight or curved), flags of the edges some robot drives.
struct RoadNetwork {
  int nx = 0, ny = 0;
  double block_m = 0.0;
  std::vector<Eigen::Vector2d> node_xy;
  struct Edge {
    int a = 0, b = 0;                       ///< node indices, a < b
    std::vector<Eigen::Vector2d> polyline;  ///< from a to b, first = node a, last = node b
    bool driven = false;                    ///< some robot's route uses it
  };
  std::vector<Edge> edges;
  /// Region of each node: -1 shared area, 0..R-1 a robot's private region, -2 gap (connectors only).
  std::vector<int> node_region;
  /// Index of the edge joining nodes a and b, or -1.
  int EdgeBetween(int a, int b) const;
};

struct RobotMission {
  int id = 0;
  Eigen::Isometry3d T_gt_robotstart = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Isometry3d> gt;        ///< T_robotstart_sensor per keyframe (gt[0] = identity)
  std::vector<Eigen::Isometry3d> odometry;  ///< T_odomstart_sensor per keyframe (odometry[0] = identity)
  std::vector<double> times_s;              ///< keyframe times from the robot's start [s]
  std::vector<std::uint8_t> on_shared_tour; ///< 1 when the keyframe lies on the shared tour (by construction)
  std::vector<int> route_nodes;             ///< the node walk the robot drives
  double scale_bias = 0.0;                  ///< drawn odometry scale error
  double yaw_bias_rad_per_m = 0.0;          ///< drawn yaw drift rate

  /// True pose of keyframe k's sensor in the ground-truth frame gt.
  Eigen::Isometry3d T_gt_sensor(std::size_t k) const { return T_gt_robotstart * gt[k]; }
};

struct MissionPlan {
  MissionParams params;
  RoadNetwork network;
  std::vector<RobotMission> robots;
  double sensor_height_m = 1.8;  ///< above the ground
  double lane_offset_m = 0.0;    ///< robots keep this far right of the path centre
  double speed_m_per_s = 1.0;
  std::vector<int> shared_tour;  ///< closed node walk of the shared area
};

/// Plans the network, the routes, the keyframe poses and the odometry of every robot (the courtyard:
/// core/sim/courtyard.hpp, without a network). Deterministic in
/// params (same params, same plan bit for bit on one build). Errors: invalid params.
Result<MissionPlan> PlanMission(const MissionParams& params);

/// Fills robot->odometry (and its drawn biases) from robot->gt with the drift model of params.drift; the draws
/// depend on (params.seed, robot_index) only.
void AddDriftingOdometry(const MissionParams& params, int robot_index, RobotMission* robot);

/// Overlap of the robots' true keyframe positions: fraction[i][j] = share of robot i's keyframes within
/// `radius_m` (horizontal) of some keyframe of robot j; any[i] = within radius of any other robot.
struct OverlapReport {
  double radius_m = 0.0;
  std::vector<std::vector<double>> fraction;
  std::vector<double> any;
};
OverlapReport MeasureOverlap(const MissionPlan& plan, double radius_m = 6.0);

/// Seed of the range noise of robot `robot`'s keyframe `k` scan.
std::uint64_t ScanNoiseSeed(const MissionParams& params, int robot, std::size_t k);

}  // namespace commerge
