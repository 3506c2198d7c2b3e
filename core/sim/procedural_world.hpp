// SPDX-License-Identifier: BSD-3-Clause
// commerge: the procedural worlds of the simulator, generated along a mission's network (seeded by the
// mission's seed, deterministic):
//  * urban: every grid street is lined with buildings (oriented boxes 10-28 m wide, 4-40 m high, set back
//    9-13 m from the street centre), poles, parked cars and street trees;
//  * campus: curved footpaths (the driven edges) under trees (trunk cylinder + crown spheres), lawn trees,
//    a few large buildings, lamp posts, benches;
//  * indoor: a floor of 3 m wide corridors on a 24 m grid under a 3 m ceiling, walls with a door every 6 m
//    (closed, or open onto a small room), rare cabinets: long repetitive corridors (perceptual aliasing);
//  * cave: tunnels along the driven edges (free space = noisy capsules of radius 2.6-3.6 m, chambers at the
//    junctions) over a flat floor, with boulders;
//  * courtyard (core/sim/courtyard.hpp): a courtyard of 18-26 x 36-50 m closed by building facades 8-18 m high
//    (pilasters, floor ledges, entrance porches, one passage), with trees, a fountain, benches, bollards and
//    planters between the walking loop and the facades: a small, nearly symmetric scene.
// Nothing is placed within the driving corridor of any street the robots may use.
#pragma once

#include "core/common/status.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/world.hpp"

namespace commerge {

/// Generates and builds (World::Build) the world of `plan`. Errors: a failed Build (should not happen).
Result<World> BuildMissionWorld(const MissionPlan& plan);

/// Ceiling height of the indoor world [m].
constexpr float kIndoorCeilingM = 3.0f;
/// Corridor half width of the indoor world [m].
constexpr float kIndoorCorridorHalfWidthM = 1.5f;

}  // namespace commerge
