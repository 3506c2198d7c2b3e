// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/lidar_models.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "core/geometry/angles.hpp"
#include "core/sim/sim_random.hpp"

namespace commerge {

namespace {

std::vector<float> UniformTable(int beams, double lo_deg, double hi_deg) {
  std::vector<float> t(static_cast<std::size_t>(beams));
  for (int b = 0; b < beams; ++b) {
    t[static_cast<std::size_t>(b)] =
        static_cast<float>(lo_deg + (hi_deg - lo_deg) * static_cast<double>(b) / static_cast<double>(beams - 1));
  }
  return t;
}

std::string CanonicalModelName(const std::string& name) {
  std::string out;
  for (char c : name) {
    if (c == '-' || c == '_' || c == ' ') continue;
    out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  return out;
}

// Rosette: two counter-rotating prisms deflect the beam by (R/2)(e^{i w1 t} + e^{-i w2 t}), so |deflection|
// = R |cos((w1 + w2) t / 2)|: petals through the centre whose orientation turns at (w1 - w2) / 2. The
// frequency ratio is irrational-looking, so the pattern does not repeat from frame to frame.
constexpr double kRosetteF1Hz = 131.1;
constexpr double kRosetteF2Hz = 97.3;

}  // namespace

int LidarModel::rays_per_frame() const {
  return pattern == LidarPattern::kSpinning ? static_cast<int>(elevation_deg.size()) * azimuth_steps
                                            : points_per_frame;
}

LidarModel MakeLidarModel(LidarKind kind) {
  LidarModel m;
  m.kind = kind;
  switch (kind) {
    case LidarKind::kVlp16:
      // VLP-16 user manual (Velodyne 63-9243), "Laser ID / vertical angle" table: -15..+15 deg in 2 deg steps
      // (fired interleaved -15, 1, -13, 3, ...; stored here ascending). 0.2 deg azimuth at 600 rpm (10 Hz),
      // 100 m range, +-3 cm typical accuracy (1 sigma ~1.5 cm).
      m.elevation_deg = UniformTable(16, -15.0, 15.0);
      m.azimuth_steps = 1800;
      m.min_range_m = 0.5f;
      m.max_range_m = 100.0f;
      m.range_noise_std_m = 0.015f;
      break;
    case LidarKind::kHdl64e: {
      // HDL-64E S2/S3 user manual: two blocks of 32 lasers; the upper block spans +2.0 .. -8.33 deg in 1/3 deg
      // steps, the lower block -8.83 .. -24.33 deg in 1/2 deg steps (datasheet: +2 / -24.8 deg nominal FOV,
      // ~0.4 deg mean spacing; calibrated units deviate by a few tenths of a degree). 0.17 deg azimuth at 10 Hz
      // (~2048 columns, as KITTI), 120 m range, < 2 cm accuracy.
      for (int i = 31; i >= 0; --i) m.elevation_deg.push_back(static_cast<float>(-8.83 - 0.5 * i));
      for (int i = 31; i >= 0; --i) m.elevation_deg.push_back(static_cast<float>(2.0 - static_cast<double>(i) / 3.0));
      m.azimuth_steps = 2048;
      m.min_range_m = 1.0f;
      m.max_range_m = 120.0f;
      m.range_noise_std_m = 0.01f;
      break;
    }
    case LidarKind::kOs1_128:
      // Ouster OS1 datasheet (rev 06): 128 channels uniformly over a 45 deg vertical FOV (+22.5 .. -22.5 deg,
      // 0.35 deg spacing); lidar_mode 1024x10; 120 m range (80 % reflectivity); precision ~+-3 cm.
      m.elevation_deg = UniformTable(128, -22.5, 22.5);
      m.azimuth_steps = 1024;
      m.min_range_m = 0.5f;
      m.max_range_m = 120.0f;
      m.range_noise_std_m = 0.02f;
      break;
    case LidarKind::kOs2_128:
      // Ouster OS2 datasheet (rev 06): 128 channels uniformly over 22.5 deg (+11.25 .. -11.25 deg, 0.18 deg
      // spacing); 1024x10; 240 m range (80 % reflectivity).
      m.elevation_deg = UniformTable(128, -11.25, 11.25);
      m.azimuth_steps = 1024;
      m.min_range_m = 1.0f;
      m.max_range_m = 240.0f;
      m.range_noise_std_m = 0.025f;
      break;
    case LidarKind::kOs0_128:
      // Ouster OS0 datasheet (rev 06): 128 channels uniformly over a 90 deg vertical FOV (+45 .. -45 deg,
      // 0.7 deg spacing); 1024x10; 50 m range (80 % reflectivity); precision ~+-3 cm.
      m.elevation_deg = UniformTable(128, -45.0, 45.0);
      m.azimuth_steps = 1024;
      m.min_range_m = 0.3f;
      m.max_range_m = 50.0f;
      m.range_noise_std_m = 0.02f;
      break;
    case LidarKind::kLivox:
      // Livox Mid-70 specifications: circular 70.4 deg FOV, 100 000 points/s (10 000 per 10 Hz frame),
      // non-repetitive scanning, 90 m range at 10 % reflectivity, 2 cm range precision (1 sigma).
      m.pattern = LidarPattern::kRosette;
      m.points_per_frame = 10000;
      m.fov_half_angle_deg = 35.2f;
      m.azimuth_steps = 0;
      m.min_range_m = 0.1f;
      m.max_range_m = 90.0f;
      m.range_noise_std_m = 0.02f;
      break;
  }
  return m;
}

const char* LidarKindName(LidarKind kind) noexcept {
  switch (kind) {
    case LidarKind::kVlp16: return "vlp16";
    case LidarKind::kHdl64e: return "hdl64";
    case LidarKind::kOs1_128: return "os128";
    case LidarKind::kOs2_128: return "os2-128";
    case LidarKind::kOs0_128: return "os0-128";
    case LidarKind::kLivox: return "livox";
  }
  return "?";
}

Result<LidarKind> LidarKindFromName(const std::string& name) {
  const std::string c = CanonicalModelName(name);
  if (c == "vlp16" || c == "velodynevlp16") return LidarKind::kVlp16;
  if (c == "hdl64" || c == "hdl64e" || c == "velodynehdl64e" || c == "kitti") return LidarKind::kHdl64e;
  if (c == "os128" || c == "os1128" || c == "ousteros1128") return LidarKind::kOs1_128;
  if (c == "os2128" || c == "ousteros2128") return LidarKind::kOs2_128;
  if (c == "os0128" || c == "ousteros0128") return LidarKind::kOs0_128;
  if (c == "livox" || c == "mid70" || c == "livoxmid70") return LidarKind::kLivox;
  return InvalidArgument("unknown lidar '" + name + "' (known: vlp16, hdl64, os128, os2-128, os0-128, livox)");
}

const char* SolidPresetNameFor(LidarKind kind) noexcept {
  switch (kind) {
    case LidarKind::kVlp16: return "vlp-16";
    case LidarKind::kHdl64e: return "hdl-64e";
    case LidarKind::kOs1_128: return "os1-128";
    case LidarKind::kOs2_128: return "os2-128";
    case LidarKind::kOs0_128: return "os0-128";
    case LidarKind::kLivox: return "avia";
  }
  return "?";
}

Status ValidateLidarModel(const LidarModel& m) {
  if (m.pattern == LidarPattern::kSpinning) {
    if (m.elevation_deg.empty()) return InvalidArgument("lidar model: empty elevation table");
    for (std::size_t b = 0; b < m.elevation_deg.size(); ++b) {
      const float e = m.elevation_deg[b];
      if (!std::isfinite(e) || e < -90.0f || e > 90.0f) {
        return InvalidArgument("lidar model: elevation of beam " + std::to_string(b) + " outside [-90, 90] deg");
      }
      if (b > 0 && !(e > m.elevation_deg[b - 1])) {
        return InvalidArgument("lidar model: elevation table not strictly ascending at beam " + std::to_string(b));
      }
    }
    if (m.azimuth_steps < 1) return InvalidArgument("lidar model: azimuth_steps must be >= 1");
  } else {
    if (m.points_per_frame < 1) return InvalidArgument("lidar model: points_per_frame must be >= 1");
    if (!(m.fov_half_angle_deg > 0.0f && m.fov_half_angle_deg < 90.0f)) {
      return InvalidArgument("lidar model: fov_half_angle_deg must be in (0, 90)");
    }
  }
  if (!(m.min_range_m >= 0.0f) || !(m.max_range_m > m.min_range_m) || !std::isfinite(m.max_range_m)) {
    return InvalidArgument("lidar model: ranges must satisfy 0 <= min_range_m < max_range_m");
  }
  if (!(m.range_noise_std_m >= 0.0f) || !std::isfinite(m.range_noise_std_m)) {
    return InvalidArgument("lidar model: range_noise_std_m must be finite and >= 0");
  }
  if (!(m.frame_rate_hz > 0.0f)) return InvalidArgument("lidar model: frame_rate_hz must be > 0");
  if (!(m.detection_reference_reflectivity >= 0.0f && m.detection_reference_reflectivity <= 1.0f)) {
    return InvalidArgument("lidar model: detection_reference_reflectivity must be in [0, 1] (0 = off)");
  }
  return Status::Ok();
}

void LidarRayDirections(const LidarModel& m, std::uint64_t frame_index, std::vector<float>* dirs) {
  dirs->clear();
  if (m.pattern == LidarPattern::kSpinning) {
    const std::size_t beams = m.elevation_deg.size();
    dirs->reserve(3 * beams * static_cast<std::size_t>(std::max(m.azimuth_steps, 0)));
    std::vector<double> ce(beams), se(beams);
    for (std::size_t b = 0; b < beams; ++b) {
      const double e = static_cast<double>(m.elevation_deg[b]) * kPi / 180.0;
      ce[b] = std::cos(e);
      se[b] = std::sin(e);
    }
    for (int c = 0; c < m.azimuth_steps; ++c) {
      const double az = 2.0 * kPi * static_cast<double>(c) / static_cast<double>(m.azimuth_steps);
      const double ca = std::cos(az), sa = std::sin(az);
      for (std::size_t b = 0; b < beams; ++b) {
        dirs->push_back(static_cast<float>(ce[b] * ca));
        dirs->push_back(static_cast<float>(ce[b] * sa));
        dirs->push_back(static_cast<float>(se[b]));
      }
    }
    return;
  }
  const double half = static_cast<double>(m.fov_half_angle_deg) * kPi / 180.0;
  const double w1 = 2.0 * kPi * kRosetteF1Hz, w2 = 2.0 * kPi * kRosetteF2Hz;
  const double dt = 1.0 / (static_cast<double>(m.frame_rate_hz) * static_cast<double>(m.points_per_frame));
  dirs->reserve(3 * static_cast<std::size_t>(m.points_per_frame));
  // Sample j of frame f fires at t = (f N + j) dt (double: phases stay exact to ~1e-9 rad for a day of frames).
  const std::uint64_t base = frame_index * static_cast<std::uint64_t>(m.points_per_frame);
  for (int j = 0; j < m.points_per_frame; ++j) {
    const double t = static_cast<double>(base + static_cast<std::uint64_t>(j)) * dt;
    const double p1 = w1 * t, p2 = w2 * t;
    const double ux = 0.5 * half * (std::cos(p1) + std::cos(p2));
    const double uy = 0.5 * half * (std::sin(p1) - std::sin(p2));
    const double theta = std::sqrt(ux * ux + uy * uy);
    const double st = std::sin(theta);
    const double inv = theta > 1e-12 ? 1.0 / theta : 0.0;
    dirs->push_back(static_cast<float>(std::cos(theta)));
    dirs->push_back(static_cast<float>(st * ux * inv));
    dirs->push_back(static_cast<float>(st * uy * inv));
  }
}

Status SimulateLidarScan(const World& world, const LidarModel& model, const Eigen::Isometry3d& T_gt_sensor,
                         std::uint64_t noise_seed, std::uint64_t frame_index, LidarScanWorkspace* ws,
                         std::vector<PointXYZI>* out) {
  if (Status st = ValidateLidarModel(model); !st.ok()) return st;
  if (!world.built()) return InvalidArgument("lidar scan: the world is not built (call World::Build)");
  if (ws == nullptr || out == nullptr) return InvalidArgument("lidar scan: null workspace or output");
  const bool per_frame = model.pattern == LidarPattern::kRosette;
  const LidarModel& cached = ws->dirs_model;
  const bool same_rays = ws->dirs_valid && cached.pattern == model.pattern && cached.elevation_deg == model.elevation_deg &&
                         cached.azimuth_steps == model.azimuth_steps && cached.points_per_frame == model.points_per_frame &&
                         cached.fov_half_angle_deg == model.fov_half_angle_deg &&
                         cached.frame_rate_hz == model.frame_rate_hz && (!per_frame || ws->dirs_frame == frame_index);
  if (!same_rays) {
    LidarRayDirections(model, frame_index, &ws->dirs);
    ws->dirs_model = model;
    ws->dirs_frame = frame_index;
    ws->dirs_valid = true;
  }
  out->clear();
  const Eigen::Matrix3f R = T_gt_sensor.linear().cast<float>();
  const Eigen::Vector3f t = T_gt_sensor.translation().cast<float>();
  const float origin[3] = {t.x(), t.y(), t.z()};
  SimRandom rng(noise_seed);
  const float sigma = model.range_noise_std_m;
  const float cast_max = model.max_range_m + 4.0f * sigma;
  const std::size_t rays = ws->dirs.size() / 3;
  for (std::size_t r = 0; r < rays; ++r) {
    const float* ds = &ws->dirs[3 * r];
    const float dw[3] = {R(0, 0) * ds[0] + R(0, 1) * ds[1] + R(0, 2) * ds[2],
                         R(1, 0) * ds[0] + R(1, 1) * ds[1] + R(1, 2) * ds[2],
                         R(2, 0) * ds[0] + R(2, 1) * ds[1] + R(2, 2) * ds[2]};
    RayHit hit;
    const float noise = sigma > 0.0f ? sigma * static_cast<float>(rng.Gaussian()) : 0.0f;  // one draw per ray
    if (!world.CastRay(origin, dw, 0.0f, cast_max, &ws->rays, &hit)) continue;
    const float range = hit.range_m + noise;
    if (!(range >= model.min_range_m) || !(range <= model.max_range_m)) continue;
    if (model.detection_reference_reflectivity > 0.0f) {
      const float limit = model.max_range_m * std::sqrt(std::max(0.0f, hit.reflectivity * hit.cos_incidence) /
                                                        model.detection_reference_reflectivity);
      if (range > limit) continue;
    }
    const float intensity = std::clamp(hit.reflectivity * hit.cos_incidence, 0.0f, 1.0f);
    out->push_back(PointXYZI{range * ds[0], range * ds[1], range * ds[2], intensity});
  }
  return Status::Ok();
}

}  // namespace commerge
