// SPDX-License-Identifier: BSD-3-Clause
// commerge: LiDAR sensor models for the simulator: spinning multi-beam sensors with their vendors' elevation
// tables (Velodyne VLP-16, HDL-64E, Ouster OS1-128 / OS2-128) and a Livox-style non-repetitive rosette
// pattern, ray-cast into a World. Scans are deskewed (every ray of a frame leaves from the same pose) and in
// the sensor frame: x forward, y left, z up.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/cloud/point.hpp"
#include "core/common/status.hpp"
#include "core/sim/world.hpp"

namespace commerge {

enum class LidarKind {
  kVlp16,    ///< Velodyne VLP-16: 16 beams, -15..+15 deg
  kHdl64e,   ///< Velodyne HDL-64E: 64 beams, +2.0..-24.33 deg (KITTI's sensor)
  kOs1_128,  ///< Ouster OS1-128: 128 beams, -22.5..+22.5 deg
  kOs2_128,  ///< Ouster OS2-128: 128 beams, -11.25..+11.25 deg (HeLiPR's sensor)
  kOs0_128,  ///< Ouster OS0-128: 128 beams, -45..+45 deg (wide field: handheld and indoor rigs)
  kLivox,    ///< Livox Mid-70-like: forward cone of 70.4 deg, non-repetitive rosette
};

enum class LidarPattern { kSpinning, kRosette };

/// One sensor model. Spinning: every frame fires `azimuth_steps` columns x the elevation table. Rosette: each
/// frame takes the next `points_per_frame` samples of a rosette (two counter-rotating prisms) that never
/// repeats, so the coverage of the cone grows with integration time.
struct LidarModel {
  LidarKind kind = LidarKind::kVlp16;
  LidarPattern pattern = LidarPattern::kSpinning;
  std::vector<float> elevation_deg;  ///< spinning: one entry per beam, ascending
  int azimuth_steps = 1800;          ///< spinning: columns per revolution
  int points_per_frame = 0;          ///< rosette: rays per frame
  float fov_half_angle_deg = 0.0f;   ///< rosette: half-angle of the circular field of view around +x
  float frame_rate_hz = 10.0f;
  float min_range_m = 0.5f;          ///< returns nearer than this are dropped (sensor blind zone)
  float max_range_m = 100.0f;        ///< no return beyond
  float range_noise_std_m = 0.02f;   ///< Gaussian range noise (1 sigma)
  /// Detection limit: a surface of reflectivity rho hit at incidence cos c returns only within
  /// max_range_m * sqrt(rho * c / detection_reference_reflectivity) (received power ~ rho c / r^2; vendors
  /// quote max range at a reference reflectivity), so ground far away at grazing angles gives no return, as
  /// on real sensors. 0 disables it (every hit within max_range_m returns).
  float detection_reference_reflectivity = 0.0f;

  int rays_per_frame() const;
};

/// The model of `kind` at its default resolution (sources in lidar_models.cpp).
LidarModel MakeLidarModel(LidarKind kind);

/// "vlp16", "hdl64", "os128", "os2-128", "os0-128", "livox".
const char* LidarKindName(LidarKind kind) noexcept;

/// Model by name: vlp16 (vlp-16), hdl64 (hdl-64e), os128 (os1-128), os2-128, os0-128, livox (mid-70); case-insensitive.
/// Unknown name: invalid argument listing the known names.
Result<LidarKind> LidarKindFromName(const std::string& name);

/// The name of the SOLiD preset (core/descriptor/sensor_presets.hpp) matching the model: "vlp-16",
/// "hdl-64e", "os1-128", "os2-128", "os0-128", "avia" (the Livox preset).
const char* SolidPresetNameFor(LidarKind kind) noexcept;

/// OK or invalid argument naming the field: an empty or unsorted elevation table, elevations outside
/// [-90, 90] deg, azimuth_steps < 1 (spinning), points_per_frame < 1 or FOV not in (0, 90) deg (rosette),
/// ranges not 0 <= min < max, negative noise.
Status ValidateLidarModel(const LidarModel& model);

/// Unit ray directions of frame `frame_index` in the sensor frame, packed x, y, z (3 floats per ray).
/// Spinning: column-major (all beams of column 0, then column 1, ...), column c at azimuth 2 pi c / steps
/// counter-clockwise from +x. Rosette: in firing order.
void LidarRayDirections(const LidarModel& model, std::uint64_t frame_index, std::vector<float>* dirs_xyz);

/// Scratch of SimulateLidarScan (ray directions, the caster's mailbox). One per thread.
struct LidarScanWorkspace {
  std::vector<float> dirs;             ///< directions of `dirs_model`'s frame `dirs_frame`
  LidarModel dirs_model;
  std::uint64_t dirs_frame = ~std::uint64_t{0};
  bool dirs_valid = false;
  RayWorkspace rays;
};

/// Casts one frame of `model` from the sensor pose T_gt_sensor (gt = the scene's frame) into `world` (built) and
/// writes the returns in the sensor frame to *out (cleared first): range = true range + N(0, range_noise_std_m),
/// kept when within [min_range_m, max_range_m]; intensity = reflectivity x |cos incidence| in [0, 1].
/// `noise_seed` seeds the range noise, `frame_index` selects the rosette's portion (ignored by spinning models).
/// Deterministic.
/// Errors: invalid model, world not built.
Status SimulateLidarScan(const World& world, const LidarModel& model, const Eigen::Isometry3d& T_gt_sensor,
                         std::uint64_t noise_seed, std::uint64_t frame_index, LidarScanWorkspace* ws,
                         std::vector<PointXYZI>* out);

}  // namespace commerge
