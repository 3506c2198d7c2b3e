// SPDX-License-Identifier: BSD-3-Clause
// Submap preprocessing (core/registration/submap_features): pair features against hand-derived values,
// neighbour lists against a brute-force search, normals and their orientation towards the nearest sensor
// origin, regularised covariances, and descriptor invariance under rigid motion.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/registration/feature_matching.hpp"
#include "core/registration/submap_features.hpp"

namespace commerge {
namespace {

std::vector<PointXYZI> RandomCloud(std::uint32_t seed, int n, float extent_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-extent_m, extent_m);
  std::vector<PointXYZI> pts(static_cast<std::size_t>(n));
  for (PointXYZI& p : pts) p = PointXYZI{u(rng), u(rng), u(rng), 0.0f};
  return pts;
}

// A box-corner scene: ground z = 0 and two walls x = 0 and y = 0, sampled on a jittered 1 m grid.
std::vector<PointXYZI> CornerScene(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> j(-0.05f, 0.05f);
  std::vector<PointXYZI> pts;
  for (int a = 0; a < 16; ++a) {
    for (int b = 0; b < 16; ++b) {
      pts.push_back({0.5f + static_cast<float>(a) + j(rng), 0.5f + static_cast<float>(b) + j(rng), 0.0f, 0.0f});
      if (b < 8) {
        pts.push_back({0.0f, 0.5f + static_cast<float>(a) + j(rng), 0.5f + static_cast<float>(b) + j(rng), 0.0f});
        pts.push_back({0.5f + static_cast<float>(a) + j(rng), 0.0f, 0.5f + static_cast<float>(b) + j(rng), 0.0f});
      }
    }
  }
  // A 3 m cube on the ground (top and two sides) so that descriptors vary. No poles: a line has no defined
  // normal direction around it, so its descriptors would legitimately change under rotation.
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      pts.push_back({9.5f + static_cast<float>(a) + j(rng), 9.5f + static_cast<float>(b) + j(rng), 3.0f, 0.0f});
      pts.push_back({9.0f, 9.5f + static_cast<float>(a) + j(rng), 0.5f + static_cast<float>(b) + j(rng), 0.0f});
      pts.push_back({9.5f + static_cast<float>(a) + j(rng), 9.0f, 0.5f + static_cast<float>(b) + j(rng), 0.0f});
    }
  }
  return pts;
}

}  // namespace

