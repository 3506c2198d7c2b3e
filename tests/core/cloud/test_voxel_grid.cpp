// SPDX-License-Identifier: BSD-3-Clause
// Voxel-grid downsampling against an independent brute-force reference (std::map keyed by voxel index).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "platform/io/kitti_bin.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace {

using VoxelKey = std::tuple<std::int64_t, std::int64_t, std::int64_t>;

struct Reference {
  std::vector<VoxelKey> keys;          // ascending (std::map order = lexicographic)
  std::vector<PointXYZI> centroids;    // one per key
  std::size_t dropped_nonfinite = 0;
};

VoxelKey KeyOf(const PointXYZI& p, double voxel_size_m) {
  return {static_cast<std::int64_t>(std::floor(static_cast<double>(p.x) / voxel_size_m)),
          static_cast<std::int64_t>(std::floor(static_cast<double>(p.y) / voxel_size_m)),
          static_cast<std::int64_t>(std::floor(static_cast<double>(p.z) / voxel_size_m))};
}

// Straightforward reference: sums per voxel in a std::map.
Reference BruteForce(const std::vector<PointXYZI>& in, double voxel_size_m) {
  struct Sums {
    double x = 0, y = 0, z = 0, intensity = 0;
    double n = 0;
  };
  std::map<VoxelKey, Sums> voxels;
  Reference ref;
  for (const PointXYZI& p : in) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      ++ref.dropped_nonfinite;
      continue;
    }
    Sums& s = voxels[KeyOf(p, voxel_size_m)];
    s.x += static_cast<double>(p.x);
    s.y += static_cast<double>(p.y);
    s.z += static_cast<double>(p.z);
    s.intensity += static_cast<double>(p.intensity);
    s.n += 1;
  }
  for (const auto& [key, s] : voxels) {
    ref.keys.push_back(key);
    ref.centroids.push_back({static_cast<float>(s.x / s.n), static_cast<float>(s.y / s.n),
                             static_cast<float>(s.z / s.n), static_cast<float>(s.intensity / s.n)});
  }
  return ref;
}

bool Near(float a, float b, double rel) {
  return std::fabs(static_cast<double>(a) - static_cast<double>(b)) <=
         rel * std::max(1.0, std::fabs(static_cast<double>(b)));
}

// Checks count, order (output point i lies inside the reference's i-th voxel) and centroids (1e-5
// relative). Uses `grid` when given, else the one-shot VoxelDownsample. Returns the output.
std::vector<PointXYZI> CheckAgainstReference(const std::vector<PointXYZI>& in, double voxel_size_m,
                                             VoxelGrid* grid = nullptr) {
  CAPTURE(voxel_size_m);
  CAPTURE(in.size());
  const Reference ref = BruteForce(in, voxel_size_m);
  std::vector<PointXYZI> out;
  const Result<VoxelGridStats> stats = grid ? grid->Downsample(in, VoxelGridParams{voxel_size_m}, &out)
                                            : VoxelDownsample(in, VoxelGridParams{voxel_size_m}, &out);
  REQUIRE_MESSAGE(stats.ok(), stats.status().ToString());
  CHECK(stats->num_input == in.size());
  CHECK(stats->dropped_nonfinite == ref.dropped_nonfinite);
  CHECK(stats->num_voxels == ref.keys.size());
  REQUIRE(out.size() == ref.keys.size());
  std::size_t bad = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const PointXYZI& a = out[i];
    const PointXYZI& b = ref.centroids[i];
    const bool ok = KeyOf(a, voxel_size_m) == ref.keys[i] && Near(a.x, b.x, 1e-5) && Near(a.y, b.y, 1e-5) &&
                    Near(a.z, b.z, 1e-5) && Near(a.intensity, b.intensity, 1e-5);
    if (!ok && bad++ < 5) {
      FAIL_CHECK("voxel " << i << ": got (" << a.x << ", " << a.y << ", " << a.z << ", " << a.intensity
                          << "), want (" << b.x << ", " << b.y << ", " << b.z << ", " << b.intensity << ")");
    }
  }
  CHECK(bad == 0);
  return out;
}

