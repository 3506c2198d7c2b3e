// SPDX-License-Identifier: BSD-3-Clause
// GNC-TLS rotation and adaptive-voting translation (core/registration/robust_solver): hand-made inlier /
// outlier sets with known answers, and the 1-D TLS against a brute force over its candidate windows.
#include <doctest/doctest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/registration/robust_solver.hpp"
#include "tests/support/pose_errors.hpp"

namespace commerge {
namespace {

using test::RotationErrorDeg;

// Brute force of the adaptive-voting definition: the candidate consensus sets are the windows
// {v : v_k - 2 bound <= v <= v_k} (the intervals open at v_k - bound); the cheapest wins, ties to the first in
// ascending v_k.
double ScalarTlsBruteForce(const std::vector<double>& v, double bound) {
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  double best_cost = std::numeric_limits<double>::infinity(), best_mean = 0.0;
  for (double top : sorted) {
    double sum = 0.0;
    int m = 0;
    for (double x : v) {
      if (x >= top - 2.0 * bound && x <= top) sum += x, ++m;
    }
    const double mean = sum / m;
    double cost = 0.0;
    for (double x : v) {
      if (x >= top - 2.0 * bound && x <= top) cost += (x - mean) * (x - mean);
    }
    cost += static_cast<double>(static_cast<int>(v.size()) - m) * bound;
    if (cost < best_cost - 1e-9) best_cost = cost, best_mean = mean;
  }
  return best_mean;
}

}  // namespace

TEST_CASE("Scalar TLS equals a brute force over its consensus windows and finds the inlier cluster") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> spread(-50.0, 50.0), noise(-0.3, 0.3);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> v;
    const int inliers = 3 + trial % 20, outliers = trial % 15;
    const double truth = spread(rng);
    for (int i = 0; i < inliers; ++i) v.push_back(truth + noise(rng));
    for (int i = 0; i < outliers; ++i) v.push_back(spread(rng));
    std::shuffle(v.begin(), v.end(), rng);
    std::vector<std::uint8_t> in;
    const double est = EstimateScalarTls(v, 0.75, &in);
    CHECK(est == doctest::Approx(ScalarTlsBruteForce(v, 0.75)).epsilon(1e-9));
    if (inliers > outliers) CHECK(std::fabs(est - truth) < 0.3);
    for (std::size_t k = 0; k < v.size(); ++k) CHECK(static_cast<bool>(in[k]) == (std::fabs(v[k] - est) <= 0.75));
  }
  CHECK(std::isnan(EstimateScalarTls({}, 0.75)));
  CHECK(EstimateScalarTls(std::vector<double>{4.0}, 0.75) == 4.0);
}

TEST_CASE("GNC-TLS rotation recovers a known rotation with 40 percent outliers") {
  std::mt19937 rng(17);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(2.5, Eigen::Vector3d(0.3, -0.2, 1.0).normalized())).toRotationMatrix();
  std::vector<Eigen::Vector3d> x, y;
  std::vector<bool> truth;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d xi(10.0 * n01(rng), 10.0 * n01(rng), 3.0 * n01(rng));
    const bool in = i % 5 >= 2;  // 60 % inliers
    x.push_back(xi);
    y.push_back(in ? Eigen::Vector3d(R * xi + 0.1 * Eigen::Vector3d(n01(rng), n01(rng), n01(rng)))
                   : Eigen::Vector3d(10.0 * n01(rng), 10.0 * n01(rng), 3.0 * n01(rng)));
    truth.push_back(in);
  }
  RobustSolverParams p;
  std::vector<double> w;
  const RotationGncResult r = EstimateRotationGncTls(x, y, 1.5, p, &w);
  REQUIRE(r.valid);
  CHECK(RotationErrorDeg(r.R, R) < 0.5);
  CHECK(r.R.determinant() == doctest::Approx(1.0).epsilon(1e-9));
  std::size_t agree = 0;
  for (std::size_t k = 0; k < w.size(); ++k) agree += (w[k] >= 0.5) == truth[k];
  CHECK(agree >= 97);
  CHECK(r.num_inliers >= 58);
  CHECK(r.num_inliers <= 63);

  // Outlier-free, noise-free: the first iteration already fits (mu <= 0), all inliers.
  std::vector<Eigen::Vector3d> y_clean;
  for (const Eigen::Vector3d& xi : x) y_clean.push_back(R * xi);
  const RotationGncResult clean = EstimateRotationGncTls(x, y_clean, 1.5, p);
  CHECK(clean.iterations == 1);
  CHECK(clean.num_inliers == x.size());
  CHECK(RotationErrorDeg(clean.R, R) < 1e-6);
}

TEST_CASE("GNC-TLS rotation: planar measurements still give a proper rotation (reflection fix)") {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<Eigen::Vector3d> x, y;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d xi(std::cos(0.5 * i) * (3 + i), std::sin(0.5 * i) * (3 + i), 0.0);
    x.push_back(xi);
    y.push_back(R * xi);
  }
  const RotationGncResult r = EstimateRotationGncTls(x, y, 1.5, RobustSolverParams{});
  REQUIRE(r.valid);
  CHECK(r.R.determinant() == doctest::Approx(1.0).epsilon(1e-9));
  CHECK(RotationErrorDeg(r.R, R) < 1e-6);
}

TEST_CASE("Robust registration: known rigid transform from correspondences with 20 percent outliers") {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> pos(-30.0, 30.0), noise(-0.2, 0.2);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(-2.0, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX())).toRotationMatrix();
  T.translation() = Eigen::Vector3d(-14.0, 6.0, 0.7);
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 80; ++i) {
    const Eigen::Vector3d ai(pos(rng), pos(rng), 0.1 * pos(rng));
    a.push_back(ai);
    b.push_back(i % 5 != 0 ? Eigen::Vector3d(T * ai + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)))
                           : Eigen::Vector3d(pos(rng), pos(rng), 0.1 * pos(rng)));
  }
  const RobustRegistrationResult r = SolveRobustRegistration(a, b, RobustSolverParams{});
  REQUIRE(r.valid);
  CHECK(RotationErrorDeg(r.T_target_source.linear(), T.linear()) < 1.0);
  CHECK((r.T_target_source.translation() - T.translation()).norm() < 0.3);
  // Translation inliers are counted over all correspondences (spec quirk 4): the 64 true ones.
  CHECK(r.num_final_inliers >= 62);
  CHECK(r.num_final_inliers <= 66);
  // Fewer than 3 correspondences: invalid, never a crash.
  CHECK_FALSE(SolveRobustRegistration(Span<const Eigen::Vector3d>(a.data(), 2), Span<const Eigen::Vector3d>(b.data(), 2),
                                      RobustSolverParams{})
                  .valid);
}

}  // namespace commerge
