// SPDX-License-Identifier: BSD-3-Clause
// KITTI-12 and TUM pose files, KITTI times.txt: round trips, hand-written files with known values, errors.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "platform/io/poses.hpp"
#include "tests/platform/io/io_test_util.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

Eigen::Isometry3d RandomPose(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Quaterniond q(normal(*rng), normal(*rng), normal(*rng), normal(*rng));
  q.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = 100.0 * Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng));
  return T;
}

double OrthonormalityError(const Eigen::Matrix3d& R) {
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
}

// The 90-degree yaw: x -> y, y -> -x.
const Eigen::Matrix3d kYaw90 = (Eigen::Matrix3d() << 0, -1, 0, 1, 0, 0, 0, 0, 1).finished();

TEST_CASE("poses: KITTI-12 poses round-trip through WriteKittiPoses and ReadKittiPoses") {
  std::mt19937 rng(11);
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 50; ++i) poses.push_back(RandomPose(&rng));
  const std::string path = ScratchFile("roundtrip_kitti.txt");
  REQUIRE(WriteKittiPoses(path, Span<const Eigen::Isometry3d>(poses)).ok());

  auto back = ReadKittiPoses(path);
  REQUIRE(back.ok());
  REQUIRE(back->size() == poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    CHECK(((*back)[i].matrix() - poses[i].matrix()).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((*back)[i].translation() == poses[i].translation());  // text is exact; only R is re-orthonormalised
  }
}

