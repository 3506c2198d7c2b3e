// SPDX-License-Identifier: BSD-3-Clause
// The ring-occupancy descriptor against a scene built cell by cell, so the expected vector is known by
// construction: flat ground (never counted), a half ring of low wall, a full ring of tall wall. Then the
// invariances it is built for (yaw by whole sectors, sensor height, point density), invalid input, and the
// parameter checks and id.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "core/descriptor/ring_occupancy.hpp"
#include "core/geometry/angles.hpp"
#include "tests/core/descriptor/descriptor_test_util.hpp"

namespace commerge {
namespace {

constexpr double kSensorHeightM = 1.7;

// A point at horizontal range r, the centre of sector s of 60, height h above the ground.
PointXYZI At(double r, int sector, double h, double z_ground) {
  const double theta = (sector + 0.5) * 2.0 * kPi / 60.0;
  return {static_cast<float>(r * std::cos(theta)), static_cast<float>(r * std::sin(theta)),
          static_cast<float>(z_ground + h), 1.0f};
}

// Ground on rings 0..7 everywhere; ring 1 (5..10 m), band 2 (2..4 m above ground) occupied in sectors 0..29;
// ring 5 (25..30 m), band 0 (0.3..1 m) in all 60 sectors. `copies` points per occupied cell.
std::vector<PointXYZI> Scene(double z_ground, int copies) {
  std::vector<PointXYZI> cloud;
  for (int s = 0; s < 60; ++s) {
    for (double r = 2.5; r < 40.0; r += 2.5) cloud.push_back(At(r, s, 0.0, z_ground));
  }
  for (int c = 0; c < copies; ++c) {
    for (int s = 0; s < 30; ++s) cloud.push_back(At(7.0 + 0.1 * c, s, 3.0, z_ground));
    for (int s = 0; s < 60; ++s) cloud.push_back(At(27.0, s, 0.5 + 0.05 * c, z_ground));
  }
  return cloud;
}

std::vector<float> Compute(RingOccupancyDescriptor& d, const std::vector<PointXYZI>& cloud, DescriptorInfo* info) {
  std::vector<float> out(d.dimension());
  auto r = d.Compute(Span<const PointXYZI>(cloud), Span<float>(out));
  REQUIRE(r.ok());
  *info = *r;
  return out;
}

TEST_CASE("Ring occupancy: the vector of a scene built cell by cell") {
  RingOccupancyDescriptor d;
  REQUIRE(d.dimension() == 40);
  DescriptorInfo info;
  const std::vector<float> v = Compute(d, Scene(-kSensorHeightM, 1), &info);
  REQUIRE(info.valid);
  CHECK(d.last_ground_z_m() == doctest::Approx(-kSensorHeightM).epsilon(1e-6));
  // Expected: 0.5 at [ring 1][band 2], 1.0 at [ring 5][band 0], normalised by sqrt(0.25 + 1).
  const double norm = std::sqrt(0.25 + 1.0);
  for (int ring = 0; ring < 8; ++ring) {
    for (int band = 0; band < 5; ++band) {
      double want = 0.0;
      if (ring == 1 && band == 2) want = 0.5 / norm;
      if (ring == 5 && band == 0) want = 1.0 / norm;
      CAPTURE(ring);
      CAPTURE(band);
      CHECK(v[static_cast<std::size_t>(ring * 5 + band)] == doctest::Approx(want).epsilon(1e-6));
    }
  }
  CHECK(info.num_below_min_z == 60 * 15);  // every ground point
  CHECK(info.num_counted == 90);
}

TEST_CASE("Ring occupancy: the same vector after a yaw by whole sectors, at another sensor height and density") {
  RingOccupancyDescriptor d;
  DescriptorInfo info;
  const std::vector<float> base = Compute(d, Scene(-kSensorHeightM, 1), &info);
  auto same = [&](const std::vector<PointXYZI>& cloud) {
    DescriptorInfo i;
    const std::vector<float> v = Compute(d, cloud, &i);
    REQUIRE(i.valid);
    for (std::size_t k = 0; k < v.size(); ++k) {
      CHECK(v[k] == doctest::Approx(static_cast<double>(base[k])).epsilon(1e-6));
    }
    CHECK(d.Distance(Span<const float>(v), Span<const float>(base)) < 1e-6);
  };
  same(YawedCopy(Scene(-kSensorHeightM, 1), 90.0 * kDegToRad));
  same(YawedCopy(Scene(-kSensorHeightM, 1), -36.0 * kDegToRad));
  same(Scene(-0.4, 1));   // a sensor mounted 0.4 m above the ground
  same(Scene(-2.5, 1));   // ... or 2.5 m
  same(Scene(-kSensorHeightM, 5));  // five times the points in every occupied cell
}

TEST_CASE("Ring occupancy: distance grows with the change of the scene") {
  RingOccupancyDescriptor d;
  DescriptorInfo info;
  const std::vector<float> base = Compute(d, Scene(-kSensorHeightM, 1), &info);
  std::vector<PointXYZI> more = Scene(-kSensorHeightM, 1);
  for (int s = 0; s < 30; ++s) more.push_back(At(17.0, s, 6.0, -kSensorHeightM));  // ring 3, band 4, half
  std::vector<PointXYZI> much_more = more;
  for (int s = 0; s < 60; ++s) much_more.push_back(At(37.0, s, 1.5, -kSensorHeightM));  // ring 7, band 1, full
  const std::vector<float> a = Compute(d, more, &info);
  const std::vector<float> b = Compute(d, much_more, &info);
  const double d1 = d.Distance(Span<const float>(base), Span<const float>(a));
  const double d2 = d.Distance(Span<const float>(base), Span<const float>(b));
  // Independent reference: the normalised vectors written out.
  const double n0 = std::sqrt(1.25), n1 = std::sqrt(1.5);
  const double ref1 = std::sqrt(std::pow(0.5 / n0 - 0.5 / n1, 2) + std::pow(1.0 / n0 - 1.0 / n1, 2) + std::pow(0.5 / n1, 2));
  CHECK(d1 == doctest::Approx(ref1).epsilon(1e-5));
  CHECK(d2 > d1);
  CHECK(d2 <= std::sqrt(2.0) + 1e-9);
}

TEST_CASE("Ring occupancy: empty, non-finite and structureless clouds are invalid, wrong sizes are errors") {
  RingOccupancyDescriptor d;
  std::vector<float> out(d.dimension(), 7.0f);
  auto empty = d.Compute(Span<const PointXYZI>(), Span<float>(out));
  REQUIRE(empty.ok());
  CHECK_FALSE(empty->valid);
  for (float v : out) CHECK(v == 0.0f);

  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<PointXYZI> cloud = Scene(-kSensorHeightM, 1);
  cloud.push_back({nan, 1.0f, 1.0f, 1.0f});
  cloud.push_back({1.0f, std::numeric_limits<float>::infinity(), 1.0f, 1.0f});
  auto with_nan = d.Compute(Span<const PointXYZI>(cloud), Span<float>(out));
  REQUIRE(with_nan.ok());
  CHECK(with_nan->valid);
  CHECK(with_nan->num_nonfinite == 2);

  std::vector<PointXYZI> ground_only;
  for (int s = 0; s < 60; ++s) ground_only.push_back(At(5.0, s, 0.0, -kSensorHeightM));
  auto flat = d.Compute(Span<const PointXYZI>(ground_only), Span<float>(out));
  REQUIRE(flat.ok());
  CHECK_FALSE(flat->valid);

  std::vector<float> short_out(d.dimension() - 1);
  CHECK_FALSE(d.Compute(Span<const PointXYZI>(cloud), Span<float>(short_out)).ok());
}

TEST_CASE("Ring occupancy: parameter checks name the field, the id follows every field") {
  RingOccupancyParams p;
  CHECK(ValidateRingOccupancyParams(p).ok());
  auto bad = [](RingOccupancyParams q, const char* field) {
    const Status s = ValidateRingOccupancyParams(q);
    CHECK_FALSE(s.ok());
    CHECK(s.message().find(field) != std::string::npos);
    CHECK_FALSE(RingOccupancyDescriptor::Create(q).ok());
  };
  RingOccupancyParams q = p;
  q.num_rings = 0;
  bad(q, "num_rings");
  q = p;
  q.num_bands = kRingOccupancyMaxBands + 1;
  bad(q, "num_bands");
  q = p;
  q.num_sectors = 3;
  bad(q, "num_sectors");
  q = p;
  q.max_range_m = std::numeric_limits<double>::quiet_NaN();
  bad(q, "max_range_m");
  q = p;
  q.band_edges_m[2] = q.band_edges_m[1];
  bad(q, "band_edges_m");
  q = p;
  q.ground_percentile = 101.0;
  bad(q, "ground_percentile");

  const std::uint32_t id = RingOccupancyParameterId(p);
  CHECK(RingOccupancyDescriptor().parameter_id() == id);
  q = p;
  q.num_sectors = 72;
  CHECK(RingOccupancyParameterId(q) != id);
  q = p;
  q.band_edges_m[4] = 9.0;
  CHECK(RingOccupancyParameterId(q) != id);
  q = p;
  q.band_edges_m[6] = 99.0;  // beyond num_bands: unused, the id stays
  CHECK(RingOccupancyParameterId(q) == id);
}

}  // namespace
}  // namespace commerge