TEST_CASE("Pair feature: hand-derived angles, the swap rule and undefined cases") {
  PairFeature f;
  // Coplanar points with parallel normals: every angle is 0 (the flat-plane descriptor's middle bins).
  REQUIRE(ComputePairFeature({0, 0, 0}, {0, 0, 1}, {1, 2, 0}, {0, 0, 1}, &f));
  CHECK(f.f1 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(f.f2 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(f.f3 == doctest::Approx(0.0).epsilon(1e-6));
  // n1 = z, n2 = (x + z)/sqrt2, d = x: |n2.d| > |n1.d| so point 2 is the source. By hand: u = n2, d' = -x,
  // v = d' x u = y, w = u x v = (-1, 0, 1)/sqrt2; f1 = atan2(w.n1, u.n1) = pi/4, f2 = v.n1 = 0, f3 = -n2.d.
  const float s = std::sqrt(0.5f);
  REQUIRE(ComputePairFeature({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {s, 0, s}, &f));
  CHECK(f.f1 == doctest::Approx(kPi / 4).epsilon(1e-4));
  CHECK(f.f2 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(f.f3 == doctest::Approx(-static_cast<double>(s)).epsilon(1e-6));
  // Swapping the two points gives the same feature (the source is chosen by angle, not by order).
  PairFeature g;
  REQUIRE(ComputePairFeature({1, 0, 0}, {s, 0, s}, {0, 0, 0}, {0, 0, 1}, &g));
  CHECK(g.f1 == doctest::Approx(static_cast<double>(f.f1)).epsilon(1e-5));
  CHECK(g.f2 == doctest::Approx(static_cast<double>(f.f2)).epsilon(1e-5));
  CHECK(g.f3 == doctest::Approx(static_cast<double>(f.f3)).epsilon(1e-5));
  // Coincident points, and a connecting line parallel to the source normal, are undefined.
  CHECK_FALSE(ComputePairFeature({1, 1, 1}, {0, 0, 1}, {1, 1, 1}, {0, 0, 1}, &f));
  CHECK_FALSE(ComputePairFeature({0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}, &f));
  // n2 = (x - z)/sqrt2: by hand u = n2, v = -y, w = (-1, 0, -1)/sqrt2, f1 = atan2(-s, -s) = -3pi/4, f3 = -s.
  REQUIRE(ComputePairFeature({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {s, 0, -s}, &f));
  CHECK(f.f1 == doctest::Approx(-3.0 * kPi / 4).epsilon(1e-4));
  CHECK(f.f2 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(f.f3 == doctest::Approx(-static_cast<double>(s)).epsilon(1e-6));
}

TEST_CASE("Neighbour lists equal a brute-force search capped at the closest max_neighbors") {
  const std::vector<PointXYZI> pts = RandomCloud(7, 400, 6.0f);
  SubmapFeatureParams p;
  p.normal_radius_m = 1.5;
  p.fpfh_radius_m = 2.5;
  p.max_neighbors = 24;
  SubmapFeatures f;
  f.ComputeGeometry(pts, {}, p);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    std::vector<std::pair<double, std::uint32_t>> ref;
    for (std::size_t j = 0; j < pts.size(); ++j) {
      const Eigen::Vector3d d = Eigen::Vector3f(pts[i].x, pts[i].y, pts[i].z).cast<double>() -
                                Eigen::Vector3f(pts[j].x, pts[j].y, pts[j].z).cast<double>();
      const double dx = d.x(), dy = d.y(), dz = d.z();
      const double d2 = dx * dx + dy * dy + dz * dz;
      if (d2 <= p.fpfh_radius_m * p.fpfh_radius_m) ref.emplace_back(d2, static_cast<std::uint32_t>(j));
    }
    std::sort(ref.begin(), ref.end());
    if (ref.size() > 24) ref.resize(24);
    const Span<const std::uint32_t> got = f.neighbor_indices(i);
    const Span<const float> got_d2 = f.neighbor_distances_sq(i);
    REQUIRE(got.size() == ref.size());
    for (std::size_t k = 0; k < ref.size(); ++k) {
      CHECK(got[k] == ref[k].second);
      CHECK(static_cast<double>(got_d2[k]) == doctest::Approx(ref[k].first).epsilon(1e-4));
    }
  }
}

TEST_CASE("Normals: plane normals, oriented towards the nearest of several sensor origins") {
  // Plane z = 0.2 x (tilted), 1 m grid; origin A above the plane at x < 0, origin B below it at x > 0.
  std::vector<PointXYZI> pts;
  for (int a = -10; a <= 10; ++a)
    for (int b = -10; b <= 10; ++b) pts.push_back({static_cast<float>(a), static_cast<float>(b), 0.2f * static_cast<float>(a), 0.0f});
  const Eigen::Vector3d plane_normal = Eigen::Vector3d(-0.2, 0.0, 1.0).normalized();
  const std::vector<Eigen::Vector3d> origins = {{-10.0, 0.0, 6.0}, {10.0, 0.0, -6.0}};
  SubmapFeatures f;
  f.ComputeGeometry(pts, origins, SubmapFeatureParams{});
  CHECK(f.stats().num_valid_normals == pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3d n = f.normals()[i].cast<double>();
    CHECK(std::fabs(n.dot(plane_normal)) > 0.9999);
    const Eigen::Vector3d p = Eigen::Vector3f(pts[i].x, pts[i].y, pts[i].z).cast<double>();
    const Eigen::Vector3d& nearest = (origins[0] - p).norm() <= (origins[1] - p).norm() ? origins[0] : origins[1];
    // Brute-force orientation reference: towards the nearest origin (evaluated at the point; the plane is flat,
    // so the neighbourhood mean lies on the same side).
    CHECK(n.dot(nearest - p) > 0.0);
  }
  // GICP covariances of a plane: eigenvalues (1e-3, 1, 1), smallest direction = the plane normal.
  for (std::size_t i = 0; i < pts.size(); i += 37) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(f.covariances()[i]);
    CHECK(eig.eigenvalues()(0) == doctest::Approx(1e-3).epsilon(1e-6));
    CHECK(eig.eigenvalues()(1) == doctest::Approx(1.0).epsilon(1e-9));
    CHECK(eig.eigenvalues()(2) == doctest::Approx(1.0).epsilon(1e-9));
    CHECK(std::fabs(eig.eigenvectors().col(0).dot(plane_normal)) > 0.9999);
  }
}

TEST_CASE("Normals: too few neighbours or coincident points give no normal and no keypoint") {
  std::vector<PointXYZI> pts = {{0, 0, 0, 0}, {10, 0, 0, 0}, {20, 0, 0, 0}, {5, 5, 5, 0}, {5, 5, 5, 0}, {5, 5, 5, 0}};
  SubmapFeatures f;
  f.ComputeGeometry(pts, {}, SubmapFeatureParams{});
  f.ComputeDescriptors(SubmapFeatureParams{});
  CHECK(f.stats().num_valid_normals == 0);  // isolated points; three identical points have no spread
  CHECK(f.keypoints().empty());
  CHECK(f.descriptors().empty());
}

TEST_CASE("Descriptors: blocks sum to 100, invariant to a rigid motion of points and sensor origins") {
  const std::vector<PointXYZI> pts = CornerScene(3);
  const std::vector<Eigen::Vector3d> origins = {{6.0, 6.0, 1.7}};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())).toRotationMatrix();
  T.translation() = Eigen::Vector3d(13.0, -7.0, 2.5);
  std::vector<PointXYZI> moved;
  for (const PointXYZI& p : pts) {
    const Eigen::Vector3d q = T * Eigen::Vector3f(p.x, p.y, p.z).cast<double>();
    moved.push_back({static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), 0.0f});
  }
  const std::vector<Eigen::Vector3d> moved_origins = {T * origins[0]};
  SubmapFeatureParams p;
  SubmapFeatures a, b;
  a.ComputeGeometry(pts, origins, p);
  a.ComputeDescriptors(p);
  b.ComputeGeometry(moved, moved_origins, p);
  b.ComputeDescriptors(p);
  REQUIRE(a.keypoints().size() > 100);
  REQUIRE(a.keypoints() == b.keypoints());
  std::size_t num_different = 0;
  for (std::size_t k = 0; k < a.keypoints().size(); ++k) {
    double max_diff = 0.0;
    for (int block = 0; block < 3; ++block) {
      double sum = 0.0;
      for (int bin = 0; bin < kFpfhBins; ++bin) sum += static_cast<double>(a.descriptors()[k * kFpfhDims + static_cast<std::size_t>(block * kFpfhBins + bin)]);
      CHECK(sum == doctest::Approx(100.0).epsilon(1e-4));
    }
    for (int d = 0; d < kFpfhDims; ++d) {
      const std::size_t i = k * kFpfhDims + static_cast<std::size_t>(d);
      max_diff = std::max(max_diff, static_cast<double>(std::fabs(a.descriptors()[i] - b.descriptors()[i])));
    }
    num_different += max_diff > 0.05;
  }
  // Float rounding of the moved coordinates can move a pair feature across a bin edge or a neighbour across the
  // radius: a few descriptors may differ, the rest are equal.
  MESSAGE("descriptors that differ after the rigid motion: " << num_different << " of " << a.keypoints().size());
  CHECK(num_different * 50 <= a.keypoints().size());
}

namespace {

// Reference descriptors from the public pieces, one pair at a time: ComputePairFeature for each (keypoint,
// valid-normal neighbour) pair, the bin rule floor((f - lo) / (hi - lo) * 11) clamped to [0, 10], SPFH
// increments 100 / (number of valid-normal neighbours), FPFH = own SPFH + sum of the keypoint neighbours' SPFH
// weighted by 1 / d^2 (1 at d = 0), each block rescaled to sum 100. Returns how many descriptors differ from
// `f` by more than 0.01 in any bin, and the largest difference of any bin in *worst_bin.
std::size_t CountDescriptorsUnlikeReference(const std::vector<PointXYZI>& pts, const SubmapFeatures& f,
                                            double* worst_bin) {
  const auto bin = [](float v, float lo, float hi) {
    const int b = static_cast<int>(std::floor((v - lo) / (hi - lo) * static_cast<float>(kFpfhBins)));
    return static_cast<std::size_t>(std::min(std::max(b, 0), kFpfhBins - 1));
  };
  const auto pos = [&pts](std::uint32_t i) { return Eigen::Vector3f(pts[i].x, pts[i].y, pts[i].z); };
  const float pi = static_cast<float>(kPi);
  const std::size_t nk = f.keypoints().size();
  std::vector<std::int64_t> keypoint_of(pts.size(), -1);
  for (std::size_t k = 0; k < nk; ++k) keypoint_of[f.keypoints()[k]] = static_cast<std::int64_t>(k);
  std::vector<double> spfh(nk * kFpfhDims, 0.0);
  for (std::size_t k = 0; k < nk; ++k) {
    const std::uint32_t i = f.keypoints()[k];
    std::vector<std::uint32_t> valid;
    for (std::uint32_t j : f.neighbor_indices(i)) {
      if (j != i && f.normal_valid()[j]) valid.push_back(j);
    }
    for (std::uint32_t j : valid) {
      PairFeature pf;
      if (!ComputePairFeature(pos(i), f.normals()[i], pos(j), f.normals()[j], &pf)) continue;
      const double inc = 100.0 / static_cast<double>(valid.size());
      spfh[k * kFpfhDims + bin(pf.f1, -pi, pi)] += inc;
      spfh[k * kFpfhDims + kFpfhBins + bin(pf.f2, -1.0f, 1.0f)] += inc;
      spfh[k * kFpfhDims + 2 * kFpfhBins + bin(pf.f3, -1.0f, 1.0f)] += inc;
    }
  }
  std::size_t unlike = 0;
  *worst_bin = 0.0;
  for (std::size_t k = 0; k < nk; ++k) {
    const std::uint32_t i = f.keypoints()[k];
    std::vector<double> acc(spfh.begin() + static_cast<std::ptrdiff_t>(k * kFpfhDims),
                            spfh.begin() + static_cast<std::ptrdiff_t>((k + 1) * kFpfhDims));
    const Span<const std::uint32_t> nb = f.neighbor_indices(i);
    for (std::size_t m = 0; m < nb.size(); ++m) {
      if (keypoint_of[nb[m]] < 0) continue;
      const double d2 = static_cast<double>(f.neighbor_distances_sq(i)[m]);
      const double w = d2 > 0.0 ? 1.0 / d2 : 1.0;
      for (int b = 0; b < kFpfhDims; ++b) {
        acc[static_cast<std::size_t>(b)] += w * spfh[static_cast<std::size_t>(keypoint_of[nb[m]]) * kFpfhDims + static_cast<std::size_t>(b)];
      }
    }
    double worst = 0.0;
    for (int block = 0; block < 3; ++block) {
      double sum = 0.0;
      for (int b = 0; b < kFpfhBins; ++b) sum += acc[static_cast<std::size_t>(block * kFpfhBins + b)];
      for (int b = 0; b < kFpfhBins; ++b) {
        const auto d = static_cast<std::size_t>(block * kFpfhBins + b);
        const double expected = sum > 0.0 ? acc[d] * 100.0 / sum : 0.0;
        worst = std::max(worst, std::fabs(expected - static_cast<double>(f.descriptors()[k * kFpfhDims + d])));
      }
    }
    unlike += worst > 0.01;
    *worst_bin = std::max(*worst_bin, worst);
  }
  return unlike;
}

}  // namespace

TEST_CASE("Descriptors equal a pair-by-pair reference built from ComputePairFeature and the spec's formulas") {
  // A scene of planes and a box, and a random cloud (normals in every direction, so every bin is used).
  const std::vector<PointXYZI> corner = CornerScene(9);
  const std::vector<PointXYZI> random = RandomCloud(21, 700, 6.0f);
  for (const std::vector<PointXYZI>* pts : {&corner, &random}) {
    SubmapFeatureParams p;
    p.normal_radius_m = 2.5;
    p.fpfh_radius_m = 3.5;
    p.max_neighbors = 37;  // not a multiple of the kernel's vector width
    SubmapFeatures f;
    f.ComputeGeometry(*pts, std::vector<Eigen::Vector3d>{{6.0, 6.0, 1.7}}, p);
    f.ComputeDescriptors(p);
    REQUIRE(f.keypoints().size() > 200);
    std::vector<int> used(kFpfhDims, 0);
    for (std::size_t d = 0; d < f.descriptors().size(); ++d) used[d % kFpfhDims] |= f.descriptors()[d] > 0.0f;
    if (pts == &random) CHECK(std::count(used.begin(), used.end(), 1) == kFpfhDims);
    // None differs on x86-64 or aarch64 (qemu): the kernel repeats ComputePairFeature's operations. Until
    // ComputePairFeature wrote its dot products out, Eigen summed them in another order on aarch64; that moved
    // one ill-conditioned pair (f3 = -0.9999991, f2 divides by a tiny s) into the next bin and 29 of 700
    // descriptors by up to 0.6. The margin below is for a compiler that fuses multiply-adds differently in
    // vector and scalar code; a wrong kernel changes most descriptors, or some by whole units.
    double worst_bin = 0.0;
    const std::size_t unlike = CountDescriptorsUnlikeReference(*pts, f, &worst_bin);
    MESSAGE("descriptors unlike the reference: " << unlike << " of " << f.keypoints().size()
                                                 << ", largest bin difference " << worst_bin);
    CHECK(unlike * 100 <= f.keypoints().size());
    CHECK(worst_bin <= 1.0);
  }
}

TEST_CASE("Descriptors: every point of an exact plane carries the flat-plane descriptor") {
  std::vector<PointXYZI> pts;
  for (int a = 0; a < 20; ++a)
    for (int b = 0; b < 20; ++b) pts.push_back({static_cast<float>(a), static_cast<float>(b), 0.0f, 0.0f});
  const std::vector<Eigen::Vector3d> origin = {{10.0, 10.0, 2.0}};  // above the plane: one normal orientation
  SubmapFeatures f;
  f.ComputeGeometry(pts, origin, SubmapFeatureParams{});
  f.ComputeDescriptors(SubmapFeatureParams{});
  REQUIRE(f.keypoints().size() == pts.size());
  for (std::size_t k = 0; k < f.keypoints().size(); ++k) {
    CHECK(FlatDescriptorDistanceSq(f.descriptors().data() + k * kFpfhDims) < 1e-6f);
  }
}

}  // namespace commerge

