// SPDX-License-Identifier: BSD-3-Clause
// LiDAR models (core/sim/lidar_models.hpp): the vendors' elevation tables, ray directions, the Livox-style
// rosette (inside its cone, non-repetitive), range noise statistics against a known wall, range limits,
// sensor-frame output and determinism.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/sim/lidar_models.hpp"
#include "core/sim/world.hpp"

namespace commerge {
namespace {

double ToDouble(float v) { return static_cast<double>(v); }

TEST_CASE("lidar models: VLP-16 elevations are -15..+15 deg in 2 deg steps (VLP-16 user manual)") {
  const LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  REQUIRE(m.elevation_deg.size() == 16);
  for (int b = 0; b < 16; ++b) CHECK(ToDouble(m.elevation_deg[static_cast<std::size_t>(b)]) == doctest::Approx(-15.0 + 2.0 * b));
  CHECK(m.azimuth_steps == 1800);  // 0.2 deg at 10 Hz
  CHECK(ValidateLidarModel(m).ok());
}

TEST_CASE("lidar models: HDL-64E blocks: upper +2.0..-8.33 in 1/3 deg, lower -8.83..-24.33 in 1/2 deg (S2/S3 manual)") {
  const LidarModel m = MakeLidarModel(LidarKind::kHdl64e);
  REQUIRE(m.elevation_deg.size() == 64);
  CHECK(ToDouble(m.elevation_deg.back()) == doctest::Approx(2.0));
  CHECK(ToDouble(m.elevation_deg.front()) == doctest::Approx(-24.33));
  for (int b = 1; b < 32; ++b) {  // lower block, ascending
    CHECK(ToDouble(m.elevation_deg[static_cast<std::size_t>(b)] - m.elevation_deg[static_cast<std::size_t>(b - 1)]) ==
          doctest::Approx(0.5).epsilon(1e-4));
  }
  CHECK(ToDouble(m.elevation_deg[31]) == doctest::Approx(-8.83));
  CHECK(ToDouble(m.elevation_deg[32]) == doctest::Approx(2.0 - 31.0 / 3.0));
  for (int b = 33; b < 64; ++b) {
    CHECK(ToDouble(m.elevation_deg[static_cast<std::size_t>(b)] - m.elevation_deg[static_cast<std::size_t>(b - 1)]) ==
          doctest::Approx(1.0 / 3.0).epsilon(1e-4));
  }
  CHECK(ValidateLidarModel(m).ok());
}

TEST_CASE("lidar models: OS1-128 spans +-22.5 deg and OS2-128 +-11.25 deg uniformly (Ouster datasheets)") {
  for (auto [kind, half] : {std::pair{LidarKind::kOs1_128, 22.5}, std::pair{LidarKind::kOs2_128, 11.25}}) {
    const LidarModel m = MakeLidarModel(kind);
    REQUIRE(m.elevation_deg.size() == 128);
    CHECK(ToDouble(m.elevation_deg.front()) == doctest::Approx(-half));
    CHECK(ToDouble(m.elevation_deg.back()) == doctest::Approx(half));
    for (std::size_t b = 1; b < 128; ++b) {
      CHECK(ToDouble(m.elevation_deg[b] - m.elevation_deg[b - 1]) == doctest::Approx(2.0 * half / 127.0).epsilon(1e-3));
    }
  }
}

TEST_CASE("lidar models: spinning ray directions are unit vectors at the table's elevation and column azimuth") {
  LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  m.azimuth_steps = 36;
  std::vector<float> dirs;
  LidarRayDirections(m, 0, &dirs);
  REQUIRE(dirs.size() == 3u * 16u * 36u);
  for (int c = 0; c < 36; ++c) {
    for (int b = 0; b < 16; ++b) {
      const float* d = &dirs[3 * static_cast<std::size_t>(c * 16 + b)];
      CHECK(std::hypot(ToDouble(d[0]), ToDouble(d[1]), ToDouble(d[2])) == doctest::Approx(1.0).epsilon(1e-6));
      CHECK(std::asin(ToDouble(d[2])) * 180.0 / kPi == doctest::Approx(-15.0 + 2.0 * b).epsilon(1e-4));
      double az = std::atan2(ToDouble(d[1]), ToDouble(d[0])) * 180.0 / kPi;
      if (az < -1e-3) az += 360.0;
      CHECK(az == doctest::Approx(10.0 * c).epsilon(1e-4));
    }
  }
}

TEST_CASE("lidar models: the Livox rosette stays in its 70.4 deg cone and does not repeat from frame to frame") {
  const LidarModel m = MakeLidarModel(LidarKind::kLivox);
  CHECK(m.points_per_frame == 10000);
  CHECK(ValidateLidarModel(m).ok());
  std::set<int> covered_one, covered_ten;
  std::vector<float> frame0, frame1;
  double max_angle_deg = 0.0;
  for (std::uint64_t f = 0; f < 10; ++f) {
    std::vector<float> dirs;
    LidarRayDirections(m, f, &dirs);
    REQUIRE(dirs.size() == 30000u);
    if (f == 0) frame0 = dirs;
    if (f == 1) frame1 = dirs;
    for (std::size_t i = 0; i < dirs.size(); i += 3) {
      const double angle_deg = std::acos(std::min(1.0, ToDouble(dirs[i]))) * 180.0 / kPi;
      max_angle_deg = std::max(max_angle_deg, angle_deg);
      // 1 x 1 deg cells of (azimuth, elevation) to measure coverage
      const int cell = static_cast<int>(std::floor(std::atan2(ToDouble(dirs[i + 1]), ToDouble(dirs[i])) * 180 / kPi)) * 1000 +
                       static_cast<int>(std::floor(std::asin(ToDouble(dirs[i + 2])) * 180 / kPi));
      covered_ten.insert(cell);
      if (f == 0) covered_one.insert(cell);
    }
  }
  CHECK(max_angle_deg <= 35.2 + 1e-3);
  CHECK(max_angle_deg > 34.0);  // the cone is used to its edge
  CHECK(frame0 != frame1);
  CHECK(covered_ten.size() > covered_one.size() * 3 / 2);  // integration fills the cone
}

/// A wall (x = 10 m plane, large) in front of the sensor at the origin.
World WallWorld(float x_m) {
  World w;
  w.set_ground_z_m(-50.0f);
  OrientedBox wall;
  wall.cx_m = x_m + 0.5f;
  wall.half_x_m = 0.5f;
  wall.half_y_m = 500.0f;
  wall.z_min_m = -50.0f;
  wall.z_max_m = 50.0f;
  w.AddBox(wall);
  REQUIRE(w.Build().ok());
  return w;
}

TEST_CASE("lidar models: range noise has the configured standard deviation and no bias (wall at 10 m)") {
  const World w = WallWorld(10.0f);
  LidarModel m = MakeLidarModel(LidarKind::kHdl64e);
  m.azimuth_steps = 256;
  m.range_noise_std_m = 0.05f;
  LidarScanWorkspace ws;
  std::vector<PointXYZI> pts;
  REQUIRE(SimulateLidarScan(w, m, Eigen::Isometry3d::Identity(), 77, 0, &ws, &pts).ok());
  REQUIRE(pts.size() > 2000);
  double sum = 0, sum2 = 0;
  for (const PointXYZI& p : pts) {
    CHECK(p.x > 0.0f);  // only the wall in front is hit
    const double r = std::hypot(ToDouble(p.x), ToDouble(p.y), ToDouble(p.z));
    const double true_r = 10.0 * r / ToDouble(p.x);  // the ray's direction is p / |p|: the plane x = 10 along it
    sum += r - true_r;
    sum2 += (r - true_r) * (r - true_r);
  }
  const double n = static_cast<double>(pts.size());
  const double mean = sum / n, stddev = std::sqrt(sum2 / n - mean * mean);
  CHECK(std::fabs(mean) < 4 * 0.05 / std::sqrt(n));
  CHECK(stddev == doctest::Approx(0.05).epsilon(0.06));
}

TEST_CASE("lidar models: returns beyond max range or inside min range are dropped") {
  LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  m.azimuth_steps = 90;
  LidarScanWorkspace ws;
  std::vector<PointXYZI> pts;
  REQUIRE(SimulateLidarScan(WallWorld(150.0f), m, Eigen::Isometry3d::Identity(), 1, 0, &ws, &pts).ok());
  CHECK(pts.empty());  // 150 m > 100 m
  REQUIRE(SimulateLidarScan(WallWorld(0.3f), m, Eigen::Isometry3d::Identity(), 1, 0, &ws, &pts).ok());
  for (const PointXYZI& p : pts) CHECK(std::hypot(ToDouble(p.x), ToDouble(p.y), ToDouble(p.z)) >= ToDouble(m.min_range_m));
}

TEST_CASE("lidar models: points are in the sensor frame and the same seed gives the same scan") {
  // The wall at x = 10 in gt; the sensor at (2, 0, 0) yawed by +90 deg looks along gt +y, so the wall is on
  // its right (sensor -y) at 8 m.
  const World w = WallWorld(10.0f);
  LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  m.azimuth_steps = 180;
  m.range_noise_std_m = 0.0f;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(2.0, 0.0, 0.0);
  LidarScanWorkspace ws;
  std::vector<PointXYZI> pts;
  REQUIRE(SimulateLidarScan(w, m, T, 3, 0, &ws, &pts).ok());
  REQUIRE(!pts.empty());
  for (const PointXYZI& p : pts) CHECK(ToDouble(p.y) == doctest::Approx(-8.0).epsilon(1e-4));

  LidarModel noisy = MakeLidarModel(LidarKind::kVlp16);
  noisy.azimuth_steps = 180;
  std::vector<PointXYZI> a, b, c;
  REQUIRE(SimulateLidarScan(w, noisy, T, 42, 0, &ws, &a).ok());
  LidarScanWorkspace other;
  REQUIRE(SimulateLidarScan(w, noisy, T, 42, 0, &other, &b).ok());
  REQUIRE(SimulateLidarScan(w, noisy, T, 43, 0, &ws, &c).ok());
  REQUIRE(a.size() == b.size());
  bool same = true, differs = a.size() != c.size();
  for (std::size_t i = 0; i < a.size(); ++i) {
    same &= a[i].x == b[i].x && a[i].y == b[i].y && a[i].z == b[i].z && a[i].intensity == b[i].intensity;
    if (i < c.size()) differs |= a[i].x != c[i].x;
  }
  CHECK(same);
  CHECK(differs);
}

TEST_CASE("lidar models: one workspace serves models with the same ray count (OS1-128 then OS2-128)") {
  const World w = WallWorld(10.0f);
  LidarModel os1 = MakeLidarModel(LidarKind::kOs1_128), os2 = MakeLidarModel(LidarKind::kOs2_128);
  os1.azimuth_steps = os2.azimuth_steps = 64;
  REQUIRE(os1.rays_per_frame() == os2.rays_per_frame());
  LidarScanWorkspace ws;
  std::vector<PointXYZI> pts;
  double max_elev_deg = 0.0;
  REQUIRE(SimulateLidarScan(w, os1, Eigen::Isometry3d::Identity(), 1, 0, &ws, &pts).ok());
  for (const PointXYZI& p : pts) max_elev_deg = std::max(max_elev_deg, std::atan2(ToDouble(p.z), std::hypot(ToDouble(p.x), ToDouble(p.y))) * 180 / kPi);
  CHECK(max_elev_deg == doctest::Approx(22.5).epsilon(0.01));
  max_elev_deg = 0.0;
  REQUIRE(SimulateLidarScan(w, os2, Eigen::Isometry3d::Identity(), 1, 0, &ws, &pts).ok());
  for (const PointXYZI& p : pts) max_elev_deg = std::max(max_elev_deg, std::atan2(ToDouble(p.z), std::hypot(ToDouble(p.x), ToDouble(p.y))) * 180 / kPi);
  CHECK(max_elev_deg == doctest::Approx(11.25).epsilon(0.01));
}

TEST_CASE("lidar models: the detection limit drops far grazing ground returns by the received-power formula") {
  // Ground only (reflectivity 0.25), sensor 1.8 m above it: beam e hits at r = 1.8 / sin(-e) with incidence
  // cos = sin(-e); it returns iff r <= max_range * sqrt(0.25 * sin(-e) / rho_ref). Compare the beams that
  // return with that formula, evaluated here independently of the caster.
  World w;
  w.set_ground_z_m(-1.8f);
  REQUIRE(w.Build().ok());
  LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  m.azimuth_steps = 36;
  m.range_noise_std_m = 0.0f;
  LidarScanWorkspace ws;
  std::vector<PointXYZI> off, on;
  REQUIRE(SimulateLidarScan(w, m, Eigen::Isometry3d::Identity(), 5, 0, &ws, &off).ok());
  m.detection_reference_reflectivity = 0.8f;
  REQUIRE(SimulateLidarScan(w, m, Eigen::Isometry3d::Identity(), 5, 0, &ws, &on).ok());
  auto beams_of = [](const std::vector<PointXYZI>& pts) {
    std::set<int> beams;
    for (const PointXYZI& p : pts) {
      beams.insert(static_cast<int>(std::lround(std::atan2(ToDouble(p.z), std::hypot(ToDouble(p.x), ToDouble(p.y))) * 180 / kPi)));
    }
    return beams;
  };
  std::set<int> expect_off, expect_on;
  for (int e = -15; e < 0; e += 2) {
    const double s = std::sin(-e * kPi / 180), r = 1.8 / s;
    if (r <= 100.0) expect_off.insert(e);
    if (r <= 100.0 * std::sqrt(0.25 * s / 0.8)) expect_on.insert(e);
  }
  CHECK(beams_of(off) == expect_off);  // -1 deg reaches the ground at 103 m: beyond max range anyway
  CHECK(beams_of(on) == expect_on);    // -15 .. -7 deg (<= 14.7 m) stay, -5 deg (20.7 m) and flatter fade
  CHECK(expect_on.size() < expect_off.size());
  CHECK(on.size() == 36 * expect_on.size());
  // A wall face-on at 60 m (reflectivity 0.5, cos 1): limit 100 sqrt(0.5 / 0.8) = 79 m, so it stays.
  std::vector<PointXYZI> wall;
  REQUIRE(SimulateLidarScan(WallWorld(60.0f), m, Eigen::Isometry3d::Identity(), 5, 0, &ws, &wall).ok());
  CHECK(!wall.empty());
  m.detection_reference_reflectivity = 1.5f;
  CHECK(ValidateLidarModel(m).message().find("detection_reference_reflectivity") != std::string::npos);
}

TEST_CASE("lidar models: names, SOLiD presets and validation errors") {
  CHECK(*LidarKindFromName("VLP-16") == LidarKind::kVlp16);
  CHECK(*LidarKindFromName("hdl64") == LidarKind::kHdl64e);
  CHECK(*LidarKindFromName("os128") == LidarKind::kOs1_128);
  CHECK(*LidarKindFromName("os2-128") == LidarKind::kOs2_128);
  CHECK(*LidarKindFromName("livox") == LidarKind::kLivox);
  const auto bad = LidarKindFromName("hdl32");
  REQUIRE(!bad.ok());
  CHECK(bad.status().message().find("vlp16, hdl64, os128") != std::string::npos);
  CHECK(std::string(SolidPresetNameFor(LidarKind::kVlp16)) == "vlp-16");
  LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  m.elevation_deg[3] = m.elevation_deg[2];
  CHECK(ValidateLidarModel(m).message().find("ascending") != std::string::npos);
  m = MakeLidarModel(LidarKind::kVlp16);
  m.max_range_m = 0.1f;
  CHECK(!ValidateLidarModel(m).ok());
  World unbuilt;
  LidarScanWorkspace ws;
  std::vector<PointXYZI> pts;
  CHECK(SimulateLidarScan(unbuilt, MakeLidarModel(LidarKind::kVlp16), Eigen::Isometry3d::Identity(), 1, 0, &ws, &pts)
            .code() == StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace commerge
