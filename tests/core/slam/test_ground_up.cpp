// SPDX-License-Identifier: BSD-3-Clause
// Up from the ground (core/slam/ground_up.hpp): the fitted ground normal against the plane the points were drawn
// on, the refusals, and the running estimate against the mean of the normals given.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <random>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/slam/ground_up.hpp"

using namespace commerge;

namespace ground_up_test {

// A scene seen from the origin: ground 1.5 m below on the plane with unit normal `n`, walls 12 m away on two
// sides, a few posts; range noise of `noise_m` on every point.
std::vector<PointXYZI> Scene(const Eigen::Vector3d& n, double noise_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  std::vector<PointXYZI> out;
  auto add = [&](const Eigen::Vector3d& p) {
    out.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z() + noise(rng)), 1.0f});
  };
  const Eigen::Vector3d origin_on_ground = -1.5 * n;
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  for (double a = -20.0; a <= 20.0; a += 0.5) {
    for (double b = -20.0; b <= 20.0; b += 0.5) add(origin_on_ground + a * u + b * v);
  }
  for (double s = -12.0; s <= 12.0; s += 0.3) {
    for (double z = -1.4; z < 8.0; z += 0.3) {
      add(Eigen::Vector3d(12.0, s, z));
      add(Eigen::Vector3d(s, 12.0, z));
    }
  }
  for (double z = -1.4; z < 2.0; z += 0.1) add(Eigen::Vector3d(4.0, -3.0, z));
  return out;
}

Eigen::Vector3d Leaning(double deg_about_x, double deg_about_y) {
  return (Eigen::AngleAxisd(deg_about_x * kDegToRad, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(deg_about_y * kDegToRad, Eigen::Vector3d::UnitY()))
      .toRotationMatrix() *
      Eigen::Vector3d::UnitZ();
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) / kDegToRad;
}

}  // namespace ground_up_test

using namespace ground_up_test;

TEST_CASE("Ground up: the fitted ground normal is the plane's, for leans up to 15 deg, with walls and noise") {
  const GroundUpParams params;
  std::vector<float> scratch;
  for (double lean : {0.0, 3.0, 8.0, 15.0}) {
    for (std::uint32_t seed = 1; seed <= 3; ++seed) {
      const Eigen::Vector3d n = Leaning(lean * std::cos(seed), lean * std::sin(seed));
      Eigen::Vector3d fitted;
      REQUIRE(FitGroundNormal(Span<const PointXYZI>(Scene(n, 0.02, seed)), params, &scratch, &fitted));
      CHECK(AngleDeg(fitted, n) < 0.2);
      CHECK(fitted.z() > 0.0);
      CHECK(fitted.norm() == doctest::Approx(1.0));
    }
  }
}

TEST_CASE("Ground up: no ground (a wall alone), a ground leaning past max_lean_deg or too few points give no normal") {
  const GroundUpParams params;
  std::vector<float> scratch;
  Eigen::Vector3d fitted;
  std::vector<PointXYZI> wall;
  for (double s = -8.0; s <= 8.0; s += 0.2) {
    for (double z = -1.4; z < 6.0; z += 0.2) wall.push_back({8.0f, static_cast<float>(s), static_cast<float>(z), 1.0f});
  }
  // Its lowest points are a line: no plane.
  CHECK_FALSE(FitGroundNormal(Span<const PointXYZI>(wall), params, &scratch, &fitted));
  CHECK_FALSE(FitGroundNormal(Span<const PointXYZI>(Scene(Leaning(35.0, 0.0), 0.02, 1)), params, &scratch, &fitted));
  std::vector<PointXYZI> few(20, PointXYZI{3.0f, 0.0f, -1.5f, 1.0f});
  CHECK_FALSE(FitGroundNormal(Span<const PointXYZI>(few), params, &scratch, &fitted));
  CHECK_FALSE(FitGroundNormal(Span<const PointXYZI>(), params, &scratch, &fitted));
}

TEST_CASE("Ground up: the estimate is the normalised sum of the normals given, and the frame's z without any") {
  GroundUpEstimate e;
  CHECK(e.up() == Eigen::Vector3d::UnitZ());
  CHECK(e.tilt_deg() == 0.0);
  const Eigen::Vector3d a = Leaning(6.0, 0.0), b = Leaning(10.0, 0.0), c = Leaning(8.0, 2.0);
  e.Add(a);
  e.Add(b);
  e.Add(c);
  CHECK(e.count() == 3);
  CHECK(AngleDeg(e.up(), a + b + c) < 1e-9);
  CHECK(e.tilt_deg() == doctest::Approx(AngleDeg(a + b + c, Eigen::Vector3d::UnitZ())));
}

TEST_CASE("Ground up: parameters out of range are named") {
  GroundUpParams p;
  CHECK(ValidateGroundUpParams(p).ok());
  p.min_frame_tilt_deg = -1.0;
  CHECK(ValidateGroundUpParams(p).message().find("min_frame_tilt_deg") != std::string::npos);
  p = GroundUpParams{};
  p.max_range_m = 1.0;
  CHECK(ValidateGroundUpParams(p).message().find("max_range_m") != std::string::npos);
  p = GroundUpParams{};
  p.iterations = 0;
  CHECK(ValidateGroundUpParams(p).message().find("iterations") != std::string::npos);
  p = GroundUpParams{};
  p.max_flatness = 0.0;
  CHECK(ValidateGroundUpParams(p).message().find("max_flatness") != std::string::npos);
}
