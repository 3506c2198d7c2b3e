// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/keyframe_drive.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "core/descriptor/sensor_presets.hpp"

namespace commerge {

Result<SimulatedKeyframes> SimulateStraightDrive(const BoxScene& scene, const SpinningLidar& lidar,
                                                 const SolidParams& solid, const StraightDrive& drive) {
  if (Status s = ValidateSolidParams(solid); !s.ok()) return s;
  if (drive.keyframes < 0) return InvalidArgument("simulated drive: keyframes must be >= 0");
  SimulatedKeyframes out;
  out.dim = solid.num_rings;
  const std::size_t count = static_cast<std::size_t>(drive.keyframes);
  out.descriptors.resize(count * static_cast<std::size_t>(out.dim));
  out.valid.resize(count);
  SolidWorkspace workspace(solid);
  std::vector<PointXYZI> scan;
  const double c = std::cos(static_cast<double>(drive.yaw_rad)), s = std::sin(static_cast<double>(drive.yaw_rad));
  const Eigen::Isometry3d T_gt_start =
      Eigen::Translation3d(static_cast<double>(drive.start_x_m), static_cast<double>(drive.lane_y_m),
                           static_cast<double>(drive.sensor_height_m)) *
      Eigen::AngleAxisd(static_cast<double>(drive.yaw_rad), Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d T_start_gt = T_gt_start.inverse();
  for (std::size_t k = 0; k < count; ++k) {
    const double along = static_cast<double>(drive.spacing_m) * static_cast<double>(k);
    const Eigen::Vector3d p_gt(static_cast<double>(drive.start_x_m) + along * c,
                               static_cast<double>(drive.lane_y_m) + along * s,
                               static_cast<double>(drive.sensor_height_m));
    CastScan(scene, lidar, static_cast<float>(p_gt.x()), static_cast<float>(p_gt.y()), drive.sensor_height_m,
             drive.yaw_rad, drive.seed + static_cast<std::uint32_t>(k), &scan);
    SolidResult result;
    if (Status st = ComputeSolid(Span<const PointXYZI>(scan), solid, &workspace, &result); !st.ok()) return st;
    if (Status st = UnitNormalizeRSolid(result, Span<float>(out.descriptors.data() + k * static_cast<std::size_t>(out.dim),
                                                               static_cast<std::size_t>(out.dim)));
        !st.ok()) {
      return st;
    }
    out.valid[k] = result.valid ? 1 : 0;
    out.gt_m.push_back(p_gt);
    out.own_frame_m.push_back(T_start_gt * p_gt);
    out.raw_points.push_back(static_cast<std::uint32_t>(scan.size()));
  }
  return out;
}

}  // namespace commerge
