// SPDX-License-Identifier: BSD-3-Clause
// commerge: SOLiD descriptor parameters, per-sensor presets and scan traits, validation and the parameter-set id.
//
// The values of SolidParams are part of the protocol: two SOLiD descriptors are comparable only when all of
// them are identical, which SolidParameterId() condenses into one 32-bit id (shared/spec/SOLID.md §1.1). The
// id travels in every keyframe_batch_t: the server compares only robots of one id (MergeServer).
// min_z_m (our extension, off by default) enters the id only when it is set, so the paper's parameter sets
// keep their ids.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "core/common/status.hpp"

namespace commerge {

/// Largest num_rings / num_sectors a SolidResult holds (the paper's values are 40 / 60).
constexpr int kSolidMaxRings = 80;
constexpr int kSolidMaxSectors = 120;
/// Largest num_elev_bins accepted (the workspace is (num_rings + num_sectors) x num_elev_bins counters).
constexpr int kSolidMaxElevBins = 1024;

/// Parameters of the SOLiD descriptor (SOLID.md §1.1). The defaults are the Velodyne HDL-64E (KITTI) preset.
struct SolidParams {
  int num_rings = 40;           ///< N_r: range rings over [0, max_range_m); R-SOLiD length (the paper fixes 40)
  int num_sectors = 60;         ///< N_a: azimuth sectors over [0, 360) deg; A-SOLiD length; must divide 360
  int num_elev_bins = 64;       ///< N_e: elevation bins over [fov_down_deg, fov_up_deg]; = number of beams
  double fov_up_deg = 2.0;      ///< f_u: upper edge of the vertical field of view [deg]
  double fov_down_deg = -24.8;  ///< f_d: lower edge of the vertical field of view [deg]; f_d < f_u
  double max_range_m = 80.0;    ///< L: ring extent and maximum 3-D range (exclusive) [m]
  double min_range_m = 3.0;     ///< minimum 3-D range (exclusive) [m]
  /// Our extension, not in the paper: points whose z in the sensor frame is below this are not counted
  /// (num_below_min_z), e.g. -0.5 on a sensor 1.8 m above the ground leaves the ground out. The ground's
  /// range rings move with the vehicle's roll and pitch (a 0.5 deg tilt moves a -5 deg beam's ground ring
  /// by 2 m), so on open terrain they make the same place look different. -infinity (default): every point,
  /// as the paper. Recalibrate tau_inter when setting it: distances between unrelated places grow.
  double min_z_m = -std::numeric_limits<double>::infinity();
};

/// Sensors with a built-in preset.
enum class LidarSensor {
  kVelodyneHdl64e,  ///< KITTI: -24.8 .. +2.0 deg (nominal), 64 bins, 80 m
  kVelodyneVlp16,   ///< -15 .. +15 deg, 16 bins, 80 m
  kOusterOs1_64,    ///< -22.5 .. +22.5 deg, 64 bins, 80 m
  kOusterOs1_128,   ///< -22.5 .. +22.5 deg, 128 bins, 80 m
  kOusterOs2_128,   ///< -11.25 .. +11.25 deg, 128 bins, 120 m
  kOusterOs0_128,   ///< -45 .. +45 deg, 128 bins, 80 m (wide-field, handheld / indoor)
  kLivoxAvia,       ///< -38.6 .. +38.6 deg, 64 bins (no beams), 120 m
  kAeva,            ///< -9.6 .. +9.6 deg, 64 bins, 120 m
};

/// Preset of `sensor`. Sources: SOLID.md §1.1 (sparolab/SOLiD python/test.py header; HDL-64E from the C++
/// header) for HDL-64E, VLP-16, OS1-64, Avia and Aeva; Ouster datasheets (OS1 45 deg, OS2 22.5 deg vertical
/// FOV, symmetric about the horizon) for OS1-128 / OS2-128, with L = 80 m like every spinning preset for the
/// OS1 and L = 120 m for the long-range OS2 (an assumption: re-calibrate on recorded data).
/// Real elevations can exceed the nominal FOV (KITTI: up to +4.2 deg); watch num_above_fov.
SolidParams SolidPreset(LidarSensor sensor) noexcept;

/// Canonical name of `sensor`: "hdl-64e", "vlp-16", "os1-64", "os1-128", "os2-128", "avia", "aeva".
const char* LidarSensorName(LidarSensor sensor) noexcept;

/// Sensor by name, case-insensitive, ignoring '-', '_' and spaces: the canonical names above plus the
/// aliases "kitti" (HDL-64E), "velodyne-hdl-64e", "velodyne-vlp-16", "ouster-os1-64", "ouster-os1-128",
/// "ouster-os2-128", "livox-avia". Unknown name: not found, the message lists the known names.
Result<LidarSensor> LidarSensorFor(const std::string& name);

/// Preset of the sensor named `sensor` (names as LidarSensorFor).
Result<SolidParams> SolidPresetFor(const std::string& sensor);

/// How a sensor scans, from its datasheet, for the choices that depend on it rather than on its SOLiD bins.
struct LidarScanTraits {
  /// Horizontal field of view [deg]: 360 for the spinning sensors, 70.4 for the Livox Avia, 120 for the Aeva
  /// Aeries II. A sensor narrower than 360 deg sees a place again only from a similar heading.
  double horizontal_fov_deg = 360.0;
  /// A non-repetitive (rosette) pattern: each scan covers the field of view sparsely and differently, so the
  /// paper's second threshold column (tau_intra 0.01, tau_inter 0.05) and accumulated local maps apply.
  /// Only the Livox Avia.
  bool non_repetitive = false;
};
LidarScanTraits ScanTraits(LidarSensor sensor) noexcept;
/// The traits of the sensor named `sensor` (names as LidarSensorFor); a spinning 360 deg sensor when unknown.
LidarScanTraits ScanTraitsFor(const std::string& sensor);

/// The paper's descriptor thresholds by scan pattern (its two threshold columns): tau_inter 0.10 and tau_intra
/// 0.05 for a spinning sensor, 0.05 and 0.01 for a non-repetitive one.
double PaperTauInter(const LidarScanTraits& traits) noexcept;
double PaperTauIntra(const LidarScanTraits& traits) noexcept;
/// Headings within which two keyframes see the same place: the horizontal field of view, at most 180 deg.
double ColocationHeadingDeg(const LidarScanTraits& traits) noexcept;

/// OK, or invalid argument naming the first offending field and its value: counts in [1, kSolidMax*];
/// num_sectors must divide 360; FOV finite, within [-90, 90] deg and fov_down_deg < fov_up_deg; ranges
/// finite with 0 <= min_range_m < max_range_m; min_z_m -infinity or finite within (-max_range_m, max_range_m).
Status ValidateSolidParams(const SolidParams& params);

/// Stable 32-bit id of the parameter set: FNV-1a over the descriptor kind byte (1 = SOLiD), the three
/// counts as little-endian int32 and the four lengths/angles as little-endian IEEE-754 binary64 bit
/// patterns (-0.0 hashed as +0.0), in declaration order; when min_z_m is finite, then the byte 'z' and
/// min_z_m the same way (so an unset min_z_m leaves the id as before). Identical on every platform.
std::uint32_t SolidParameterId(const SolidParams& params) noexcept;

namespace detail {
/// FNV-1a (32-bit) building blocks shared by the descriptor parameter ids.
constexpr std::uint32_t kFnv1aOffset = 2166136261u;
std::uint32_t Fnv1aByte(std::uint32_t h, std::uint8_t byte) noexcept;
std::uint32_t Fnv1aInt32(std::uint32_t h, std::int32_t value) noexcept;
std::uint32_t Fnv1aDouble(std::uint32_t h, double value) noexcept;
}  // namespace detail

}  // namespace commerge
