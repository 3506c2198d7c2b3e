// SPDX-License-Identifier: BSD-3-Clause
// commerge: the one definition of pi and the degree/radian factors, for core, platform, tests and profiling.
// kDegToRad and kRadToDeg are the rounded quotients pi / 180 and 180 / pi: `x * kDegToRad` and `x * kPi / 180`
// can differ in the last bit, so code keeps whichever form it computes with.
#pragma once

namespace commerge {

constexpr double kPi = 3.14159265358979323846;
/// pi rounded to float (the same value as the float literal 3.14159265f).
constexpr float kPiF = static_cast<float>(kPi);
constexpr double kDegToRad = kPi / 180.0;  ///< [rad / deg]
constexpr double kRadToDeg = 180.0 / kPi;  ///< [deg / rad]

}  // namespace commerge
