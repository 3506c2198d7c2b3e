// SPDX-License-Identifier: BSD-3-Clause
// commerge: SO(3) / SE(3) exponential and logarithm maps, box-minus, adjoint and Jacobians.
//
// Conventions (used everywhere in commerge):
//  * T_a_b maps points from frame b to frame a: p_a = T_a_b * p_b.
//  * A twist xi in se(3) ~ R^6 is ordered [rho; phi]: rho (xi.head<3>()) is the translational part [m],
//    phi (xi.tail<3>()) the rotation vector [rad] (axis * angle). ExpSE3(xi) = [ExpSO3(phi), J_l(phi) rho; 0 1]
//    (Barfoot, "State Estimation for Robotics", ch. 7).
//  * Box-minus is X [-] Y = LogSE3(Y^-1 X), the twist that takes Y to X by right-multiplication:
//    X = Y * ExpSE3(X [-] Y) (paper, section "Intra-Robot SLAM for Local Mapping").
//  * Perturbations are on the right: T <- T * ExpSE3(delta).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace commerge {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Skew-symmetric matrix [v]x with [v]x * w = v.cross(w).
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

/// Rotation matrix of the rotation vector `omega_rad` (axis * angle, Rodrigues' formula; exact near 0).
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& omega_rad);

/// Rotation vector (axis * angle, angle in [0, pi]) of the rotation matrix `R`. Accurate near 0 and near pi
/// (via the quaternion, Shepperd's method); at exactly pi either of the two opposite axes is returned.
/// `R` must be a rotation matrix (orthonormal, det +1) up to rounding.
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R);

/// Rotation angle of `R` in [0, pi] [rad] (= LogSO3(R).norm(), computed directly).
double RotationAngleRad(const Eigen::Matrix3d& R);

/// Left Jacobian J_l(phi) of SO(3): ExpSO3(phi + d) ~= ExpSO3(J_l(phi) d) * ExpSO3(phi).
Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi_rad);

/// Inverse of LeftJacobianSO3 (defined for |phi| < 2 pi).
Eigen::Matrix3d LeftJacobianInverseSO3(const Eigen::Vector3d& phi_rad);

/// Rigid transform of the twist `xi` = [rho [m]; phi [rad]].
Eigen::Isometry3d ExpSE3(const Vector6d& xi);

/// Twist [rho [m]; phi [rad]] of the rigid transform `T` (rotation angle in [0, pi]).
Vector6d LogSE3(const Eigen::Isometry3d& T);

/// a [-] b = LogSE3(b^-1 * a): the twist, in b's frame, that takes b to a (a = b * ExpSE3(a [-] b)).
Vector6d BoxMinus(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

/// a [+] xi = a * ExpSE3(xi) (right perturbation; inverse of BoxMinus).
Eigen::Isometry3d BoxPlus(const Eigen::Isometry3d& a, const Vector6d& xi);

/// Adjoint of T for [rho; phi] twists: T * ExpSE3(xi) * T^-1 = ExpSE3(AdjointSE3(T) * xi);
/// AdjointSE3(T) = [R, [t]x R; 0, R].
Matrix6d AdjointSE3(const Eigen::Isometry3d& T);

/// Inverse of the left Jacobian of SE(3) (Barfoot eq. 7.85-7.86, exact, with series near 0):
/// LogSE3(ExpSE3(d) * ExpSE3(xi)) ~= xi + LeftJacobianInverseSE3(xi) * d.
Matrix6d LeftJacobianInverseSE3(const Vector6d& xi);

/// Inverse of the right Jacobian of SE(3) (= LeftJacobianInverseSE3(-xi)):
/// LogSE3(ExpSE3(xi) * ExpSE3(d)) ~= xi + RightJacobianInverseSE3(xi) * d.
Matrix6d RightJacobianInverseSE3(const Vector6d& xi);

/// Rotation R = Rz(yaw) * Ry(pitch) * Rx(roll) (intrinsic Z-Y-X; angles in rad).
Eigen::Matrix3d RotationFromYawPitchRoll(double yaw_rad, double pitch_rad, double roll_rad);

/// Yaw of R = Rz(yaw) * Ry(pitch) * Rx(roll), in (-pi, pi] [rad] (heading of R's x axis in the xy-plane).
double YawRad(const Eigen::Matrix3d& R);

/// True when every entry of T's rotation and translation is finite and the rotation is orthonormal with
/// det +1 within `tolerance` (max-abs entry of R^T R - I, and |det R - 1|).
bool IsValidRigidTransform(const Eigen::Isometry3d& T, double tolerance = 1e-6);

}  // namespace commerge
