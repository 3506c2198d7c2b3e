// SPDX-License-Identifier: BSD-3-Clause
// SO(3)/SE(3) maps. Closed forms from Barfoot, "State Estimation for Robotics" (2017), sections 7.1.3-7.1.5;
// each coefficient switches to its Taylor series below a small angle, where the closed form cancels.
#include "core/geometry/se3.hpp"

#include <cmath>

namespace commerge {
namespace {

// Below this angle [rad] the coefficients use their series; above it the closed forms are accurate to
// ~1e-16 / angle^k, which the coefficient's own factor angle^k cancels (absolute error ~1e-16).
constexpr double kSmallAngleRad = 1e-3;

}  // namespace

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& omega_rad) {
  const double theta2 = omega_rad.squaredNorm();
  const double theta = std::sqrt(theta2);
  double a;  // sin(theta) / theta
  double b;  // (1 - cos(theta)) / theta^2
  if (theta < kSmallAngleRad) {
    a = 1.0 - theta2 / 6.0 + theta2 * theta2 / 120.0;
    b = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0;
  } else {
    a = std::sin(theta) / theta;
    b = (1.0 - std::cos(theta)) / theta2;
  }
  const Eigen::Matrix3d W = Skew(omega_rad);
  return Eigen::Matrix3d::Identity() + a * W + b * W * W;
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  // q = [w, v] with v = sin(theta/2) * axis, w = cos(theta/2); pick w >= 0 so that theta is in [0, pi].
  const Eigen::Quaterniond q(R);
  double w = q.w();
  Eigen::Vector3d v = q.vec();
  if (w < 0.0) {
    w = -w;
    v = -v;
  }
  const double n2 = v.squaredNorm();
  if (n2 < 1e-16) {
    // theta / n = 2 atan(n / w) / n = (2 / w) (1 - n^2 / (3 w^2) + ...); w ~= 1 here.
    return (2.0 / w) * (1.0 - n2 / (3.0 * w * w)) * v;
  }
  const double n = std::sqrt(n2);
  return (2.0 * std::atan2(n, w) / n) * v;
}

double RotationAngleRad(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi_rad) {
  const double theta2 = phi_rad.squaredNorm();
  const double theta = std::sqrt(theta2);
  double b;  // (1 - cos(theta)) / theta^2
  double c;  // (theta - sin(theta)) / theta^3
  if (theta < kSmallAngleRad) {
    b = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0;
    c = 1.0 / 6.0 - theta2 / 120.0 + theta2 * theta2 / 5040.0;
  } else {
    b = (1.0 - std::cos(theta)) / theta2;
    c = (theta - std::sin(theta)) / (theta2 * theta);
  }
  const Eigen::Matrix3d W = Skew(phi_rad);
  return Eigen::Matrix3d::Identity() + b * W + c * W * W;
}

Eigen::Matrix3d LeftJacobianInverseSO3(const Eigen::Vector3d& phi_rad) {
  const double theta2 = phi_rad.squaredNorm();
  const double theta = std::sqrt(theta2);
  double d;  // (1 - (theta / 2) cot(theta / 2)) / theta^2
  if (theta < kSmallAngleRad) {
    d = 1.0 / 12.0 + theta2 / 720.0 + theta2 * theta2 / 30240.0;
  } else {
    const double half = 0.5 * theta;
    d = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  const Eigen::Matrix3d W = Skew(phi_rad);
  return Eigen::Matrix3d::Identity() - 0.5 * W + d * W * W;
}

Eigen::Isometry3d ExpSE3(const Vector6d& xi) {
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = ExpSO3(phi);
  T.translation() = LeftJacobianSO3(phi) * xi.head<3>();
  return T;
}

Vector6d LogSE3(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d phi = LogSO3(T.linear());
  Vector6d xi;
  xi.head<3>() = LeftJacobianInverseSO3(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Vector6d BoxMinus(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return LogSE3(b.inverse() * a); }

Eigen::Isometry3d BoxPlus(const Eigen::Isometry3d& a, const Vector6d& xi) { return a * ExpSE3(xi); }

Matrix6d AdjointSE3(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  Matrix6d ad;
  ad.topLeftCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = Skew(T.translation()) * R;
  ad.bottomLeftCorner<3, 3>().setZero();
  ad.bottomRightCorner<3, 3>() = R;
  return ad;
}

Matrix6d LeftJacobianInverseSE3(const Vector6d& xi) {
  const Eigen::Vector3d phi = xi.tail<3>();
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  // Q(rho, phi), Barfoot eq. 7.86.
  double c1;  // (theta - sin) / theta^3
  double c2;  // (theta^2 + 2 cos - 2) / (2 theta^4)
  double c3;  // (2 theta - 3 sin + theta cos) / (2 theta^5)
  if (theta < kSmallAngleRad) {
    c1 = 1.0 / 6.0 - theta2 / 120.0;
    c2 = 1.0 / 24.0 - theta2 / 720.0;
    c3 = 1.0 / 120.0 - theta2 / 2520.0;
  } else {
    const double s = std::sin(theta);
    const double c = std::cos(theta);
    const double theta4 = theta2 * theta2;
    c1 = (theta - s) / (theta2 * theta);
    c2 = (theta2 + 2.0 * c - 2.0) / (2.0 * theta4);
    c3 = (2.0 * theta - 3.0 * s + theta * c) / (2.0 * theta4 * theta);
  }
  const Eigen::Matrix3d P = Skew(phi);
  const Eigen::Matrix3d Rho = Skew(xi.head<3>());
  const Eigen::Matrix3d PR = P * Rho;
  const Eigen::Matrix3d RP = Rho * P;
  const Eigen::Matrix3d PRP = PR * P;
  const Eigen::Matrix3d Q = 0.5 * Rho + c1 * (PR + RP + PRP) + c2 * (P * PR + RP * P - 3.0 * PRP) +
                            c3 * (PRP * P + P * PRP);
  const Eigen::Matrix3d A = LeftJacobianInverseSO3(phi);
  Matrix6d J;
  J.topLeftCorner<3, 3>() = A;
  J.topRightCorner<3, 3>() = -A * Q * A;
  J.bottomLeftCorner<3, 3>().setZero();
  J.bottomRightCorner<3, 3>() = A;
  return J;
}

Matrix6d RightJacobianInverseSE3(const Vector6d& xi) { return LeftJacobianInverseSE3(-xi); }

Eigen::Matrix3d RotationFromYawPitchRoll(double yaw_rad, double pitch_rad, double roll_rad) {
  return (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

double YawRad(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

bool IsValidRigidTransform(const Eigen::Isometry3d& T, double tolerance) {
  const Eigen::Matrix3d R = T.linear();
  if (!R.allFinite() || !T.translation().allFinite()) return false;
  const double orthonormality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return orthonormality <= tolerance && std::abs(R.determinant() - 1.0) <= tolerance;
}

}  // namespace commerge