std::vector<PointXYZI> UniformBox(std::mt19937& rng, std::size_t n, float lo, float hi) {
  std::uniform_real_distribution<float> coord(lo, hi), intensity(0.0f, 1.0f);
  std::vector<PointXYZI> pts(n);
  for (PointXYZI& p : pts) p = {coord(rng), coord(rng), coord(rng), intensity(rng)};
  return pts;
}

std::vector<PointXYZI> Clustered(std::mt19937& rng, std::size_t n) {
  std::uniform_real_distribution<float> center(-30.0f, 30.0f), intensity(0.0f, 1.0f);
  std::normal_distribution<float> spread(0.0f, 0.3f);
  std::vector<PointXYZI> pts;
  while (pts.size() < n) {
    const float cx = center(rng), cy = center(rng), cz = center(rng);
    for (int k = 0; k < 100 && pts.size() < n; ++k) {
      pts.push_back({cx + spread(rng), cy + spread(rng), cz + spread(rng), intensity(rng)});
    }
  }
  return pts;
}

// Coordinates exactly on (float-rounded) voxel boundaries k * voxel_size_m, both signs.
std::vector<PointXYZI> OnBoundaries(std::mt19937& rng, std::size_t n, double voxel_size_m) {
  std::uniform_int_distribution<int> k(-300, 300);
  std::uniform_real_distribution<float> intensity(0.0f, 1.0f);
  std::vector<PointXYZI> pts(n);
  for (PointXYZI& p : pts) {
    p = {static_cast<float>(k(rng) * voxel_size_m), static_cast<float>(k(rng) * voxel_size_m),
         static_cast<float>(k(rng) * voxel_size_m), intensity(rng)};
  }
  pts.push_back({-0.0f, -0.0f, -0.0f, 0.5f});
  return pts;
}

TEST_CASE("voxel grid matches the brute-force reference on seeded random clouds") {
  for (const double voxel_size_m : {0.1, 0.5, 0.7, 1.0, 2.0}) {
    for (const std::uint32_t seed : {1u, 2u}) {
      std::mt19937 rng(seed);
      CheckAgainstReference(UniformBox(rng, 2000, 0.0f, 10.0f), voxel_size_m);    // many points per voxel at 1-2 m
      CheckAgainstReference(UniformBox(rng, 2000, -60.0f, 40.0f), voxel_size_m);  // sparse, mixed signs
      CheckAgainstReference(UniformBox(rng, 1000, -80.0f, -50.0f), voxel_size_m); // all negative
      CheckAgainstReference(Clustered(rng, 2000), voxel_size_m);
      CheckAgainstReference(OnBoundaries(rng, 1000, voxel_size_m), voxel_size_m);
    }
  }
}

TEST_CASE("voxel grid boundaries and order by hand") {
  // v = 1: x = -1 and -0.5 share voxel -1; -0 and 0.999 share voxel 0; 1.0 starts voxel 1.
  const std::vector<PointXYZI> in = {{1.0f, 0, 0, 1.0f},  {-0.5f, 0, 0, 0.0f}, {0.999f, 0, 0, 1.0f},
                                     {-1.0f, 0, 0, 1.0f}, {-0.0f, 0, 0, 0.0f}, {0.0f, 0, -0.25f, 0.0f},
                                     {0.0f, -3.0f, 5.0f, 0.0f}};
  std::vector<PointXYZI> out;
  const auto stats = VoxelDownsample(in, VoxelGridParams{1.0}, &out);
  REQUIRE(stats.ok());
  REQUIRE(out.size() == 5);
  // (ix, iy, iz) ascending: (-1,0,0), (0,-3,5), (0,0,-1), (0,0,0), (1,0,0).
  CHECK(out[0].x == doctest::Approx(-0.75));
  CHECK(out[0].intensity == doctest::Approx(0.5));
  CHECK(out[1].y == -3.0f);
  CHECK(out[2].z == -0.25f);
  CHECK(out[3].x == doctest::Approx(0.4995));
  CHECK(out[4].x == 1.0f);
}

