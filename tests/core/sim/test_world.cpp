// SPDX-License-Identifier: BSD-3-Clause
// The simulator's ray caster (core/sim/world.hpp) against analytic distances (planes, boxes, cylinders,
// spheres, a tunnel), against a brute-force reference written here independently of the grid traversal,
// and against the existing BoxScene caster.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/sim/lidar_models.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/sim/world.hpp"

namespace commerge {
namespace {

struct Ray {
  float o[3];
  float d[3];
};

Ray MakeRay(double ox, double oy, double oz, double dx, double dy, double dz) {
  const double n = std::sqrt(dx * dx + dy * dy + dz * dz);
  return {{static_cast<float>(ox), static_cast<float>(oy), static_cast<float>(oz)},
          {static_cast<float>(dx / n), static_cast<float>(dy / n), static_cast<float>(dz / n)}};
}

/// Range of the nearest hit, or +inf.
double Cast(const World& w, const Ray& r, float max_range = 500.0f, RayHit* out = nullptr) {
  RayWorkspace ws;
  RayHit hit;
  if (!w.CastRay(r.o, r.d, 0.0f, max_range, &ws, &hit)) return std::numeric_limits<double>::infinity();
  if (out) *out = hit;
  return static_cast<double>(hit.range_m);
}

TEST_CASE("sim world: ground and ceiling planes at the analytic distance h / sin(elevation)") {
  World w;
  w.set_ground_z_m(0.0f);
  w.set_ceiling_z_m(3.0f);
  REQUIRE(w.Build().ok());
  for (double elev_deg : {-30.0, -10.0, -2.0, 5.0, 45.0, 89.0}) {
    const double e = elev_deg * kPi / 180.0;
    const Ray r = MakeRay(2.0, -1.0, 1.2, std::cos(e) * std::cos(0.3), std::cos(e) * std::sin(0.3), std::sin(e));
    const double expected = e < 0 ? 1.2 / std::sin(-e) : (3.0 - 1.2) / std::sin(e);
    RayHit hit;
    CHECK(Cast(w, r, 500.0f, &hit) == doctest::Approx(expected).epsilon(1e-5));
    CHECK(static_cast<double>(hit.cos_incidence) == doctest::Approx(std::fabs(std::sin(e))).epsilon(1e-5));
  }
  // Horizontal ray under a ceiling: nothing within range.
  CHECK(std::isinf(Cast(w, MakeRay(0, 0, 1, 1, 0, 0), 100.0f)));
}

TEST_CASE("sim world: oriented box faces at the analytic distance, also rotated by 30 deg") {
  World w;
  w.set_ground_z_m(-100.0f);
  const double yaw = 30.0 * kPi / 180.0;
  OrientedBox b;
  b.cx_m = static_cast<float>(10.0 * std::cos(yaw));
  b.cy_m = static_cast<float>(10.0 * std::sin(yaw));
  b.half_x_m = 1.0f;
  b.half_y_m = 2.5f;
  b.z_min_m = -1.0f;
  b.z_max_m = 4.0f;
  b.yaw_rad = static_cast<float>(yaw);
  w.AddBox(b);
  REQUIRE(w.Build(4.0f).ok());
  // Along the box's own x axis: the near face is 10 - half_x away, hit head-on.
  RayHit hit;
  CHECK(Cast(w, MakeRay(0, 0, 1, std::cos(yaw), std::sin(yaw), 0), 500.0f, &hit) == doctest::Approx(9.0).epsilon(1e-5));
  CHECK(static_cast<double>(hit.cos_incidence) == doctest::Approx(1.0).epsilon(1e-5));
  // Tilted by psi inside the face: the face plane is 9 m away along its normal -> 9 / cos(psi).
  for (double psi_deg : {-8.0, 5.0, 12.0}) {
    const double psi = psi_deg * kPi / 180.0;
    CHECK(Cast(w, MakeRay(0, 0, 1, std::cos(yaw + psi), std::sin(yaw + psi), 0)) ==
          doctest::Approx(9.0 / std::cos(psi)).epsilon(1e-5));
  }
  // Over the top (z = 4) from above: a ray going down onto the roof.
  const Ray down = MakeRay(static_cast<double>(b.cx_m), static_cast<double>(b.cy_m), 10, 0, 0, -1);
  CHECK(Cast(w, down) == doctest::Approx(6.0).epsilon(1e-5));
  // Misses: above the roof, and beside it.
  CHECK(std::isinf(Cast(w, MakeRay(0, 0, 5, std::cos(yaw), std::sin(yaw), 0))));
  CHECK(std::isinf(Cast(w, MakeRay(0, 0, 1, std::cos(yaw + 0.5), std::sin(yaw + 0.5), 0))));
}

TEST_CASE("sim world: vertical cylinder and sphere at the analytic chord distances") {
  World w;
  w.set_ground_z_m(-100.0f);
  VerticalCylinder c;
  c.cx_m = 8.0f;
  c.cy_m = 0.0f;
  c.radius_m = 0.5f;
  c.z_min_m = 0.0f;
  c.z_max_m = 6.0f;
  w.AddCylinder(c);
  Sphere s;
  s.cx_m = 0.0f;
  s.cy_m = 20.0f;
  s.cz_m = 3.0f;
  s.radius_m = 2.0f;
  w.AddSphere(s);
  REQUIRE(w.Build().ok());
  // Cylinder: t = d cos(theta) - sqrt(r^2 - d^2 sin^2(theta)) for a horizontal ray at angle theta.
  for (double theta : {0.0, 0.03, -0.05}) {
    const double expected = 8.0 * std::cos(theta) - std::sqrt(0.25 - 64.0 * std::sin(theta) * std::sin(theta));
    CHECK(Cast(w, MakeRay(0, 0, 1, std::cos(theta), std::sin(theta), 0)) == doctest::Approx(expected).epsilon(1e-5));
  }
  CHECK(std::isinf(Cast(w, MakeRay(0, 0, 7, 1, 0, 0))));  // above the pole
  // Sphere: the ray from (0, 0, 3) towards (0, 20, 3) offset by angle a: t = D cos a - sqrt(r^2 - D^2 sin^2 a).
  for (double a : {0.0, 0.05, 0.09}) {
    const double expected = 20.0 * std::cos(a) - std::sqrt(4.0 - 400.0 * std::sin(a) * std::sin(a));
    CHECK(Cast(w, MakeRay(0, 0, 3, std::sin(a), std::cos(a), 0)) == doctest::Approx(expected).epsilon(1e-5));
  }
}

/// Independent reference: every primitive tested, no grid.
double AsDouble(float v) { return static_cast<double>(v); }

double BruteForce(const World& w, const Ray& r, double max_range) {
  double best = max_range;
  const double o[3] = {AsDouble(r.o[0]), AsDouble(r.o[1]), AsDouble(r.o[2])}, d[3] = {AsDouble(r.d[0]), AsDouble(r.d[1]), AsDouble(r.d[2])};
  if (d[2] < 0) best = std::min(best, (AsDouble(w.ground_z_m()) - o[2]) / d[2]);
  for (const OrientedBox& b : w.boxes()) {
    const double c = std::cos(AsDouble(b.yaw_rad)), s = std::sin(AsDouble(b.yaw_rad));
    const double lo[3] = {c * (o[0] - AsDouble(b.cx_m)) + s * (o[1] - AsDouble(b.cy_m)), -s * (o[0] - AsDouble(b.cx_m)) + c * (o[1] - AsDouble(b.cy_m)), o[2]};
    const double ld[3] = {c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]};
    const double mn[3] = {-AsDouble(b.half_x_m), -AsDouble(b.half_y_m), AsDouble(b.z_min_m)}, mx[3] = {AsDouble(b.half_x_m), AsDouble(b.half_y_m), AsDouble(b.z_max_m)};
    double t0 = -1e30, t1 = 1e30;
    for (int a = 0; a < 3; ++a) {
      if (std::fabs(ld[a]) < 1e-15) {
        if (lo[a] < mn[a] || lo[a] > mx[a]) t0 = 1e30;
        continue;
      }
      const double u = (mn[a] - lo[a]) / ld[a], v = (mx[a] - lo[a]) / ld[a];
      t0 = std::max(t0, std::min(u, v));
      t1 = std::min(t1, std::max(u, v));
    }
    if (t0 <= t1 && t0 > 1e-3) best = std::min(best, t0);
  }
  for (const VerticalCylinder& cy : w.cylinders()) {
    const double px = o[0] - AsDouble(cy.cx_m), py = o[1] - AsDouble(cy.cy_m);
    const double a = d[0] * d[0] + d[1] * d[1], bq = px * d[0] + py * d[1];
    const double cq = px * px + py * py - AsDouble(cy.radius_m) * AsDouble(cy.radius_m);
    if (a > 1e-15 && bq * bq - a * cq >= 0) {
      const double t = (-bq - std::sqrt(bq * bq - a * cq)) / a;
      const double z = o[2] + t * d[2];
      if (t > 1e-3 && z >= AsDouble(cy.z_min_m) && z <= AsDouble(cy.z_max_m)) best = std::min(best, t);
    }
    if (std::fabs(d[2]) > 1e-15) {
      const double t = ((d[2] < 0 ? AsDouble(cy.z_max_m) : AsDouble(cy.z_min_m)) - o[2]) / d[2];
      const double qx = px + t * d[0], qy = py + t * d[1];
      if (t > 1e-3 && qx * qx + qy * qy <= AsDouble(cy.radius_m) * AsDouble(cy.radius_m)) best = std::min(best, t);
    }
  }
  for (const Sphere& s : w.spheres()) {
    const double px = o[0] - AsDouble(s.cx_m), py = o[1] - AsDouble(s.cy_m), pz = o[2] - AsDouble(s.cz_m);
    const double bq = px * d[0] + py * d[1] + pz * d[2];
    const double disc = bq * bq - (px * px + py * py + pz * pz - AsDouble(s.radius_m) * AsDouble(s.radius_m));
    if (disc >= 0) {
      const double t = -bq - std::sqrt(disc);
      if (t > 1e-3) best = std::min(best, t);
    }
  }
  return best < max_range ? best : std::numeric_limits<double>::infinity();
}

TEST_CASE("sim world: the grid traversal finds exactly the brute-force nearest hit (2000 random rays)") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  World w;
  for (int i = 0; i < 150; ++i) {
    OrientedBox b;
    b.cx_m = static_cast<float>(200 * u(rng) - 100);
    b.cy_m = static_cast<float>(200 * u(rng) - 100);
    b.half_x_m = static_cast<float>(0.5 + 12 * u(rng));
    b.half_y_m = static_cast<float>(0.5 + 6 * u(rng));
    b.z_max_m = static_cast<float>(1 + 30 * u(rng));
    b.yaw_rad = static_cast<float>(2 * kPi * u(rng));
    w.AddBox(b);
    VerticalCylinder c;
    c.cx_m = static_cast<float>(200 * u(rng) - 100);
    c.cy_m = static_cast<float>(200 * u(rng) - 100);
    c.radius_m = static_cast<float>(0.1 + 1.5 * u(rng));
    c.z_min_m = static_cast<float>(2 * u(rng));
    c.z_max_m = c.z_min_m + static_cast<float>(1 + 8 * u(rng));
    w.AddCylinder(c);
    Sphere s;
    s.cx_m = static_cast<float>(200 * u(rng) - 100);
    s.cy_m = static_cast<float>(200 * u(rng) - 100);
    s.cz_m = static_cast<float>(1 + 8 * u(rng));
    s.radius_m = static_cast<float>(0.3 + 3 * u(rng));
    w.AddSphere(s);
  }
  REQUIRE(w.Build(8.0f).ok());
  RayWorkspace ws;  // one workspace for all rays: the mailbox must not leak between rays
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const double az = 2 * kPi * u(rng), el = (u(rng) - 0.6) * 1.2;
    // Origins inside and outside the grid's rectangle.
    const Ray r = MakeRay(260 * u(rng) - 130, 260 * u(rng) - 130, 0.2 + 5 * u(rng), std::cos(el) * std::cos(az),
                          std::cos(el) * std::sin(az), std::sin(el));
    RayHit hit;
    const bool found = w.CastRay(r.o, r.d, 0.0f, 150.0f, &ws, &hit);
    const double ref = BruteForce(w, r, 150.0);
    REQUIRE(found == std::isfinite(ref));
    if (found) {
      ++hits;
      REQUIRE(static_cast<double>(hit.range_m) == doctest::Approx(ref).epsilon(1e-4));
    }
  }
  CHECK(hits > 1000);
}

