// SPDX-License-Identifier: BSD-3-Clause
// commerge: the multi-robot frame solver. From pairwise inter-robot transforms (one per successful map merge
// between two robots, possibly several per pair, some of them wrong), it picks the consistent ones by cycle
// consistency and places every robot's map frame in a common frame: the world frame (robot 0's map frame).
//
// Rule (exact unless the search budget runs out, see FrameSolution::search_exhaustive):
//  1. Every measurement m is read as T_lo_hi, the transform from the higher-index robot's frame into the
//     lower-index robot's frame (a measurement given as T_a_b with a > b is inverted first). All errors below
//     are measured on T_lo_hi: translation ||t_implied - t_measured|| [m] (in the lower robot's frame) and the
//     rotation angle of R_measured^T R_implied [deg].
//  2. A spanning forest F is a set of measurements with no cycle that connects every connected component of
//     the measurement graph (one tree per component; parallel measurements of one robot pair are separate
//     edges). F fixes every robot's pose relative to its tree, hence an implied T_lo_hi for every measurement;
//     m is consistent with F when its errors against that implied transform are <= max_translation_m and
//     <= max_rotation_deg (F's own edges are consistent with F by construction).
//  3. The chosen forest maximises the number of consistent measurements; ties go to the larger total weight of
//     the consistent measurements, remaining ties to the first forest found (deterministic for a given input and
//     parameters). Consistent measurements are accepted (kUnverified for a bridge: a measurement whose removal
//     disconnects its robots, which no cycle can check), the others rejected, with the error that rejected them.
//  4. The robot frames are then refined by weighted least squares over the consistent measurements:
//     Gauss-Newton on SE(3) with right box-plus updates, each component's anchor fixed, residual
//     LogSE3(T_measured^-1 X_lo^-1 X_hi) whitened by (max_translation_m, max_rotation_deg) and scaled by the
//     measurement's weight.
// Placement T_world_map: relative to the map frame of each connected component's anchor, its lowest-index robot.
// For the component containing robot 0 that is the world frame (robot 0's map frame); a component without
// robot 0 is placed in its own anchor's map frame (connected_to_robot0 false).
//
// Search: measurements are ordered by support (parallel measurements and closed triangles that agree with
// them), then weight. Incumbents: the Kruskal forest in that order, then one greedy forest per seed measurement
// (repeatedly add the joining measurement that makes the most measurements consistent). Then an exact branch
// and bound over all spanning forests (include / exclude each measurement in order, union-find, bound = the
// consistent count and weight already determined plus, per robot pair not yet joined, the most of its
// measurements that can agree with one transform). Greedy joins and search nodes together are capped at
// max_search_nodes; when the cap stops the search, the best forest found so far is used and
// search_exhaustive is false. The proof of optimality completes within the default cap for 8 robots with up to
// about 20 measurements spread over all pairs (more on sparser graphs, always when all measurements agree);
// for denser graphs the answer is the best of the greedy and the partial search (in the tests: all inliers
// accepted, all outliers rejected, at 8 robots / 64 measurements with 25% outliers). Sizes: 2..8 robots, at
// most 64 measurements.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

inline constexpr int kFrameSolverMinRobots = 2;
inline constexpr int kFrameSolverMaxRobots = 8;
inline constexpr std::size_t kFrameSolverMaxMeasurements = 64;

/// One pairwise inter-robot transform.
struct FrameMeasurement {
  int robot_a = 0;
  int robot_b = 1;
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();  ///< p_a = T_a_b p_b
  double weight = 1.0;  ///< confidence, > 0 (e.g. the registration's inlier count)
};

struct FrameSolverParams {
  double max_translation_m = 2.0;  ///< consistency threshold on the translation [m], > 0
  double max_rotation_deg = 5.0;   ///< consistency threshold on the rotation [deg], in (0, 180]
  int refine_iterations = 5;       ///< Gauss-Newton iterations of the final refinement, in [0, 100] (0: none)
  /// Greedy joins plus branch-and-bound nodes before the search stops with the best forest so far, >= 1
  /// (~0.25 us each on a desktop core). The default bounds the worst case (8 robots, 64 measurements) to about
  /// 25 ms on a desktop core (a Cortex-A57 is several times slower).
  std::size_t max_search_nodes = 100000;
};

enum class MeasurementVerdict : std::uint8_t {
  kAccepted = 0,  ///< consistent with the chosen forest and on a cycle of the measurement graph
  kRejected,      ///< inconsistent with the chosen forest
  kUnverified,    ///< a bridge: used (it is the only link between its two sides) but no cycle can check it
};
/// "accepted", "rejected", "unverified".
const char* MeasurementVerdictName(MeasurementVerdict verdict) noexcept;

struct MeasurementOutcome {
  MeasurementVerdict verdict = MeasurementVerdict::kRejected;
  bool in_forest = false;  ///< one of the chosen spanning forest's edges
  /// Errors of the measured T_lo_hi against the chosen forest's implied one (0 for forest edges): the cycle
  /// error that accepted or rejected it.
  double cycle_translation_m = 0.0;
  double cycle_rotation_deg = 0.0;
  /// Errors against the refined robot frames.
  double residual_translation_m = 0.0;
  double residual_rotation_deg = 0.0;
  /// Forest edges: consistent non-forest measurements whose cycle (with the forest path between their robots)
  /// runs through this edge; 0 means nothing corroborates it. Always 0 for non-forest measurements.
  std::size_t support = 0;
};

struct RobotFrame {
  /// The robot's map frame in its component's frame (p_world = T_world_map p_map; the world frame when
  /// connected_to_robot0, else the anchor's map frame); identity for anchors.
  Eigen::Isometry3d T_world_map = Eigen::Isometry3d::Identity();
  int component = 0;     ///< component id, 0 .. num_components - 1, numbered by ascending anchor index
  int anchor_robot = 0;  ///< lowest robot index of the component (its map frame is the component's frame)
  bool connected_to_robot0 = false;  ///< in robot 0's component (T_world_map is then in the world frame)
};

struct FrameSolution {
  std::vector<RobotFrame> robots;                ///< one per robot
  std::vector<MeasurementOutcome> measurements;  ///< one per input measurement, same order
  int num_components = 0;
  std::size_t consistent_count = 0;  ///< consistent measurements of the chosen forest (the maximised objective)
  double consistent_weight = 0.0;    ///< their total weight (the tie-break)
  std::size_t accepted = 0;
  std::size_t rejected = 0;
  std::size_t unverified = 0;
  bool search_exhaustive = true;  ///< false when max_search_nodes stopped the search (optimum not proven)
  std::size_t search_nodes = 0;
  int refine_iterations_run = 0;
};

/// Checks FrameSolverParams; InvalidArgument naming the field and value otherwise.
Status ValidateFrameSolverParams(const FrameSolverParams& params);

/// Solves for the robot frames (rule in the header comment). Errors (InvalidArgument naming the field and
/// value): num_robots outside [2, 8]; more than 64 measurements; a measurement with a robot index outside
/// [0, num_robots), robot_a == robot_b, a non-finite T_a_b or one whose rotation is not orthonormal with det +1
/// within 1e-5 (smaller rounding is projected away), a weight that is not finite and > 0;
/// invalid params. No measurements is valid: every robot is then its own component.
Result<FrameSolution> SolveRobotFrames(int num_robots, Span<const FrameMeasurement> measurements,
                                       const FrameSolverParams& params = {});

}  // namespace commerge