TEST_CASE("voxel index is floor(c / v) in double, not c * (1 / v)") {
  // -175 / 0.7 = -250.00000000000003 in double (voxel -251), while -175 * (1 / 0.7) = -250 exactly.
  const std::vector<PointXYZI> in = {{-174.8f, 0, 0, 0}, {-175.0f, 0, 0, 0}};
  std::vector<PointXYZI> out;
  REQUIRE(VoxelDownsample(in, VoxelGridParams{0.7}, &out).ok());
  REQUIRE(out.size() == 2);
  CHECK(out[0].x == -175.0f);
  CHECK(out[1].x == -174.8f);
}

TEST_CASE("voxel grid skips and counts NaN and inf points") {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const std::vector<PointXYZI> in = {{kNaN, 0, 0, 0},     {0.2f, 0.2f, 0.2f, 1.0f}, {0, -kInf, 0, 0},
                                     {0, 0, kInf, 0},     {0.4f, 0.4f, 0.4f, 3.0f}, {1e30f, 0, kNaN, 0},
                                     {5.0f, 0, 0, kNaN}};  // NaN intensity is not a non-finite point
  std::vector<PointXYZI> out;
  const auto stats = VoxelDownsample(in, VoxelGridParams{1.0}, &out);
  REQUIRE(stats.ok());
  CHECK(stats->num_input == 7);
  CHECK(stats->dropped_nonfinite == 4);
  CHECK(stats->num_voxels == 2);
  REQUIRE(out.size() == 2);
  CHECK(out[0].x == doctest::Approx(0.3));
  CHECK(out[0].intensity == doctest::Approx(2.0));
  CHECK(out[1].x == 5.0f);

  const std::vector<PointXYZI> all_bad = {{kNaN, kNaN, kNaN, 0}, {kInf, 0, 0, 0}};
  const auto none = VoxelDownsample(all_bad, VoxelGridParams{1.0}, &out);
  REQUIRE(none.ok());
  CHECK(none->dropped_nonfinite == 2);
  CHECK(out.empty());
}

TEST_CASE("voxel grid: empty input, single point, one voxel") {
  std::vector<PointXYZI> out = {{1, 2, 3, 4}};  // stale content must be cleared
  const auto empty = VoxelDownsample(Span<const PointXYZI>(), VoxelGridParams{}, &out);
  REQUIRE(empty.ok());
  CHECK(empty->num_input == 0);
  CHECK(empty->num_voxels == 0);
  CHECK(out.empty());

  const std::vector<PointXYZI> single = {{-12.34f, 56.78f, -0.01f, 0.42f}};
  REQUIRE(VoxelDownsample(single, VoxelGridParams{0.5}, &out).ok());
  REQUIRE(out.size() == 1);
  CHECK(std::memcmp(&out[0], &single[0], sizeof(PointXYZI)) == 0);

  std::vector<PointXYZI> one_voxel;
  double sx = 0, sy = 0, sz = 0, si = 0;
  for (int i = 0; i < 100; ++i) {
    const PointXYZI p{10.0f + 0.009f * i, -3.0f + 0.005f * i, 2.0f + 0.001f * i, 0.01f * i};
    one_voxel.push_back(p);
    sx += static_cast<double>(p.x), sy += static_cast<double>(p.y), sz += static_cast<double>(p.z);
    si += static_cast<double>(p.intensity);
  }
  const auto stats = VoxelDownsample(one_voxel, VoxelGridParams{1.0}, &out);
  REQUIRE(stats.ok());
  CHECK(stats->num_voxels == 1);
  REQUIRE(out.size() == 1);
  CHECK(out[0].x == static_cast<float>(sx / 100));
  CHECK(out[0].y == static_cast<float>(sy / 100));
  CHECK(out[0].z == static_cast<float>(sz / 100));
  CHECK(out[0].intensity == static_cast<float>(si / 100));
}