TEST_CASE("sim world: tunnel wall at the capsule radius, and on the noisy wall's zero level") {
  World w;
  TunnelSegment seg;
  seg.ax_m = -50.0f;
  seg.bx_m = 50.0f;
  seg.az_m = seg.bz_m = 1.2f;
  seg.radius_m = 3.0f;
  w.AddTunnelSegment(seg);
  REQUIRE(w.Build().ok());
  // From the axis sideways and upwards: the wall at 3 m (within the surface tolerance of 1 cm).
  CHECK(Cast(w, MakeRay(0, 0, 1.2, 0, 1, 0)) == doctest::Approx(3.0).epsilon(0.005));
  CHECK(Cast(w, MakeRay(0, 0, 1.2, 0, std::cos(0.7), std::sin(0.7))) == doctest::Approx(3.0).epsilon(0.005));
  // Down: the floor plane first (1.2 m), inside the capsule.
  CHECK(Cast(w, MakeRay(0, 0, 1.2, 0, 0, -1)) == doctest::Approx(1.2).epsilon(1e-5));
  // Along the axis: the round end cap, 50 + 3 m away.
  CHECK(Cast(w, MakeRay(0, 0, 1.2, 1, 0, 0)) == doctest::Approx(53.0).epsilon(0.001));
  const float inside[3] = {0, 0, 1.2f}, rock[3] = {0, 4, 1.2f};
  CHECK(w.TunnelSignedDistance(inside) == doctest::Approx(-3.0));
  CHECK(w.TunnelSignedDistance(rock) > 0.0f);

  World noisy;
  noisy.AddTunnelSegment(seg);
  TunnelWallNoise noise;
  noise.amplitude_m = 0.6f;
  noise.wavelength_m = 4.0f;
  noise.seed = 9;
  noisy.set_tunnel_noise(noise);
  REQUIRE(noisy.Build().ok());
  double min_r = 1e9, max_r = 0;
  for (int k = 0; k < 72; ++k) {
    const double a = 2 * kPi * k / 72.0;
    const Ray r = MakeRay(0, 0, 1.2, 0.2, std::cos(a), std::sin(a));
    const double t = Cast(noisy, r);
    REQUIRE(std::isfinite(t));
    const float p[3] = {r.o[0] + static_cast<float>(t) * r.d[0], r.o[1] + static_cast<float>(t) * r.d[1],
                        r.o[2] + static_cast<float>(t) * r.d[2]};
    if (p[2] > 0.01f) CHECK(std::fabs(noisy.TunnelSignedDistance(p)) < 0.03f);  // on the wall's zero level
    const double radial = std::hypot(static_cast<double>(p[1]), static_cast<double>(p[2]) - 1.2);
    if (p[2] > 0.01f) {
      min_r = std::min(min_r, radial);
      max_r = std::max(max_r, radial);
    }
  }
  CHECK(min_r > 3.0 - 0.6 - 0.03);
  CHECK(max_r < 3.0 + 0.6 + 0.03);
  CHECK(max_r - min_r > 0.2);  // the wall is irregular
}

