// SPDX-License-Identifier: BSD-3-Clause
// Scan Context (SOLID.md §6) on generated data: a hand-checked grid, the shift/yaw sign with rotated scans,
// distance behaviour (rotated copy vs another place), degenerate inputs, float16 transport.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/descriptor/descriptor_codec.hpp"
#include "tests/core/descriptor/descriptor_test_util.hpp"
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/synthetic_scan.hpp"

namespace commerge {
namespace {



std::vector<PointXYZI> Street(float x_m) {
  static const BoxScene scene = MakeStreetScene(11);
  SpinningLidar lidar;
  lidar.beams = 16;
  lidar.azimuth_steps = 720;
  lidar.max_range_m = 90.0f;
  std::vector<PointXYZI> pts;
  CastScan(scene, lidar, x_m, 1.5f, 1.73f, 0.0f, 9, &pts);
  return pts;
}

float Cell(const std::vector<float>& sc, int ring, int sector) { return sc[static_cast<std::size_t>(ring * 60 + sector)]; }

TEST_CASE("Scan Context grid: ring / sector indices (ceil - 1), max height + 2 m, empty = 0") {
  const std::vector<PointXYZI> pts = {
      {10, 0.5f, -1.0f, 0},   // rho 10.01 -> ring ceil(2.50) - 1 = 2; theta 2.86 deg -> sector 0; 1.0
      {10, 0.6f, 0.5f, 0},    // same cell, higher: 2.5
      {0, 3, -2.5f, 0},       // x == 0 -> 0.001: theta 89.98 deg -> sector 14; rho 3 -> ring 0; -0.5
      {-41, 0, 1, 0},         // y == 0 -> 0.001: theta 179.9986 deg -> sector 29; rho 41 -> ring 10; 3
      {0.0f, 0.0f, 0.0f, 0},  // rho 0.0014 -> ring 0; theta 45 deg -> sector 7; 2
      {80, 0.1f, 4, 0},       // rho 80.00006 > 80: skipped
      {79.9f, -0.01f, 4, 0},  // theta 359.993 -> sector 59, ring 19; 6
      {std::numeric_limits<float>::quiet_NaN(), 0, 0, 0},
  };
  std::vector<float> sc(1200, 99.0f);
  const auto info = ComputeScanContext(pts, ScanContextParams{}, sc);
  REQUIRE(info.ok());
  CHECK(info->valid);
  CHECK(info->num_points_in == 8);
  CHECK(info->num_nonfinite == 1);
  CHECK(info->num_out_of_range == 1);
  CHECK(info->num_counted == 6);
  CHECK(Cell(sc, 2, 0) == 2.5f);
  CHECK(Cell(sc, 0, 14) == -0.5f);  // negative maxima are kept
  CHECK(Cell(sc, 10, 29) == 3.0f);
  CHECK(Cell(sc, 0, 7) == 2.0f);
  CHECK(Cell(sc, 19, 59) == 6.0f);
  int nonzero = 0;
  for (float v : sc) nonzero += v != 0.0f;
  CHECK(nonzero == 5);

  std::vector<float> key(20);
  REQUIRE(ScanContextRingKey(sc, 20, 60, key).ok());
  CHECK(key[2] == doctest::Approx(2.5 / 60));
  CHECK(key[0] == doctest::Approx(1.5 / 60));
  CHECK_FALSE(ScanContextRingKey(sc, 20, 61, key).ok());
}

TEST_CASE("Scan Context degenerate inputs and parameter validation") {
  ScanContextDescriptor desc;
  CHECK(desc.kind() == DescriptorKind::kScanContext);
  CHECK(desc.dimension() == 1200);
  std::vector<float> sc(1200, 5.0f);
  auto info = desc.Compute(Span<const PointXYZI>(), sc);
  REQUIRE(info.ok());
  CHECK_FALSE(info->valid);
  CHECK(std::all_of(sc.begin(), sc.end(), [](float v) { return v == 0.0f; }));
  const std::vector<PointXYZI> far = {{100, 0, 0, 0}, {0, -200, 3, 0}};
  info = desc.Compute(far, sc);
  REQUIRE(info.ok());
  CHECK_FALSE(info->valid);
  CHECK(info->num_out_of_range == 2);
  std::vector<float> small(1199);
  CHECK_FALSE(desc.Compute(far, small).ok());

  // |C| = 0 for every shift: distance 1.
  const std::vector<float> zeros(1200, 0.0f);
  CHECK(desc.Distance(zeros, zeros) == 1.0);
  CHECK(desc.Distance(zeros, small) == 1.0);

  ScanContextParams bad;
  bad.num_sectors = 7;
  CHECK_FALSE(ValidateScanContextParams(bad).ok());
  bad = ScanContextParams{};
  bad.max_range_m = -1;
  CHECK(ValidateScanContextParams(bad).message().find("max_range_m") != std::string::npos);
  CHECK_FALSE(ScanContextDescriptor::Create(bad).ok());
  CHECK(ScanContextParameterId(ScanContextParams{}) != SolidParameterId(SolidParams{}));
  CHECK(ScanContextParameterId(ScanContextParams{}) == 0x01C24D19u);  // pinned (FNV-1a, see the header)
}

TEST_CASE("Scan Context shift / yaw sign and distance on rotated scans") {
  const std::vector<PointXYZI> base = Street(-30.0f);
  REQUIRE(base.size() > 5000);
  ScanContextDescriptor desc;
  std::vector<float> sc_base(1200), sc_q(1200), sc_other(1200);
  REQUIRE(desc.Compute(base, sc_base).ok());
  REQUIRE(desc.Compute(Street(10.0f), sc_other).ok());
  const ScanContextMatch other = desc.Match(sc_other, sc_base);
  MESSAGE("Scan Context distance to a scan 40 m further: " << other.distance);

  for (const double psi_deg : {30.0, 17.0, 123.4, 271.0}) {
    CAPTURE(psi_deg);
    REQUIRE(desc.Compute(YawedCopy(base, psi_deg * kPi / 180.0), sc_q).ok());
    const ScanContextMatch m = desc.Match(sc_q, sc_base);
    MESSAGE("yaw " << psi_deg << " deg: shift " << m.shift << ", yaw " << m.yaw_rad * kRadToDeg << " deg, distance "
                   << m.distance);
    CHECK(std::fabs(std::remainder(m.yaw_rad * kRadToDeg - psi_deg, 360.0)) <= 6.0);
    CHECK(m.distance < other.distance);
    if (psi_deg == 30.0) {  // a whole number of sectors: the grids are the same up to float rounding
      CHECK(m.shift == 5);
      CHECK(m.distance < 1e-3);
    }
    // The reverse pair is yawed by -psi.
    const ScanContextMatch back = desc.Match(sc_base, sc_q);
    CHECK(std::fabs(std::remainder(back.yaw_rad * kRadToDeg + psi_deg, 360.0)) <= 6.0);
  }
  CHECK(desc.Distance(sc_base, sc_base) < 1e-12);
  CHECK(desc.Match(sc_base, sc_base).shift == 0);
  CHECK(other.distance > 0.1);
}

TEST_CASE("Scan Context survives float16 transport (1200 values -> 2400 bytes)") {
  ScanContextDescriptor desc;
  std::vector<float> sc(1200), q(1200), back(1200);
  const std::vector<PointXYZI> base = Street(-30.0f);
  REQUIRE(desc.Compute(base, sc).ok());
  REQUIRE(desc.Compute(YawedCopy(base, 0.3), q).ok());
  std::vector<std::uint8_t> wire(Float16EncodedBytes(sc.size()));
  CHECK(wire.size() == 2400);
  REQUIRE(EncodeFloat16(sc, wire).ok());
  REQUIRE(DecodeFloat16(wire, back).ok());
  double max_err = 0;
  for (std::size_t i = 0; i < sc.size(); ++i) {
    max_err = std::max(max_err, static_cast<double>(std::fabs(back[i] - sc[i])));
    CHECK(std::fabs(back[i] - sc[i]) <= std::fabs(sc[i]) * (1.0f / 2048.0f));  // half: 11-bit significand
  }
  const ScanContextMatch a = desc.Match(q, sc), b = desc.Match(q, back);
  MESSAGE("float16 Scan Context: max cell error " << max_err << " m, distance " << a.distance << " -> " << b.distance);
  CHECK(a.shift == b.shift);
  CHECK(std::fabs(a.distance - b.distance) < 1e-3);
}

}  // namespace
}  // namespace commerge