TEST_CASE("voxel grid rejects an invalid voxel size and a null output") {
  const std::vector<PointXYZI> in = {{1, 2, 3, 0}};
  for (const double bad : {0.0, -1.0, -0.0, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    CAPTURE(bad);
    std::vector<PointXYZI> out = {{1, 2, 3, 4}};
    const auto r = VoxelDownsample(in, VoxelGridParams{bad}, &out);
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kInvalidArgument);
    CHECK(r.status().message().find("voxel_size_m") != std::string::npos);
    CHECK(out.empty());
  }
  const auto r = VoxelDownsample(in, VoxelGridParams{1.0}, nullptr);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("voxel grid reports an extent too large for the key instead of wrapping") {
  std::vector<PointXYZI> out;
  // 2^21 voxels per axis fit (indices 0 .. 2097151); one more does not. Checked on every axis.
  for (int axis = 0; axis < 3; ++axis) {
    CAPTURE(axis);
    auto make = [axis](float far) {
      std::vector<PointXYZI> pts(2);
      (axis == 0 ? pts[1].x : axis == 1 ? pts[1].y : pts[1].z) = far;
      return pts;
    };
    const auto fits = VoxelDownsample(make(2097151.5f), VoxelGridParams{1.0}, &out);
    REQUIRE(fits.ok());
    CHECK(out.size() == 2);
    const auto too_wide = VoxelDownsample(make(2097152.0f), VoxelGridParams{1.0}, &out);
    REQUIRE_FALSE(too_wide.ok());
    CHECK(too_wide.status().code() == StatusCode::kInvalidArgument);
    CHECK(too_wide.status().message().find("voxel_size_m = 1") != std::string::npos);
    CHECK(too_wide.status().message().find("2097153 voxels") != std::string::npos);
    CHECK(out.empty());
  }
  // A tiny voxel size over an ordinary cloud, and a quotient that overflows double, are errors too.
  const std::vector<PointXYZI> scan = {{-50, 0, 0, 0}, {50, 0, 0, 0}};
  CHECK(VoxelDownsample(scan, VoxelGridParams{1e-5}, &out).status().code() == StatusCode::kInvalidArgument);
  CHECK(VoxelDownsample(scan, VoxelGridParams{1e-310}, &out).status().code() == StatusCode::kInvalidArgument);
  const std::vector<PointXYZI> huge = {{3e38f, 0, 0, 0}, {3e38f, 1, 0, 0}};
  CHECK(VoxelDownsample(huge, VoxelGridParams{1e-3}, &out).status().code() == StatusCode::kInvalidArgument);
}

// Shuffling changes the order in which each voxel's points are summed (in double). The voxel set and
// order must be identical; centroids must agree to 1e-6 relative in general, and bitwise when every
// double sum is exact (coordinates on a 1/64 m grid, as asserted in the second half).
TEST_CASE("voxel grid output does not depend on the input order") {
  std::mt19937 rng(7);
  std::vector<PointXYZI> in = Clustered(rng, 3000);
  const std::vector<PointXYZI> uniform = UniformBox(rng, 2000, -40.0f, 40.0f);
  in.insert(in.end(), uniform.begin(), uniform.end());
  std::vector<PointXYZI> a, b;
  REQUIRE(VoxelDownsample(in, VoxelGridParams{0.5}, &a).ok());
  std::shuffle(in.begin(), in.end(), rng);
  REQUIRE(VoxelDownsample(in, VoxelGridParams{0.5}, &b).ok());
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    REQUIRE(KeyOf(a[i], 0.5) == KeyOf(b[i], 0.5));
    REQUIRE(Near(a[i].x, b[i].x, 1e-6));
    REQUIRE(Near(a[i].y, b[i].y, 1e-6));
    REQUIRE(Near(a[i].z, b[i].z, 1e-6));
    REQUIRE(Near(a[i].intensity, b[i].intensity, 1e-6));
  }

  for (PointXYZI& p : in) {
    p.x = std::round(p.x * 64.0f) / 64.0f, p.y = std::round(p.y * 64.0f) / 64.0f;
    p.z = std::round(p.z * 64.0f) / 64.0f, p.intensity = std::round(p.intensity * 64.0f) / 64.0f;
  }
  REQUIRE(VoxelDownsample(in, VoxelGridParams{0.5}, &a).ok());
  std::shuffle(in.begin(), in.end(), rng);
  REQUIRE(VoxelDownsample(in, VoxelGridParams{0.5}, &b).ok());
  REQUIRE(a.size() == b.size());
  CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(PointXYZI)) == 0);
}

