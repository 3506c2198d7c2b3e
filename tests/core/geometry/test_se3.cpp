// SPDX-License-Identifier: BSD-3-Clause
// SO(3)/SE(3) maps: round trips (including angles near 0 and near pi), agreement with independent references
// (Eigen's AngleAxis, a series 4x4 matrix exponential), box-minus identities, Jacobians vs finite differences.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {
namespace {

// Rotation angles that exercise both branches of every coefficient and the neighbourhood of pi.
const std::vector<double> kAngles = {0.0,    1e-12, 1e-9,     1e-6,     1e-4,     9.99e-4,     1e-3,
                                     1.01e-3, 1e-2, 0.3,      1.0,      2.0,      3.0,         kPi - 1e-3,
                                     kPi - 1e-6, kPi - 1e-9};

Eigen::Vector3d RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d v(n(rng), n(rng), n(rng));
  return v.normalized();
}

Vector6d RandomTwist(std::mt19937& rng, double angle_rad, double translation_m) {
  Vector6d xi;
  xi.head<3>() = translation_m * RandomUnit(rng);
  xi.tail<3>() = angle_rad * RandomUnit(rng);
  return xi;
}

// Independent reference: exp of the 4x4 twist matrix by scaling and squaring of a Taylor series.
Eigen::Matrix4d MatrixExp(const Vector6d& xi) {
  Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
  X.topLeftCorner<3, 3>() = Skew(xi.tail<3>());
  X.topRightCorner<3, 1>() = xi.head<3>();
  int squarings = 0;
  while (X.cwiseAbs().maxCoeff() > 0.01) {
    X *= 0.5;
    ++squarings;
  }
  Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
  for (int k = 1; k <= 12; ++k) {
    term = term * X / static_cast<double>(k);
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = result * result;
  return result;
}

double MaxAbsDiff(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff();
}

}  // namespace

TEST_CASE("ExpSO3 matches Eigen's AngleAxis and is orthonormal") {
  std::mt19937 rng(1);
  for (const double angle : kAngles) {
    for (int rep = 0; rep < 5; ++rep) {
      const Eigen::Vector3d axis = RandomUnit(rng);
      const Eigen::Matrix3d R = ExpSO3(angle * axis);
      const Eigen::Matrix3d ref = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      CHECK((R - ref).cwiseAbs().maxCoeff() < 1e-14);
      CHECK((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-14);
      CHECK(R.determinant() == doctest::Approx(1.0).epsilon(1e-14));
    }
  }
}

TEST_CASE("LogSO3 inverts ExpSO3 for angles from 0 to just below pi") {
  std::mt19937 rng(2);
  for (const double angle : kAngles) {
    for (int rep = 0; rep < 20; ++rep) {
      const Eigen::Vector3d omega = angle * RandomUnit(rng);
      const Eigen::Matrix3d R = ExpSO3(omega);
      const Eigen::Vector3d back = LogSO3(R);
      // Relative accuracy near 0, absolute ~1e-15 elsewhere (near pi the axis is recovered from the
      // symmetric part, which is exact to rounding).
      INFO("angle " << angle);
      CHECK((back - omega).norm() <= 1e-14 * std::max(1.0, angle) + 1e-15 * angle);
      CHECK(RotationAngleRad(R) == doctest::Approx(angle).epsilon(1e-13).scale(1.0));
    }
  }
  // Uniformly random rotations.
  for (int rep = 0; rep < 200; ++rep) {
    std::uniform_real_distribution<double> u(0.0, kPi);
    const Eigen::Vector3d omega = u(rng) * RandomUnit(rng);
    CHECK((LogSO3(ExpSO3(omega)) - omega).norm() < 1e-13);
  }
}

TEST_CASE("LogSO3 at exactly pi returns an angle of pi about the right axis (either sign)") {
  std::mt19937 rng(3);
  for (int rep = 0; rep < 20; ++rep) {
    const Eigen::Vector3d axis = RandomUnit(rng);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(kPi, axis).toRotationMatrix();
    const Eigen::Vector3d omega = LogSO3(R);
    CHECK(omega.norm() == doctest::Approx(kPi).epsilon(1e-12));
    CHECK(std::abs(omega.normalized().dot(axis)) == doctest::Approx(1.0).epsilon(1e-12));
    CHECK((ExpSO3(omega) - R).cwiseAbs().maxCoeff() < 1e-14);
  }
  // Axis-aligned half turns (the trace = -1 corner cases of matrix-based logs).
  for (int i = 0; i < 3; ++i) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(kPi, Eigen::Vector3d::Unit(i)).toRotationMatrix();
    CHECK(LogSO3(R).norm() == doctest::Approx(kPi).epsilon(1e-14));
    CHECK((ExpSO3(LogSO3(R)) - R).cwiseAbs().maxCoeff() < 1e-15);
  }
  CHECK(LogSO3(Eigen::Matrix3d::Identity()).norm() == 0.0);
}

TEST_CASE("ExpSE3 matches the 4x4 matrix exponential and LogSE3 inverts it") {
  std::mt19937 rng(4);
  for (const double angle : kAngles) {
    for (int rep = 0; rep < 10; ++rep) {
      const Vector6d xi = RandomTwist(rng, angle, 5.0 * (rep + 1));
      const Eigen::Isometry3d T = ExpSE3(xi);
      INFO("angle " << angle);
      CHECK((T.matrix() - MatrixExp(xi)).cwiseAbs().maxCoeff() < 1e-12 * std::max(1.0, xi.norm()));  // reference rounding grows with |xi|
      CHECK((LogSE3(T) - xi).norm() < 1e-12 * std::max(1.0, xi.norm()));
    }
  }
  // Translation-only and rotation-only twists.
  Vector6d xi;
  xi << 1.0, -2.0, 3.0, 0.0, 0.0, 0.0;
  CHECK((ExpSE3(xi).translation() - xi.head<3>()).norm() == 0.0);
  CHECK((LogSE3(ExpSE3(xi)) - xi).norm() < 1e-15);
  xi << 0.0, 0.0, 0.0, 0.1, 0.2, -0.3;
  CHECK(ExpSE3(xi).translation().norm() == 0.0);
}

