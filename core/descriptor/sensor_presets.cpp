// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/sensor_presets.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "core/common/number_text.hpp"

namespace commerge {
namespace {

// Lower case, without '-', '_' and spaces.
std::string Canonical(const std::string& name) {
  std::string out;
  out.reserve(name.size());
  for (const char c : name) {
    if (c == '-' || c == '_' || c == ' ') continue;
    out.push_back((c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c);
  }
  return out;
}

struct NamedSensor {
  const char* key;  // canonical form
  LidarSensor sensor;
};

constexpr NamedSensor kNames[] = {
    {"hdl64e", LidarSensor::kVelodyneHdl64e},     {"kitti", LidarSensor::kVelodyneHdl64e},
    {"velodynehdl64e", LidarSensor::kVelodyneHdl64e}, {"vlp16", LidarSensor::kVelodyneVlp16},
    {"velodynevlp16", LidarSensor::kVelodyneVlp16}, {"os164", LidarSensor::kOusterOs1_64},
    {"ousteros164", LidarSensor::kOusterOs1_64},   {"os1128", LidarSensor::kOusterOs1_128},
    {"ousteros1128", LidarSensor::kOusterOs1_128}, {"os2128", LidarSensor::kOusterOs2_128},
    {"ousteros2128", LidarSensor::kOusterOs2_128}, {"os0128", LidarSensor::kOusterOs0_128},
    {"ousteros0128", LidarSensor::kOusterOs0_128}, {"avia", LidarSensor::kLivoxAvia},
    {"livoxavia", LidarSensor::kLivoxAvia},        {"aeva", LidarSensor::kAeva},
};

SolidParams Make(int elev_bins, double fov_down_deg, double fov_up_deg, double max_range_m) {
  SolidParams p;
  p.num_rings = 40;
  p.num_sectors = 60;
  p.num_elev_bins = elev_bins;
  p.fov_up_deg = fov_up_deg;
  p.fov_down_deg = fov_down_deg;
  p.max_range_m = max_range_m;
  p.min_range_m = 3.0;
  return p;
}

}  // namespace

SolidParams SolidPreset(LidarSensor sensor) noexcept {
  switch (sensor) {
    case LidarSensor::kVelodyneHdl64e: return Make(64, -24.8, 2.0, 80.0);
    case LidarSensor::kVelodyneVlp16: return Make(16, -15.0, 15.0, 80.0);
    case LidarSensor::kOusterOs1_64: return Make(64, -22.5, 22.5, 80.0);
    case LidarSensor::kOusterOs1_128: return Make(128, -22.5, 22.5, 80.0);
    case LidarSensor::kOusterOs2_128: return Make(128, -11.25, 11.25, 120.0);
    case LidarSensor::kOusterOs0_128: return Make(128, -45.0, 45.0, 80.0);
    case LidarSensor::kLivoxAvia: return Make(64, -38.6, 38.6, 120.0);
    case LidarSensor::kAeva: return Make(64, -9.6, 9.6, 120.0);
  }
  return SolidParams{};
}

const char* LidarSensorName(LidarSensor sensor) noexcept {
  switch (sensor) {
    case LidarSensor::kVelodyneHdl64e: return "hdl-64e";
    case LidarSensor::kVelodyneVlp16: return "vlp-16";
    case LidarSensor::kOusterOs1_64: return "os1-64";
    case LidarSensor::kOusterOs1_128: return "os1-128";
    case LidarSensor::kOusterOs2_128: return "os2-128";
    case LidarSensor::kOusterOs0_128: return "os0-128";
    case LidarSensor::kLivoxAvia: return "avia";
    case LidarSensor::kAeva: return "aeva";
  }
  return "unknown";
}

Result<LidarSensor> LidarSensorFor(const std::string& name) {
  const std::string key = Canonical(name);
  for (const NamedSensor& n : kNames) {
    if (key == n.key) return n.sensor;
  }
  return NotFound("no SOLiD preset for sensor '" + name +
                  "'; known: hdl-64e (kitti), vlp-16, os1-64, os1-128, os2-128, os0-128, avia (livox-avia), aeva");
}

Result<SolidParams> SolidPresetFor(const std::string& sensor) {
  Result<LidarSensor> s = LidarSensorFor(sensor);
  if (!s.ok()) return s.status();
  return SolidPreset(*s);
}

LidarScanTraits ScanTraits(LidarSensor sensor) noexcept {
  LidarScanTraits t;
  switch (sensor) {
    case LidarSensor::kLivoxAvia:
      t.horizontal_fov_deg = 70.4;
      t.non_repetitive = true;
      break;
    case LidarSensor::kAeva: t.horizontal_fov_deg = 120.0; break;
    case LidarSensor::kVelodyneHdl64e:
    case LidarSensor::kVelodyneVlp16:
    case LidarSensor::kOusterOs1_64:
    case LidarSensor::kOusterOs1_128:
    case LidarSensor::kOusterOs2_128:
    case LidarSensor::kOusterOs0_128: break;
  }
  return t;
}

LidarScanTraits ScanTraitsFor(const std::string& sensor) {
  Result<LidarSensor> found = LidarSensorFor(sensor);
  return found.ok() ? ScanTraits(*found) : LidarScanTraits{};
}

double PaperTauInter(const LidarScanTraits& traits) noexcept { return traits.non_repetitive ? 0.05 : 0.10; }

double PaperTauIntra(const LidarScanTraits& traits) noexcept { return traits.non_repetitive ? 0.01 : 0.05; }

double ColocationHeadingDeg(const LidarScanTraits& traits) noexcept {
  return traits.horizontal_fov_deg < 180.0 ? traits.horizontal_fov_deg : 180.0;
}

Status ValidateSolidParams(const SolidParams& p) {
  const auto count_error = [](const char* field, int value, int max) {
    return InvalidArgument(std::string("SOLiD parameters: ") + field + " must be in [1, " + std::to_string(max) +
                           "], got " + std::to_string(value));
  };
  if (p.num_rings < 1 || p.num_rings > kSolidMaxRings) return count_error("num_rings", p.num_rings, kSolidMaxRings);
  if (p.num_sectors < 1 || p.num_sectors > kSolidMaxSectors) {
    return count_error("num_sectors", p.num_sectors, kSolidMaxSectors);
  }
  if (360 % p.num_sectors != 0) {
    return InvalidArgument("SOLiD parameters: num_sectors must divide 360, got " + std::to_string(p.num_sectors));
  }
  if (p.num_elev_bins < 1 || p.num_elev_bins > kSolidMaxElevBins) {
    return count_error("num_elev_bins", p.num_elev_bins, kSolidMaxElevBins);
  }
  if (!(std::isfinite(p.fov_up_deg) && p.fov_up_deg >= -90.0 && p.fov_up_deg <= 90.0)) {
    return InvalidArgument("SOLiD parameters: fov_up_deg must be finite and in [-90, 90], got " +
                           FormatNumber(p.fov_up_deg, 12));
  }
  if (!(std::isfinite(p.fov_down_deg) && p.fov_down_deg >= -90.0 && p.fov_down_deg <= 90.0)) {
    return InvalidArgument("SOLiD parameters: fov_down_deg must be finite and in [-90, 90], got " +
                           FormatNumber(p.fov_down_deg, 12));
  }
  if (!(p.fov_down_deg < p.fov_up_deg)) {
    return InvalidArgument("SOLiD parameters: fov_down_deg (" + FormatNumber(p.fov_down_deg, 12) +
                           ") must be < fov_up_deg (" + FormatNumber(p.fov_up_deg, 12) +
                           "); a swapped FOV drops or misbins 40-50 % of the points");
  }
  if (!(std::isfinite(p.max_range_m) && p.max_range_m > 0.0)) {
    return InvalidArgument("SOLiD parameters: max_range_m must be finite and > 0, got " +
                           FormatNumber(p.max_range_m, 12));
  }
  if (!(std::isfinite(p.min_range_m) && p.min_range_m >= 0.0 && p.min_range_m < p.max_range_m)) {
    return InvalidArgument("SOLiD parameters: min_range_m must be finite, >= 0 and < max_range_m (" +
                           FormatNumber(p.max_range_m, 12) + "), got " + FormatNumber(p.min_range_m, 12));
  }
  const bool z_unset = p.min_z_m == -std::numeric_limits<double>::infinity();
  if (!z_unset && !(std::isfinite(p.min_z_m) && std::abs(p.min_z_m) < p.max_range_m)) {
    return InvalidArgument(
        "SOLiD parameters: min_z_m must be -infinity (off) or finite within (-max_range_m, "
        "max_range_m) = (-" +
        FormatNumber(p.max_range_m, 12) + ", " + FormatNumber(p.max_range_m, 12) + "), got " +
        FormatNumber(p.min_z_m, 12));
  }
  return Status::Ok();
}

namespace detail {

std::uint32_t Fnv1aByte(std::uint32_t h, std::uint8_t byte) noexcept {
  return (h ^ byte) * 16777619u;
}

std::uint32_t Fnv1aInt32(std::uint32_t h, std::int32_t value) noexcept {
  const auto u = static_cast<std::uint32_t>(value);
  for (int i = 0; i < 4; ++i) h = Fnv1aByte(h, static_cast<std::uint8_t>(u >> (8 * i)));
  return h;
}

std::uint32_t Fnv1aDouble(std::uint32_t h, double value) noexcept {
  if (value == 0.0) value = 0.0;  // -0.0 and +0.0 describe the same parameter
  std::uint64_t bits = 0;
  static_assert(sizeof(bits) == sizeof(value), "IEEE-754 binary64 expected");
  std::memcpy(&bits, &value, sizeof(bits));
  for (int i = 0; i < 8; ++i) h = Fnv1aByte(h, static_cast<std::uint8_t>(bits >> (8 * i)));
  return h;
}

}  // namespace detail

std::uint32_t SolidParameterId(const SolidParams& p) noexcept {
  std::uint32_t h = detail::Fnv1aByte(detail::kFnv1aOffset, 1);  // DescriptorKind::kSolid
  h = detail::Fnv1aInt32(h, p.num_rings);
  h = detail::Fnv1aInt32(h, p.num_sectors);
  h = detail::Fnv1aInt32(h, p.num_elev_bins);
  h = detail::Fnv1aDouble(h, p.fov_up_deg);
  h = detail::Fnv1aDouble(h, p.fov_down_deg);
  h = detail::Fnv1aDouble(h, p.max_range_m);
  h = detail::Fnv1aDouble(h, p.min_range_m);
  if (std::isfinite(p.min_z_m)) {
    h = detail::Fnv1aByte(h, static_cast<std::uint8_t>('z'));
    h = detail::Fnv1aDouble(h, p.min_z_m);
  }
  return h;
}

}  // namespace commerge