TEST_CASE("voxel grid steady state: a second same-size call does not grow the workspace") {
  constexpr std::size_t kN = 5000;
  std::mt19937 rng(11);
  const std::vector<PointXYZI> first = UniformBox(rng, kN, -30.0f, 30.0f);
  const std::vector<PointXYZI> second = UniformBox(rng, kN, -10.0f, 50.0f);

  VoxelGrid reserved(kN);
  const std::size_t initial = reserved.workspace_capacity_bytes();
  CHECK(initial >= 2 * kN * 12);  // two (key, index) buffers of at least 12 bytes per point
  std::vector<PointXYZI> out;
  out.reserve(kN);
  const PointXYZI* out_data = out.data();
  REQUIRE(reserved.Downsample(first, VoxelGridParams{1.0}, &out).ok());
  CHECK(reserved.workspace_capacity_bytes() == initial);
  REQUIRE(reserved.Downsample(second, VoxelGridParams{1.0}, &out).ok());
  CHECK(reserved.workspace_capacity_bytes() == initial);
  CHECK(out.data() == out_data);  // the caller's buffer was reused, not reallocated

  VoxelGrid grown;  // no reservation: the first call sizes the workspace, the second reuses it
  CHECK(grown.workspace_capacity_bytes() == 0);
  REQUIRE(grown.Downsample(first, VoxelGridParams{1.0}, &out).ok());
  const std::size_t after_first = grown.workspace_capacity_bytes();
  CHECK(after_first >= 2 * kN * 12);
  REQUIRE(grown.Downsample(second, VoxelGridParams{1.0}, &out).ok());
  CHECK(grown.workspace_capacity_bytes() == after_first);
  CHECK(out.data() == out_data);
}

TEST_CASE("voxel grid on KITTI scans matches the reference and stays inside its voxels") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/kitti00_frames0-15/velodyne");
  VoxelGrid grid;  // reused across scans
  for (const char* name : {"000000.bin", "000007.bin"}) {
    CAPTURE(name);
    const auto scan = platform::ReadKittiBin(dir + "/" + name);
    REQUIRE_MESSAGE(scan.ok(), scan.status().ToString());
    const std::vector<PointXYZI>& in = scan->points;
    REQUIRE(in.size() > 100000);
    // Also checks that every output point lies inside its (reference) voxel.
    const std::vector<PointXYZI> out = CheckAgainstReference(in, 1.0, &grid);
    MESSAGE(std::string(name) << ": " << in.size() << " points -> " << out.size() << " voxels at 1.0 m");
    CHECK(out.size() > 1000);
    CHECK(out.size() * 10 < in.size());
    for (std::size_t i = 1; i < out.size(); ++i) REQUIRE(KeyOf(out[i - 1], 1.0) < KeyOf(out[i], 1.0));
  }
}

// ---- DownsampleAdaptive (the scene-scaled voxel size) ----

