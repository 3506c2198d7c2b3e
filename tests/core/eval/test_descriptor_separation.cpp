// SPDX-License-Identifier: BSD-3-Clause
// Descriptor separation against ground truth (core/eval/descriptor_separation.hpp): quantiles of a hand-made
// vector, and two robots of three keyframes each whose true pairs (within 3 m), false pairs (20 m or more) and
// skipped pairs are known, with 2-d unit descriptors at known angles (distance 2 sin(angle / 2)); invalid
// keyframes, keyframes without ground truth, the heading limit of a forward-looking sensor and the subsampled
// false pairs of a costly metric.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/eval/descriptor_separation.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

using namespace commerge;

namespace {

Eigen::Isometry3d SeparationPose(double x, double yaw_deg = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw_deg * kDegToRad, 0.0, 0.0);
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

// Unit 2-d descriptors at the given angles [deg], row-major.
std::vector<float> UnitDescriptors(const std::vector<double>& angles_deg) {
  std::vector<float> out;
  for (double a : angles_deg) {
    out.push_back(static_cast<float>(std::cos(a * kDegToRad)));
    out.push_back(static_cast<float>(std::sin(a * kDegToRad)));
  }
  return out;
}

DescriptorSetView SeparationSet(const std::vector<float>& values, const std::vector<std::uint8_t>& valid = {}) {
  DescriptorSetView set;
  set.values = Span<const float>(values);
  set.dim = 2;
  set.valid = Span<const std::uint8_t>(valid);
  return set;
}

// Alpha at x = 0, 10, 50 with descriptors at 0, 90, 180 deg; beta at x = 1, 12, 80 with 60, 90, 0 deg.
// Pairs (alpha, beta): (0,0) 1 m true, distance 1; (1,1) 2 m true, 0; (0,1) 12 m and (1,0) 9 m skipped;
// false (0,2) 0, (1,2) sqrt 2, (2,0) sqrt 3, (2,1) sqrt 2, (2,2) 2.
struct SeparationScene {
  std::vector<Eigen::Isometry3d> alpha_gt = {SeparationPose(0), SeparationPose(10), SeparationPose(50)};
  std::vector<Eigen::Isometry3d> beta_gt = {SeparationPose(1), SeparationPose(12), SeparationPose(80)};
  std::vector<float> alpha = UnitDescriptors({0, 90, 180});
  std::vector<float> beta = UnitDescriptors({60, 90, 0});
};

DistanceQuantiles SeparateScene(const SeparationScene& s, const std::vector<std::uint8_t>& beta_valid = {},
                           const DescriptorMetric& metric = {}, const DescriptorSeparationParams& params = {}) {
  return DescriptorSeparation(SeparationSet(s.alpha), Span<const Eigen::Isometry3d>(s.alpha_gt),
                              SeparationSet(s.beta, beta_valid), Span<const Eigen::Isometry3d>(s.beta_gt), metric,
                              params);
}

}  // namespace

TEST_CASE("Descriptor separation: a quantile is the element of rank floor(q n), the last for q = 1, -1 when empty") {
  std::vector<float> v = {5, 1, 4, 2, 3};
  CHECK(QuantileInPlace(Span<float>(v), 0.0) == 1.0);
  CHECK(QuantileInPlace(Span<float>(v), 0.19) == 1.0);  // floor(0.95) = 0
  CHECK(QuantileInPlace(Span<float>(v), 0.2) == 2.0);   // floor(1.0) = 1
  CHECK(QuantileInPlace(Span<float>(v), 0.5) == 3.0);
  CHECK(QuantileInPlace(Span<float>(v), 0.95) == 5.0);
  CHECK(QuantileInPlace(Span<float>(v), 1.0) == 5.0);  // rank 5 clamped to the last
  std::vector<float> even = {4, 1, 3, 2};
  CHECK(QuantileInPlace(Span<float>(even), 0.5) == 3.0);  // the upper middle
  CHECK(QuantileInPlace({}, 0.5) == -1.0);
}

