// SPDX-License-Identifier: BSD-3-Clause
// Pose differences for test assertions: the rotation angle between two orientations (core/geometry's
// RotationAngleRad of a^T b, in [0, pi]) and the distance between two positions, so that every test measures
// rotation and translation errors the same way. Also ground-truth poses re-expressed in a robot's map frame.
#pragma once

#include <Eigen/Geometry>

#include <cmath>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge::test {

/// Rotation angle of R [deg], in [0, 180].
inline double AngleDeg(const Eigen::Matrix3d& R) { return RotationAngleRad(R) * 180.0 / kPi; }

/// Angle of the rotation a^T b that takes orientation a to orientation b [rad], in [0, pi].
inline double RotationErrorRad(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return RotationAngleRad(a.transpose() * b);
}
inline double RotationErrorRad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return RotationErrorRad(a.linear(), b.linear());
}

/// RotationErrorRad in degrees, in [0, 180].
inline double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return RotationErrorRad(a, b) * 180.0 / kPi;
}
inline double RotationErrorDeg(const Eigen::Isometry3d& truth, const Eigen::Isometry3d& estimate) {
  return RotationErrorDeg(truth.linear(), estimate.linear());
}

/// Distance between the translations of a and b [m].
inline double TranslationErrorM(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

/// The ground-truth poses expressed in a map frame whose pose in the ground-truth frame is T_gt_map.
inline std::vector<Eigen::Isometry3d> InMapFrame(const std::vector<Eigen::Isometry3d>& ground_truth,
                                                 const Eigen::Isometry3d& T_gt_map) {
  std::vector<Eigen::Isometry3d> out;
  out.reserve(ground_truth.size());
  for (const Eigen::Isometry3d& T : ground_truth) out.push_back(T_gt_map.inverse() * T);
  return out;
}

}  // namespace commerge::test
