// SPDX-License-Identifier: BSD-3-Clause
// The sensor-to-body extrinsic of the ROS inputs (`commerge import --extrinsic`, `commerge-ros1-bridge --extrinsic`).
#pragma once

#include <string>

#include <Eigen/Geometry>

#include "core/common/status.hpp"

namespace commerge::platform {

/// "x y z roll pitch yaw" [m, deg] -> T_body_sensor = Trans(x, y, z) * Rz(yaw) * Ry(pitch) * Rx(roll); "" is the
/// identity. Errors (InvalidArgument naming --extrinsic and the text): not six finite numbers.
Result<Eigen::Isometry3d> ParseExtrinsic(const std::string& text);

}  // namespace commerge::platform