TEST_CASE("Descriptor separation: true pairs within 3 m, false pairs 20 m or more apart, the rest skipped") {
  const SeparationScene s;
  const DistanceQuantiles q = SeparateScene(s);
  CHECK(q.true_pairs == 2);
  CHECK(q.false_pairs == 5);
  // True {0, 1}: p05 rank 0, p50 and p95 rank 1.
  CHECK(q.true_p05 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(q.true_p50 == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(q.true_p95 == doctest::Approx(1.0).epsilon(1e-6));
  // False {0, sqrt 2, sqrt 2, sqrt 3, 2}: p01 and p05 rank 0, p50 rank 2.
  CHECK(q.false_p01 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(q.false_p05 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(q.false_p50 == doctest::Approx(std::sqrt(2.0)).epsilon(1e-6));
  // Exactly 3 m is a true pair, exactly 20 m a false one; 3.5 and 19.9 m are neither.
  SeparationScene edges;
  edges.alpha_gt = {SeparationPose(0)};
  edges.alpha = UnitDescriptors({0});
  edges.beta_gt = {SeparationPose(3), SeparationPose(20), SeparationPose(3.5), SeparationPose(19.9)};
  edges.beta = UnitDescriptors({0, 0, 0, 0});
  const DistanceQuantiles e = SeparateScene(edges);
  CHECK(e.true_pairs == 1);
  CHECK(e.false_pairs == 1);
  // Other limits: within 10 m is true, 40 m or more false: (1,0) 9 m joins the true pairs (90 - 60 = 30 deg
  // apart: distance 2 sin 15 deg), (2,1) 38 m and (2,2) 30 m leave the false ones.
  DescriptorSeparationParams wide;
  wide.true_pair_max_m = 10.0;
  wide.false_pair_min_m = 40.0;
  const DistanceQuantiles w = SeparateScene(s, {}, {}, wide);
  CHECK(w.true_pairs == 3);
  CHECK(w.false_pairs == 3);
  CHECK(w.true_p50 == doctest::Approx(2 * std::sin(15 * kDegToRad)).epsilon(1e-6));  // {0, 0.518, 1}
}

TEST_CASE("Descriptor separation: invalid keyframes and keyframes without ground truth are left out") {
  const SeparationScene s;
  // Beta keyframe 1 invalid: true {1}, false {0, sqrt 2, sqrt 3, 2}.
  const DistanceQuantiles q = SeparateScene(s, {1, 0, 1});
  CHECK(q.true_pairs == 1);
  CHECK(q.false_pairs == 4);
  CHECK(q.true_p50 == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(q.false_p50 == doctest::Approx(std::sqrt(3.0)).epsilon(1e-6));
  // Alpha keyframe 2 without ground truth: false {0, sqrt 2}.
  SeparationScene short_gt;
  short_gt.alpha_gt.pop_back();
  const DistanceQuantiles g = SeparateScene(short_gt);
  CHECK(g.true_pairs == 2);
  CHECK(g.false_pairs == 2);
  CHECK(g.false_p50 == doctest::Approx(std::sqrt(2.0)).epsilon(1e-6));
  // Nothing at all: every quantile -1.
  const DistanceQuantiles none = SeparateScene(s, {0, 0, 0});
  CHECK(none.true_pairs == 0);
  CHECK(none.false_pairs == 0);
  CHECK(none.true_p05 == -1.0);
  CHECK(none.false_p50 == -1.0);
}

TEST_CASE("Descriptor separation: a forward-looking sensor's true pairs need headings within its field of view") {
  SeparationScene s;
  s.beta_gt = {SeparationPose(1, 90), SeparationPose(12, 60), SeparationPose(80, 180)};
  DescriptorSeparationParams forward;
  forward.max_heading_deg = 70.0;
  const DistanceQuantiles q = SeparateScene(s, {}, {}, forward);
  CHECK(q.true_pairs == 1);   // (0,0) is 90 deg apart; (1,1) 60 deg stays
  CHECK(q.false_pairs == 5);  // headings do not matter for false pairs
  CHECK(q.true_p50 == doctest::Approx(0.0).epsilon(1e-6));
  CHECK(SeparateScene(s).true_pairs == 2);  // a spinning sensor (180) keeps both
}

TEST_CASE("Descriptor separation: a costly metric measures every true pair but only every stride-th false pair") {
  const SeparationScene s;
  DescriptorMetric scan_context;
  scan_context.kind = DescriptorMetric::Kind::kScanContext;  // 2-d is no 20 x 60 grid: every distance 1
  const DistanceQuantiles q = SeparateScene(s, {}, scan_context);
  CHECK(q.true_pairs == 2);
  CHECK(q.false_pairs == 0);  // i + j is 2, 3 or 4: never a multiple of 31
  DescriptorSeparationParams every_second;
  every_second.costly_metric_false_pair_stride = 2;
  const DistanceQuantiles h = SeparateScene(s, {}, scan_context, every_second);
  CHECK(h.true_pairs == 2);
  CHECK(h.false_pairs == 3);  // (0,2), (2,0), (2,2)
  CHECK(h.false_p50 == 1.0);
  every_second.costly_metric_false_pair_stride = 1;
  CHECK(SeparateScene(s, {}, scan_context, every_second).false_pairs == 5);
  every_second.costly_metric_false_pair_stride = 2;
  CHECK(SeparateScene(s, {}, {}, every_second).false_pairs == 5);  // unit L2 is never subsampled
}
