// SPDX-License-Identifier: BSD-3-Clause
// commerge: the small-scene world of the simulator: a courtyard enclosed by building facades, walked by people
// carrying a LiDAR by hand. The walks follow one loop inset from the facades; how the robots' stretches of that
// loop overlap follows the mission's overlap mode:
//   partial:  robot r starts where robot r-1 ended (the walks meet at one place);
//   moderate: robot r starts halfway along robot r-1's walk;
//   complete: every robot walks robot 0's stretch; with alternate directions odd robots walk it backwards.
// Handheld motion: the sensor is carried at about 1.5 m, held at a constant attitude of its own per carrier
// (pitched down a little), tilts by a few degrees as the carrier walks (on top of
// MissionParams::roll_pitch_wobble_deg) and sways in yaw around the walking direction. The robots' map frames
// are their first keyframes' sensor frames, so they are not level.
//
// Frame: the simulation's ground-truth frame gt; the courtyard is centred on the origin, its short side along x.
#pragma once

#include "core/common/status.hpp"
#include "core/sim/multi_robot_mission.hpp"

namespace commerge {

/// Extent of a courtyard, drawn from the mission's seed.
struct CourtyardGeometry {
  double width_m = 20.0;        ///< inner extent along x (facade to facade), in [18, 26]
  double length_m = 45.0;       ///< inner extent along y, in [36, 50]
  double walk_inset_m = 4.0;    ///< the walking loop keeps about this far from the facades, in [3.5, 5]
  double corner_radius_m = 2.0; ///< the loop turns the corners on this radius
};

CourtyardGeometry CourtyardOf(const MissionParams& params);

/// Carrier constants of the handheld walks.
constexpr double kHandheldSensorHeightM = 1.5;
constexpr double kHandheldTiltDeg = 4.0;   ///< roll / pitch amplitude of the carrier's gait
constexpr double kHandheldHoldPitchDeg = 10.0;  ///< each carrier holds the sensor pitched in [-10, 3] deg, rolled +-3 deg
constexpr double kHandheldYawSwayDeg = 8.0;  ///< yaw sway around the walking direction
constexpr double kHandheldSpeedMPerS = 1.2;

/// The plan of a courtyard mission (params.world must be WorldKind::kCourtyard): no road network; each robot
/// walks keyframes_per_robot keyframes along the loop (wrapping around it when the walk is longer than the
/// loop). Deterministic in params. Errors: invalid params, a world other than the courtyard.
Result<MissionPlan> PlanCourtyardMission(const MissionParams& params);

/// Distance [m] from (x, y) to the walking loop's centre line (the loop without the carrier's wander).
double CourtyardLoopDistance(const CourtyardGeometry& g, double x, double y);

}  // namespace commerge