TEST_CASE("poses: TUM poses round-trip through WriteTumPoses and ReadTumPoses") {
  std::mt19937 rng(12);
  std::vector<StampedPose> poses;
  for (int i = 0; i < 50; ++i) poses.push_back(StampedPose{1.3e9 + 0.1 * i, RandomPose(&rng)});
  const std::string path = ScratchFile("roundtrip_tum.txt");
  REQUIRE(WriteTumPoses(path, Span<const StampedPose>(poses)).ok());

  auto back = ReadTumPoses(path);
  REQUIRE(back.ok());
  REQUIRE(back->size() == poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    CHECK((*back)[i].time_s == poses[i].time_s);
    CHECK((*back)[i].T_frame_sensor.translation() == poses[i].T_frame_sensor.translation());
    CHECK(((*back)[i].T_frame_sensor.matrix() - poses[i].T_frame_sensor.matrix()).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("poses: a hand-written KITTI line with a 90-degree yaw gives the expected matrix") {
  const std::string path = WriteFile("yaw90_kitti.txt",
                                     "1 0 0 0 0 1 0 0 0 0 1 0\n"
                                     "0 -1 0 1.5 1 0 0 -2 0 0 1 3.25\n\n\n");
  auto poses = ReadKittiPoses(path);
  REQUIRE(poses.ok());
  REQUIRE(poses->size() == 2);  // trailing blank lines are skipped
  CHECK((*poses)[0].matrix() == Eigen::Matrix4d::Identity());
  CHECK(((*poses)[1].linear() - kYaw90).cwiseAbs().maxCoeff() < 1e-15);
  CHECK((*poses)[1].translation() == Eigen::Vector3d(1.5, -2, 3.25));
  const Eigen::Vector3d p = (*poses)[1] * Eigen::Vector3d(1, 0, 0);  // x axis turns into y
  CHECK((p - Eigen::Vector3d(1.5, -1, 3.25)).norm() < 1e-15);
}

TEST_CASE("poses: a hand-written TUM file with comments, blank lines and a 90-degree yaw") {
  const double s = std::sqrt(0.5);
  char line[256];
  std::snprintf(line, sizeof(line), "1700000000.25 1 2 3 0 0 %.17g %.17g\n", s, s);
  const std::string path = WriteFile("yaw90_tum.txt", "# timestamp tx ty tz qx qy qz qw\n\n" + std::string(line) +
                                                          "  # another comment\n0.5 0 0 0 0 0 0 1\n\n");
  auto poses = ReadTumPoses(path);
  REQUIRE(poses.ok());
  REQUIRE(poses->size() == 2);
  CHECK((*poses)[0].time_s == 1700000000.25);
  CHECK(((*poses)[0].T_frame_sensor.linear() - kYaw90).cwiseAbs().maxCoeff() < 1e-15);
  CHECK((*poses)[0].T_frame_sensor.translation() == Eigen::Vector3d(1, 2, 3));
  CHECK((*poses)[1].time_s == 0.5);
  CHECK((*poses)[1].T_frame_sensor.matrix() == Eigen::Matrix4d::Identity());
}

TEST_CASE("poses: a KITTI line with 11 values is an error naming the file and the line") {
  const std::string path = WriteFile("eleven.txt",
                                     "1 0 0 0 0 1 0 0 0 0 1 0\n"
                                     "1 0 0 0 0 1 0 0 0 0 1 0\n"
                                     "1 0 0 0 0 1 0 0 0 0 1\n");
  auto poses = ReadKittiPoses(path);
  REQUIRE_FALSE(poses.ok());
  CheckError(poses.status(), StatusCode::kDataLoss, path, {"line 3", "expected 12 values, found 11"});
}

TEST_CASE("poses: unparsable tokens, NaN, inf and inner blank lines are errors naming the line") {
  const std::string ok = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  struct Case {
    std::string text;
    std::vector<std::string> parts;
  };
  const Case cases[] = {
      {ok + "1 0 0 0 0 1 0 abc 0 0 1 0\n", {"line 2", "value 8 'abc' is not a number"}},
      {ok + "1 0 0 0 0 1 0 1.5x 0 0 1 0\n", {"line 2", "'1.5x'"}},
      {ok + ok + "1 0 0 nan 0 1 0 0 0 0 1 0\n", {"line 3", "value 4 is nan"}},
      {"1 0 0 0 0 1 0 0 0 0 1 -inf\n", {"line 1", "-inf"}},
      {ok + "\n" + ok, {"line 2", "blank line"}},
      {"# comment\n" + ok, {"line 1", "expected 12 values, found 2"}},  // KITTI files have no comments
  };
  int index = 0;
  for (const Case& c : cases) {
    CAPTURE(c.text);
    const std::string path = WriteFile("bad_kitti_" + std::to_string(index++) + ".txt", c.text);
    auto poses = ReadKittiPoses(path);
    REQUIRE_FALSE(poses.ok());
    CheckError(poses.status(), StatusCode::kDataLoss, path, c.parts);
  }
}

TEST_CASE("poses: a rotation that is not orthonormal is rejected") {
  const std::string scaled = WriteFile("scaled.txt", "1.1 0 0 0 0 1 0 0 0 0 1 0\n");
  auto poses = ReadKittiPoses(scaled);
  REQUIRE_FALSE(poses.ok());
  CheckError(poses.status(), StatusCode::kDataLoss, scaled, {"line 1", "not orthonormal"});

  const std::string mirrored = WriteFile("mirrored.txt", "1 0 0 0 0 1 0 0 0 0 -1 0\n");  // det = -1
  poses = ReadKittiPoses(mirrored);
  REQUIRE_FALSE(poses.ok());
  CheckError(poses.status(), StatusCode::kDataLoss, mirrored, {"line 1", "det R = -1"});
}

TEST_CASE("poses: a slightly perturbed rotation is accepted and re-orthonormalised") {
  std::mt19937 rng(13);
  const Eigen::Isometry3d T = RandomPose(&rng);
  std::uniform_real_distribution<double> noise(-1e-3, 1e-3);
  Eigen::Matrix3d R = T.linear();
  for (int i = 0; i < 9; ++i) R.data()[i] += noise(rng);
  REQUIRE(OrthonormalityError(R) > 1e-4);

  std::string text;
  char value[64];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(value, sizeof(value), "%.17g ", c < 3 ? R(r, c) : T.translation()(r));
      text += value;
    }
  }
  const std::string path = WriteFile("perturbed.txt", text + "\n");
  auto poses = ReadKittiPoses(path);
  REQUIRE(poses.ok());
  REQUIRE(poses->size() == 1);
  const Eigen::Matrix3d R_read = (*poses)[0].linear();
  CHECK(OrthonormalityError(R_read) < 1e-12);
  CHECK(R_read.determinant() == doctest::Approx(1.0).epsilon(1e-12));
  CHECK((R_read - T.linear()).cwiseAbs().maxCoeff() < 3e-3);
  CHECK((*poses)[0].translation() == T.translation());
}

TEST_CASE("poses: TUM quaternions far from unit norm are rejected, near ones normalised") {
  auto norm_zero = ReadTumPoses(WriteFile("q0.txt", "0 1 2 3 0 0 0 0\n"));
  REQUIRE_FALSE(norm_zero.ok());
  CheckError(norm_zero.status(), StatusCode::kDataLoss, ScratchFile("q0.txt"), {"line 1", "quaternion norm 0"});

  auto norm_big = ReadTumPoses(WriteFile("q15.txt", "# header\n0 1 2 3 0 0 0 1.5\n"));
  REQUIRE_FALSE(norm_big.ok());
  CheckError(norm_big.status(), StatusCode::kDataLoss, ScratchFile("q15.txt"), {"line 2", "quaternion norm 1.5"});

  auto wrong_count = ReadTumPoses(WriteFile("q7.txt", "0 1 2 3 0 0 1\n"));
  REQUIRE_FALSE(wrong_count.ok());
  CheckError(wrong_count.status(), StatusCode::kDataLoss, ScratchFile("q7.txt"),
             {"line 1", "expected 8 values, found 7"});

  auto near = ReadTumPoses(WriteFile("q1005.txt", "0 1 2 3 0 0 0 1.005\n"));
  REQUIRE(near.ok());
  REQUIRE(near->size() == 1);
  CHECK(((*near)[0].T_frame_sensor.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-15);
}

TEST_CASE("poses: ReadTimes reads one number per line and rejects garbage") {
  auto times = ReadTimes(WriteFile("times.txt", "0.000000e+00\n1.037359e-01\r\n2.5\n\n"));
  REQUIRE(times.ok());
  CHECK(*times == std::vector<double>{0.0, 0.1037359, 2.5});

  const std::string two = WriteFile("times_two.txt", "0.0\n0.1 0.2\n");
  auto bad = ReadTimes(two);
  REQUIRE_FALSE(bad.ok());
  CheckError(bad.status(), StatusCode::kDataLoss, two, {"line 2", "expected 1 values, found 2"});
}

TEST_CASE("poses: missing files are not found and non-finite poses are not written") {
  const std::string missing = ScratchFile("missing_poses.txt");
  CHECK(ReadKittiPoses(missing).status().code() == StatusCode::kNotFound);
  CHECK(ReadTumPoses(missing).status().code() == StatusCode::kNotFound);
  CHECK(ReadTimes(missing).status().code() == StatusCode::kNotFound);

  std::vector<Eigen::Isometry3d> poses(2, Eigen::Isometry3d::Identity());
  poses[1].translation().x() = std::nan("");
  const std::string path = ScratchFile("nan_poses.txt");
  const Status s = WriteKittiPoses(path, Span<const Eigen::Isometry3d>(poses));
  CheckError(s, StatusCode::kInvalidArgument, path, {"pose 1"});
}

TEST_CASE("poses: KITTI 00 LiDAR poses and times") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/kitti00_frames0-15");
  auto poses = ReadKittiPoses(dir + "/poses_lidar.txt");
  REQUIRE(poses.ok());
  REQUIRE(poses->size() == 16);
  CHECK(((*poses)[0].matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff() < 1e-6);
  for (std::size_t i = 1; i < poses->size(); ++i) {
    const double step_m = ((*poses)[i].translation() - (*poses)[i - 1].translation()).norm();
    CAPTURE(i);
    CHECK(step_m > 0.0);
    CHECK(step_m < 1.5);
    CHECK(OrthonormalityError((*poses)[i].linear()) < 1e-12);
  }

  auto times = ReadTimes(dir + "/times.txt");
  REQUIRE(times.ok());
  REQUIRE(times->size() == 16);
  CHECK((*times)[0] == 0.0);
  for (std::size_t i = 1; i < times->size(); ++i) CHECK((*times)[i] > (*times)[i - 1]);
}

TEST_CASE("poses: small_gicp T_target_source as KITTI-12 equals its 4x4 text") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/small_gicp_pair");
  auto poses = ReadKittiPoses(dir + "/T_target_source_kitti12.txt");
  REQUIRE(poses.ok());
  REQUIRE(poses->size() == 1);

  std::ifstream matrix_text(dir + "/T_target_source.txt");  // independent parse of the 4x4 original
  Eigen::Matrix4d expected;
  for (int i = 0; i < 16; ++i) REQUIRE(static_cast<bool>(matrix_text >> expected.data()[i]));
  expected.transposeInPlace();  // read row by row into column-major storage
  // The file has 6 significant digits, so re-orthonormalisation moves R by about 1e-6.
  CHECK(((*poses)[0].matrix() - expected).cwiseAbs().maxCoeff() < 1e-5);
  CHECK((*poses)[0].translation() == expected.block<3, 1>(0, 3));
}

}  // namespace
}  // namespace commerge::platform