namespace commerge {

TEST_CASE("Descriptor neighbours equal brute force: 2-NN per query, reverse 1-NN per row, ties to the lower index") {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 40; ++trial) {
    const std::size_t nq = rng() % 70, nd = rng() % 90;
    // Coarse integer values make exact distance ties frequent.
    const int levels = trial % 2 == 0 ? 3 : 1000;
    std::uniform_int_distribution<int> v(0, levels - 1);
    std::vector<float> q(nq * kFpfhDims), d(nd * kFpfhDims);
    for (float& x : q) x = static_cast<float>(v(rng));
    for (float& x : d) x = static_cast<float>(v(rng));
    const auto dist = [&](std::size_t a, std::size_t b) {
      float s = 0.0f;
      for (int k = 0; k < kFpfhDims; ++k) {
        const float e = q[a * kFpfhDims + static_cast<std::size_t>(k)] - d[b * kFpfhDims + static_cast<std::size_t>(k)];
        s += e * e;
      }
      return s;
    };
    DescriptorNeighbors got;
    std::vector<float> scratch;
    FindDescriptorNeighbors(q.data(), nq, d.data(), nd, &scratch, &got);
    REQUIRE(got.nearest.size() == nq);
    REQUIRE(got.reverse_nearest.size() == nd);
    CAPTURE(trial);
    for (std::size_t a = 0; a < nq; ++a) {
      std::vector<std::pair<float, std::uint32_t>> ref;
      for (std::size_t b = 0; b < nd; ++b) ref.emplace_back(dist(a, b), static_cast<std::uint32_t>(b));
      std::sort(ref.begin(), ref.end());
      if (nd == 0) {
        CHECK(got.nearest[a] == UINT32_MAX);
        continue;
      }
      CHECK(got.nearest[a] == ref[0].second);
      CHECK(got.d1_sq[a] == ref[0].first);
      if (nd > 1) {
        CHECK(got.d2_sq[a] == ref[1].first);
      } else {
        CHECK(std::isinf(got.d2_sq[a]));
      }
    }
    for (std::size_t b = 0; b < nd; ++b) {
      std::vector<std::pair<float, std::uint32_t>> ref;
      for (std::size_t a = 0; a < nq; ++a) ref.emplace_back(dist(a, b), static_cast<std::uint32_t>(a));
      std::sort(ref.begin(), ref.end());
      CHECK(got.reverse_nearest[b] == (nq == 0 ? UINT32_MAX : ref[0].second));
    }
  }
}

}  // namespace commerge