// A flat square of side_m, one point every 0.05 m, at z = 0.5: at voxel v it occupies ceil(side_m / v)^2 voxels
// whenever side_m / v is not an integer (and exactly (side_m / v)^2 otherwise).
std::vector<PointXYZI> DensePlane(float side_m) {
  std::vector<PointXYZI> pts;
  const int n = static_cast<int>(std::lround(side_m / 0.05f));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) pts.push_back({0.025f + 0.05f * static_cast<float>(i), 0.025f + 0.05f * static_cast<float>(j), 0.5f, 1.0f});
  }
  return pts;
}

// The rule of AdaptiveVoxelParams restated on the brute-force reference: the ladder v0 / sqrt(2)^k, the first
// size that reaches min_points, no step above max_points or with less than 10 % more points.
double ReferenceAdaptiveSize(const std::vector<PointXYZI>& in, const AdaptiveVoxelParams& p) {
  double size = p.voxel_size_m;
  std::size_t count = BruteForce(in, size).keys.size();
  for (int k = 1; count < p.min_points; ++k) {
    const double v = p.voxel_size_m / std::pow(std::sqrt(2.0), k);
    if (v < p.min_voxel_size_m * (1.0 - 1e-9)) break;
    const std::size_t finer = BruteForce(in, v).keys.size();
    if (finer > p.max_points || static_cast<double>(finer) < 1.1 * static_cast<double>(count)) break;
    size = v;
    count = finer;
  }
  return size;
}

TEST_CASE("adaptive voxel: a 10 m plane goes finer until it has the points asked, by hand") {
  const std::vector<PointXYZI> plane = DensePlane(10.0f);  // 40 000 points
  VoxelGrid grid;
  std::vector<PointXYZI> out, scratch;
  struct Case {
    std::size_t min_points, max_points;
    double want_size_m;
    std::size_t want_points;
  };
  // 1 m: 10 x 10; 0.707 m: 15 x 15; 0.5 m: 20 x 20; 0.354 m: 29 x 29; 0.25 m: 40 x 40.
  for (const Case& c : {Case{0, 1000000, 1.0, 100}, Case{100, 1000000, 1.0, 100}, Case{101, 1000000, std::sqrt(0.5), 225},
                        Case{300, 1000000, 0.5, 400}, Case{1000000, 1000000, 0.25, 1600},
                        Case{1000, 500, 0.5, 400}}) {
    CAPTURE(c.min_points);
    CAPTURE(c.max_points);
    AdaptiveVoxelParams p;
    p.min_points = c.min_points;
    p.max_points = c.max_points;
    const auto stats = DownsampleAdaptive(&grid, plane, p, &out, &scratch);
    REQUIRE_MESSAGE(stats.ok(), stats.status().ToString());
    CHECK(stats->voxel_size_m == doctest::Approx(c.want_size_m));
    CHECK(out.size() == c.want_points);
    CHECK(stats->grid.num_voxels == c.want_points);
    CHECK(stats->voxel_size_m == doctest::Approx(ReferenceAdaptiveSize(plane, p)));
  }
}

TEST_CASE("adaptive voxel: a cloud no denser than the grid stays at the coarse size") {
  // 200 points 2 m apart: every size of the ladder gives 200 voxels, so no step gains 10 %.
  std::vector<PointXYZI> sparse;
  for (int i = 0; i < 200; ++i) sparse.push_back({2.0f * static_cast<float>(i % 20) + 0.3f, 2.0f * static_cast<float>(i / 20) + 0.3f, 0.3f, 0.0f});
  VoxelGrid grid;
  std::vector<PointXYZI> out, scratch;
  AdaptiveVoxelParams p;
  p.min_points = 1000;
  const auto stats = DownsampleAdaptive(&grid, sparse, p, &out, &scratch);
  REQUIRE(stats.ok());
  CHECK(stats->voxel_size_m == 1.0);
  CHECK(stats->finer_steps == 0);
  CHECK(out.size() == 200);
}

