// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/extrinsic.hpp"

#include <cmath>
#include <sstream>

#include "core/geometry/angles.hpp"

namespace commerge::platform {

Result<Eigen::Isometry3d> ParseExtrinsic(const std::string& text) {
  Eigen::Isometry3d T_body_sensor = Eigen::Isometry3d::Identity();
  if (text.empty()) return T_body_sensor;
  std::istringstream in(text);
  double v[6];
  for (double& x : v) {
    if (!(in >> x) || !std::isfinite(x)) {
      return InvalidArgument("--extrinsic: want six numbers \"x y z roll pitch yaw\" [m, deg], got '" + text + "'");
    }
  }
  std::string rest;
  if (in >> rest) return InvalidArgument("--extrinsic: more than six numbers in '" + text + "'");
  const double rad_per_deg = kPi / 180.0;
  T_body_sensor.linear() = (Eigen::AngleAxisd(v[5] * rad_per_deg, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(v[4] * rad_per_deg, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(v[3] * rad_per_deg, Eigen::Vector3d::UnitX()))
                               .toRotationMatrix();
  T_body_sensor.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return T_body_sensor;
}

}  // namespace commerge::platform
