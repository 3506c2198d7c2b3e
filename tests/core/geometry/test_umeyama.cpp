// SPDX-License-Identifier: BSD-3-Clause
// Umeyama / Kabsch alignment: recovery of known transforms (exact and noisy), least-squares optimality,
// planar sets, the reflection fix, optional scale, and rejection of bad input.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"
#include "tests/support/pose_errors.hpp"

namespace commerge {
namespace {

using test::RotationErrorRad;

Eigen::Isometry3d RandomTransform(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> angle(0.0, 3.1);
  Vector6d xi;
  xi << 20.0 * n(rng), 20.0 * n(rng), 5.0 * n(rng), 0.0, 0.0, 0.0;
  xi.tail<3>() = angle(rng) * Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  return ExpSE3(xi);
}

std::vector<Eigen::Vector3d> RandomPoints(std::mt19937& rng, std::size_t count, double extent_m) {
  std::uniform_real_distribution<double> u(-extent_m, extent_m);
  std::vector<Eigen::Vector3d> pts(count);
  for (auto& p : pts) p = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return pts;
}

std::vector<Eigen::Vector3d> Transformed(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3d>& pts) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.push_back(T * p);
  return out;
}


}  // namespace

TEST_CASE("AlignRigid recovers a random rigid transform from noise-free correspondences") {
  std::mt19937 rng(11);
  for (int rep = 0; rep < 50; ++rep) {
    const Eigen::Isometry3d T_target_source = RandomTransform(rng);
    const auto source = RandomPoints(rng, 3 + static_cast<std::size_t>(rep), 10.0);
    const auto target = Transformed(T_target_source, source);
    const Result<Eigen::Isometry3d> T = AlignRigid(source, target);
    REQUIRE(T.ok());
    CHECK(RotationErrorRad(*T, T_target_source) < 1e-9);
    CHECK((T->translation() - T_target_source.translation()).norm() < 1e-8);
    CHECK(AlignmentRmseM(source, target, *T) < 1e-8);
    CHECK(T->linear().determinant() == doctest::Approx(1.0).epsilon(1e-12));
  }
}

TEST_CASE("AlignRigid with noisy correspondences: close to the truth and no worse than the truth") {
  std::mt19937 rng(12);
  std::normal_distribution<double> noise(0.0, 0.02);  // 2 cm per axis
  for (int rep = 0; rep < 20; ++rep) {
    const Eigen::Isometry3d T_target_source = RandomTransform(rng);
    const auto source = RandomPoints(rng, 200, 10.0);
    auto target = Transformed(T_target_source, source);
    for (auto& p : target) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const Result<UmeyamaResult> r = Umeyama(source, target);
    REQUIRE(r.ok());
    CHECK(RotationErrorRad(r->T_target_source, T_target_source) < 1e-3);
    CHECK((r->T_target_source.translation() - T_target_source.translation()).norm() < 0.01);
    CHECK(r->scale == 1.0);
    // The estimate is the least-squares minimiser, so its residual cannot exceed the truth's.
    CHECK(r->rmse_m <= AlignmentRmseM(source, target, T_target_source) + 1e-12);
    CHECK(r->rmse_m == doctest::Approx(AlignmentRmseM(source, target, r->T_target_source)).epsilon(1e-12));
    CHECK(r->rmse_m == doctest::Approx(0.02 * std::sqrt(3.0)).epsilon(0.15));
  }
}

TEST_CASE("AlignRigid handles coplanar sets and never returns a reflection") {
  std::mt19937 rng(13);
  // Coplanar (z = 0) source: rank-2 cross-covariance, the reflection fix picks det +1.
  std::vector<Eigen::Vector3d> planar = RandomPoints(rng, 30, 5.0);
  for (auto& p : planar) p.z() = 0.0;
  const Eigen::Isometry3d T_target_source = RandomTransform(rng);
  const Result<Eigen::Isometry3d> T = AlignRigid(planar, Transformed(T_target_source, planar));
  REQUIRE(T.ok());
  CHECK(RotationErrorRad(*T, T_target_source) < 1e-9);
  CHECK((T->translation() - T_target_source.translation()).norm() < 1e-8);

  // Mirrored target: the best proper rotation is returned, not the mirror.
  const auto source = RandomPoints(rng, 40, 5.0);
  std::vector<Eigen::Vector3d> mirrored = source;
  for (auto& p : mirrored) p.x() = -p.x();
  const Result<Eigen::Isometry3d> M = AlignRigid(source, mirrored);
  REQUIRE(M.ok());
  CHECK(M->linear().determinant() == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(IsValidRigidTransform(*M, 1e-12));
}

TEST_CASE("Umeyama estimates a uniform scale when asked") {
  std::mt19937 rng(14);
  const Eigen::Isometry3d T = RandomTransform(rng);
  const auto source = RandomPoints(rng, 25, 4.0);
  std::vector<Eigen::Vector3d> target;
  for (const auto& p : source) target.push_back(2.5 * (T.linear() * p) + T.translation());
  UmeyamaParams params;
  params.estimate_scale = true;
  const Result<UmeyamaResult> r = Umeyama(source, target, params);
  REQUIRE(r.ok());
  CHECK(r->scale == doctest::Approx(2.5).epsilon(1e-12));
  CHECK(RotationErrorRad(r->T_target_source, T) < 1e-10);
  CHECK((r->T_target_source.translation() - T.translation()).norm() < 1e-9);
  CHECK(r->rmse_m < 1e-9);
  // Rigid alignment of the same data cannot reach zero residual.
  CHECK(Umeyama(source, target)->rmse_m > 1.0);
}

TEST_CASE("AlignRigid rejects mismatched, too small, non-finite and degenerate input") {
  std::mt19937 rng(15);
  const auto pts = RandomPoints(rng, 10, 3.0);
  std::vector<Eigen::Vector3d> fewer(pts.begin(), pts.end() - 1);

  Result<Eigen::Isometry3d> r = AlignRigid(pts, fewer);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("10 source points but 9 target") != std::string::npos);

  std::vector<Eigen::Vector3d> two(pts.begin(), pts.begin() + 2);
  r = AlignRigid(two, two);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("at least 3") != std::string::npos);
  CHECK(AlignRigid(Span<const Eigen::Vector3d>(), Span<const Eigen::Vector3d>()).status().code() ==
        StatusCode::kInvalidArgument);

  std::vector<Eigen::Vector3d> with_nan = pts;
  with_nan[4].y() = std::numeric_limits<double>::quiet_NaN();
  r = AlignRigid(pts, with_nan);
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("pair 4") != std::string::npos);

  // Collinear points: the rotation about the line is undetermined.
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 10; ++i) line.push_back(Eigen::Vector3d(1.0, 2.0, 3.0) + i * Eigen::Vector3d(0.3, -0.1, 0.7));
  r = AlignRigid(line, Transformed(RandomTransform(rng), line));
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("degenerate") != std::string::npos);

  // All points coincident.
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1.0, 1.0, 1.0));
  CHECK(AlignRigid(same, same).status().code() == StatusCode::kInvalidArgument);

  // A collinear target with a good source is degenerate too.
  CHECK(AlignRigid(pts, line).status().code() == StatusCode::kInvalidArgument);

  CHECK(std::isnan(AlignmentRmseM(pts, fewer, Eigen::Isometry3d::Identity())));
}

}  // namespace commerge