TEST_CASE("adaptive voxel matches the rule on the brute-force reference for random clouds, and its points") {
  std::mt19937 rng(17);
  VoxelGrid grid;
  std::vector<PointXYZI> out, scratch;
  for (int trial = 0; trial < 12; ++trial) {
    CAPTURE(trial);
    const float extent = 2.0f + 3.0f * static_cast<float>(trial);
    const std::vector<PointXYZI> in =
        trial % 2 == 0 ? UniformBox(rng, 3000, -extent, extent) : Clustered(rng, 3000);
    AdaptiveVoxelParams p;
    p.voxel_size_m = trial % 3 == 0 ? 2.0 : 1.0;
    p.min_voxel_size_m = trial % 3 == 0 ? 0.3 : 0.25;
    p.min_points = static_cast<std::size_t>(200 + 150 * trial);
    p.max_points = trial % 4 == 1 ? 1500 : 100000;
    const auto stats = DownsampleAdaptive(&grid, in, p, &out, &scratch);
    REQUIRE_MESSAGE(stats.ok(), stats.status().ToString());
    const double want = ReferenceAdaptiveSize(in, p);
    CHECK(stats->voxel_size_m == doctest::Approx(want));
    // The points returned are the plain grid at the chosen size.
    const Reference ref = BruteForce(in, want);
    REQUIRE(out.size() == ref.keys.size());
    for (std::size_t i = 0; i < out.size(); ++i) REQUIRE(KeyOf(out[i], want) == ref.keys[i]);
  }
}

TEST_CASE("adaptive voxel: invalid sizes and null buffers are errors naming the field") {
  VoxelGrid grid;
  std::vector<PointXYZI> out, scratch;
  const std::vector<PointXYZI> in = DensePlane(2.0f);
  AdaptiveVoxelParams p;
  p.min_voxel_size_m = 2.0;  // above voxel_size_m
  auto bad = DownsampleAdaptive(&grid, in, p, &out, &scratch);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("min_voxel_size_m") != std::string::npos);
  p = AdaptiveVoxelParams{};
  p.voxel_size_m = std::numeric_limits<double>::quiet_NaN();
  bad = DownsampleAdaptive(&grid, in, p, &out, &scratch);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("voxel_size_m") != std::string::npos);
  CHECK_FALSE(DownsampleAdaptive(&grid, in, AdaptiveVoxelParams{}, &out, nullptr).ok());
}

TEST_CASE("adaptive voxel on real scans: a KITTI street scan stays at 1 m, a Livox courtyard scan goes finer") {
  CM_SHARED_DATA_OR_SKIP(kitti, "kitti/kitti00_frames0-15/velodyne");
  CM_SHARED_DATA_OR_SKIP(hku2, "real/hku2/velodyne");
  VoxelGrid grid;
  std::vector<PointXYZI> out, scratch;
  AdaptiveVoxelParams p;
  p.min_points = 1000;  // the robots' default (--min-scan-points)
  const auto street = platform::ReadKittiBin(kitti + "/000000.bin");
  REQUIRE(street.ok());
  auto stats = DownsampleAdaptive(&grid, street->points, p, &out, &scratch);
  REQUIRE(stats.ok());
  MESSAGE("KITTI 00 scan 0: " << out.size() << " points at " << stats->voxel_size_m << " m");
  CHECK(stats->voxel_size_m == 1.0);
  CHECK(out.size() >= 1000);
  const auto courtyard = platform::ReadKittiBin(hku2 + "/000100.bin");
  REQUIRE(courtyard.ok());
  const std::size_t at_1m = BruteForce(courtyard->points, 1.0).keys.size();
  stats = DownsampleAdaptive(&grid, courtyard->points, p, &out, &scratch);
  REQUIRE(stats.ok());
  MESSAGE("hku2 scan 100: " << at_1m << " points at 1 m, " << out.size() << " at " << stats->voxel_size_m << " m");
  CHECK(at_1m < 1000);
  CHECK(stats->voxel_size_m < 1.0);
  CHECK(stats->voxel_size_m == doctest::Approx(ReferenceAdaptiveSize(courtyard->points, p)));
  CHECK(out.size() > at_1m);
}

}  // namespace
}  // namespace commerge