TEST_CASE("sim world: a BoxScene cast through World gives the same points as CastScan") {
  const BoxScene scene = MakeStreetScene(4, 120.0f);
  World w = WorldFromBoxScene(scene);
  REQUIRE(w.Build().ok());
  SpinningLidar old_lidar;
  old_lidar.beams = 16;
  old_lidar.azimuth_steps = 120;
  old_lidar.min_elevation_deg = -15.0f;
  old_lidar.max_elevation_deg = 15.0f;
  old_lidar.max_range_m = 80.0f;
  old_lidar.range_noise_std_m = 0.0f;
  std::vector<PointXYZI> expected;
  CastScan(scene, old_lidar, 3.0f, -1.0f, 1.73f, 0.4f, 1, &expected);

  LidarModel model = MakeLidarModel(LidarKind::kVlp16);  // -15..15 deg in 2 deg steps = the same 16 beams
  model.azimuth_steps = 120;
  model.min_range_m = 0.0f;
  model.max_range_m = 80.0f;
  model.range_noise_std_m = 0.0f;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(3.0, -1.0, 1.73);
  LidarScanWorkspace ws;
  std::vector<PointXYZI> got;
  REQUIRE(SimulateLidarScan(w, model, T, 1, 0, &ws, &got).ok());
  REQUIRE(expected.size() > 1000);
  CHECK(std::abs(static_cast<long>(got.size()) - static_cast<long>(expected.size())) <= 2);
  std::size_t matched = 0;
  for (const PointXYZI& p : got) {
    double best = 1e9;
    for (const PointXYZI& q : expected) best = std::min(best, static_cast<double>(std::hypot(p.x - q.x, p.y - q.y, p.z - q.z)));
    matched += best < 0.01;
  }
  CHECK(matched >= got.size() - 2);
}

TEST_CASE("sim world: Build names a degenerate primitive") {
  World w;
  OrientedBox b;
  b.half_x_m = 0.0f;
  w.AddBox(b);
  const Status st = w.Build();
  CHECK(st.code() == StatusCode::kInvalidArgument);
  CHECK(st.message().find("box 0") != std::string::npos);
  World v;
  CHECK(v.Build(0.1f).code() == StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace commerge