TEST_CASE("BoxMinus and BoxPlus are inverse to each other") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(0.0, 3.0);
  for (int rep = 0; rep < 100; ++rep) {
    const Eigen::Isometry3d a = ExpSE3(RandomTwist(rng, angle(rng), 20.0));
    const Eigen::Isometry3d b = ExpSE3(RandomTwist(rng, angle(rng), 20.0));
    CHECK(BoxMinus(a, a).norm() < 1e-14);
    CHECK(MaxAbsDiff(BoxPlus(b, BoxMinus(a, b)), a) < 1e-12);
    const Vector6d xi = RandomTwist(rng, angle(rng), 3.0);
    CHECK((BoxMinus(BoxPlus(b, xi), b) - xi).norm() < 1e-12);
    // a [-] b = -(b [-] a) is a property of Log(b^-1 a) = -Log(a^-1 b).
    CHECK((BoxMinus(a, b) + BoxMinus(b, a)).norm() < 1e-11);
  }
}

TEST_CASE("AdjointSE3 moves a twist across a transform") {
  std::mt19937 rng(6);
  for (int rep = 0; rep < 50; ++rep) {
    const Eigen::Isometry3d T = ExpSE3(RandomTwist(rng, 2.0, 10.0));
    const Vector6d xi = RandomTwist(rng, 0.7, 2.0);
    CHECK(MaxAbsDiff(T * ExpSE3(xi) * T.inverse(), ExpSE3(AdjointSE3(T) * xi)) < 1e-12);
  }
}

TEST_CASE("SO(3) left Jacobian and its inverse match finite differences") {
  std::mt19937 rng(7);
  const double h = 1e-6;
  for (const double angle : kAngles) {
    if (angle > 3.0) continue;  // J_l^-1 grows without bound towards 2 pi; pi is covered by SE(3) below
    const Eigen::Vector3d phi = angle * RandomUnit(rng);
    Eigen::Matrix3d numeric;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(i);
      // ExpSO3(phi + d) = ExpSO3(J_l d) ExpSO3(phi)
      numeric.col(i) = (LogSO3(ExpSO3(phi + d) * ExpSO3(phi).transpose()) -
                        LogSO3(ExpSO3(phi - d) * ExpSO3(phi).transpose())) / (2.0 * h);
    }
    INFO("angle " << angle);
    CHECK((LeftJacobianSO3(phi) - numeric).cwiseAbs().maxCoeff() < 1e-8);
    CHECK((LeftJacobianSO3(phi) * LeftJacobianInverseSO3(phi) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <
          1e-12);
  }
}

TEST_CASE("SE(3) left and right Jacobian inverses match finite differences") {
  std::mt19937 rng(8);
  const double h = 1e-6;
  for (const double angle : kAngles) {
    for (int rep = 0; rep < 3; ++rep) {
      const Vector6d xi = RandomTwist(rng, std::min(angle, kPi - 0.05), 3.0);
      Matrix6d right, left;
      for (int i = 0; i < 6; ++i) {
        const Vector6d d = h * Vector6d::Unit(i);
        right.col(i) = (LogSE3(ExpSE3(xi) * ExpSE3(d)) - LogSE3(ExpSE3(xi) * ExpSE3(-d))) / (2.0 * h);
        left.col(i) = (LogSE3(ExpSE3(d) * ExpSE3(xi)) - LogSE3(ExpSE3(-d) * ExpSE3(xi))) / (2.0 * h);
      }
      INFO("angle " << angle);
      CHECK((RightJacobianInverseSE3(xi) - right).cwiseAbs().maxCoeff() < 1e-7);
      CHECK((LeftJacobianInverseSE3(xi) - left).cwiseAbs().maxCoeff() < 1e-7);
    }
  }
}

TEST_CASE("yaw/pitch/roll helpers and rigid-transform validation") {
  const Eigen::Matrix3d R = RotationFromYawPitchRoll(0.7, -0.2, 0.1);
  CHECK(YawRad(R) == doctest::Approx(0.7).epsilon(1e-14));
  CHECK((R - ExpSO3(Eigen::Vector3d(0, 0, 0.7)) * ExpSO3(Eigen::Vector3d(0, -0.2, 0)) *
                 ExpSO3(Eigen::Vector3d(0.1, 0, 0)))
            .cwiseAbs()
            .maxCoeff() < 1e-15);
  CHECK(YawRad(RotationFromYawPitchRoll(-3.0, 0.0, 0.0)) == doctest::Approx(-3.0).epsilon(1e-14));

  Eigen::Isometry3d T = ExpSE3(Vector6d::Constant(0.3));
  CHECK(IsValidRigidTransform(T));
  T.translation().x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(IsValidRigidTransform(T));
  T = Eigen::Isometry3d::Identity();
  T.linear() *= 1.01;  // scaled
  CHECK_FALSE(IsValidRigidTransform(T));
  T.linear() = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();  // reflection
  CHECK_FALSE(IsValidRigidTransform(T));
}

}  // namespace commerge
