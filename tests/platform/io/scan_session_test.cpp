// SPDX-License-Identifier: BSD-3-Clause
// Scan sessions: the scan order, one kind of scan, the three pose-file formats and their errors.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "platform/io/scan_session.hpp"
#include "tests/platform/io/io_test_util.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace scan_session_test {

namespace fs = std::filesystem;

/// A fresh folder holding empty files named `names` (a name ending in '/' is a folder).
std::string MakeFolder(const std::string& name, const std::vector<std::string>& names) {
  const std::string dir = test::ScratchFile(name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const std::string& n : names) {
    if (n.back() == '/') {
      fs::create_directories(dir + "/" + n);
    } else {
      WriteFile(name + "/" + n, "");
    }
  }
  return dir;
}

/// File names of `session`'s scans, in order.
std::vector<std::string> Names(const ScanSession& session) {
  std::vector<std::string> names;
  for (const std::string& f : session.scan_files) names.push_back(fs::path(f).filename().string());
  return names;
}

/// KITTI-12 lines of `n` poses: translation (k, 2k, 3k), identity rotation.
std::string KittiLines(int n) {
  std::string text;
  for (int k = 0; k < n; ++k) {
    text += "1 0 0 " + std::to_string(k) + " 0 1 0 " + std::to_string(2 * k) + " 0 0 1 " + std::to_string(3 * k) + "\n";
  }
  return text;
}

bool Near(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tolerance = 1e-12) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() <= tolerance;
}

Eigen::Isometry3d Pose(const Eigen::Vector3d& t, const Eigen::Matrix3d& R) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

TEST_CASE("scan session: scans are ordered by the number in their names, which compare exactly") {
  const std::string poses = WriteFile("poses3.txt", KittiLines(3));
  const std::string dir = MakeFolder("numbered", {"scan_10.pcd", "scan_2.pcd", "scan_1.PCD", "notes.txt", "sub/"});
  auto session = OpenScanSession(dir, poses);
  REQUIRE(session.ok());
  CHECK(session->ordered_by_number);
  CHECK(session->scan_extension == ".pcd");
  CHECK(Names(*session) == std::vector<std::string>{"scan_1.PCD", "scan_2.pcd", "scan_10.pcd"});
  CHECK(session->ignored == std::vector<std::string>{"notes.txt", "sub/"});
  CHECK(session->trajectory.format == PoseFileFormat::kKitti);
  CHECK(session->trajectory.times_s.empty());

  // Decimal stems (time stamps) beyond double precision, and leading zeros.
  const std::string stamps = MakeFolder("stamps", {"1565432123000000000.5.bin", "1565432123000000000.25.bin",
                                                   "1565432123000000001.bin"});
  session = OpenScanSession(stamps, poses);
  REQUIRE(session.ok());
  CHECK(Names(*session) == std::vector<std::string>{"1565432123000000000.25.bin", "1565432123000000000.5.bin",
                                                    "1565432123000000001.bin"});
  const std::string zeros = MakeFolder("zeros", {"000010.ply", "9.ply", "0000.ply"});
  session = OpenScanSession(zeros, poses);
  REQUIRE(session.ok());
  CHECK(Names(*session) == std::vector<std::string>{"0000.ply", "9.ply", "000010.ply"});
}

TEST_CASE("scan session: names without numbers or with equal numbers are ordered by name") {
  const std::string poses = WriteFile("poses2.txt", KittiLines(2));
  const std::string plain = MakeFolder("plain", {"b.pcd", "a.pcd"});
  auto session = OpenScanSession(plain, poses);
  REQUIRE(session.ok());
  CHECK_FALSE(session->ordered_by_number);
  CHECK(Names(*session) == std::vector<std::string>{"a.pcd", "b.pcd"});

  const std::string equal = MakeFolder("equal", {"y_1.pcd", "x_01.pcd"});
  session = OpenScanSession(equal, poses);
  REQUIRE(session.ok());
  CHECK_FALSE(session->ordered_by_number);
  CHECK(Names(*session) == std::vector<std::string>{"x_01.pcd", "y_1.pcd"});
}

TEST_CASE("scan session: a mix of kinds, no scans, a missing folder and differing counts are errors") {
  const std::string poses = WriteFile("poses2b.txt", KittiLines(2));
  const std::string mixed = MakeFolder("mixed", {"0.pcd", "1.pcd", "2.ply", "3.bin"});
  auto session = OpenScanSession(mixed, poses);
  REQUIRE_FALSE(session.ok());
  CheckError(session.status(), StatusCode::kInvalidArgument, mixed, {"holds 1 .bin and 2 .pcd and 1 .ply files"});

  const std::string empty = MakeFolder("kitti_like", {"velodyne/", "poses.txt"});
  session = OpenScanSession(empty, poses);
  REQUIRE_FALSE(session.ok());
  CheckError(session.status(), StatusCode::kNotFound, empty, {"holds no scan", "KITTI-layout directory"});

  const std::string missing = test::ScratchFile("no_such_folder");
  CheckError(OpenScanSession(missing, poses).status(), StatusCode::kNotFound, missing, {"no such directory"});

  const std::string three = MakeFolder("three", {"0.bin", "1.bin", "2.bin"});
  session = OpenScanSession(three, poses);
  REQUIRE_FALSE(session.ok());
  CheckError(session.status(), StatusCode::kInvalidArgument, poses, {"2 poses for the 3 .bin scans in " + three});
}

TEST_CASE("scan session: TUM files pair by index and keep their times") {
  const std::string dir = MakeFolder("tum_session", {"000000.pcd", "000001.pcd"});
  const std::string poses = WriteFile("tum.txt",
                                      "# timestamp tx ty tz qx qy qz qw\n"
                                      "1700000000.25 1 2 3 0 0 0 1\n\n"
                                      "1700000000.5 4 5 6 0 0 0.7071067811865476 0.7071067811865476\n");
  auto session = OpenScanSession(dir, poses);
  REQUIRE(session.ok());
  const Trajectory& t = session->trajectory;
  CHECK(t.format == PoseFileFormat::kTum);
  CHECK(t.times_s == std::vector<double>{1700000000.25, 1700000000.5});
  REQUIRE(t.T_frame_sensor.size() == 2);
  CHECK(Near(t.T_frame_sensor[1],
             Pose({4, 5, 6}, Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix())));

  // Forcing the wrong format names the line.
  ScanSessionOptions kitti;
  kitti.pose_format = PoseFileFormat::kKitti;
  CheckError(OpenScanSession(dir, poses, kitti).status(), StatusCode::kDataLoss, poses,
             {"line 1", "expected 12 values"});
}

TEST_CASE("scan session: CSV with a header, quaternions, extra columns and times in ns") {
  const std::string path = WriteFile("poses.csv",
                                     "# exported by a tool\n"
                                     "Index, \"Timestamp_ns\", X, Y, Z, QX, QY, QZ, QW, label\n"
                                     "0, 1000000000, 1, 2, 3, 0, 0, 0, 1, start\n"
                                     "1, 1500000000, 4, 5, 6, 0, 0, 0.7071067811865476, 0.7071067811865476, turn\n");
  auto t = ReadTrajectory(path);
  REQUIRE(t.ok());
  CHECK(t->format == PoseFileFormat::kCsv);
  CHECK(t->times_s == std::vector<double>{1.0, 1.5});
  REQUIRE(t->T_frame_sensor.size() == 2);
  CHECK(Near(t->T_frame_sensor[0], Pose({1, 2, 3}, Eigen::Matrix3d::Identity())));
  CHECK(Near(t->T_frame_sensor[1],
             Pose({4, 5, 6}, Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix())));
}

TEST_CASE("scan session: whitespace CSV with roll pitch yaw in radians, R = Rz Ry Rx, and no time column") {
  const double roll = 0.1, pitch = -0.2, yaw = 2.5;
  const std::string path = WriteFile("rpy.txt", "x y z roll pitch yaw\n1.5 -2 0.25 0.1 -0.2 2.5\n");
  auto t = ReadTrajectory(path);
  REQUIRE(t.ok());
  CHECK(t->format == PoseFileFormat::kCsv);
  CHECK(t->times_s.empty());
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  REQUIRE(t->T_frame_sensor.size() == 1);
  CHECK(Near(t->T_frame_sensor[0], Pose({1.5, -2, 0.25}, R)));
}

TEST_CASE("scan session: malformed pose files are errors naming the file and line") {
  struct Case {
    std::string name, text;
    std::vector<std::string> parts;
  };
  const Case cases[] = {
      {"five.txt", "\n# c\n1 2 3 4 5\n", {"line 3", "5 numbers: not a pose file format"}},
      {"no_quat.csv", "t,x,y,z,qx,qy,qz\n", {"line 1", "lacks columns", "qx, qy, qz, qw (or roll, pitch, yaw"}},
      {"short_row.csv", "t,x,y,z,qx,qy,qz,qw\n0,1,2,3,0,0,0,1\n1,1,2,3,0,0,0\n", {"line 3", "expected 8 values, found 7"}},
      {"not_number.csv", "t,x,y,z,qx,qy,qz,qw\n0,1,2,abc,0,0,0,1\n", {"line 2", "value 4 'abc' is not a finite number"}},
      {"nan.csv", "t,x,y,z,qx,qy,qz,qw\n0,1,nan,3,0,0,0,1\n", {"line 2", "value 3 'nan'"}},
      {"quat_norm.csv", "x y z qx qy qz qw\n1 2 3 0 0 0 2\n", {"line 2", "quaternion norm 2 is not 1"}},
      {"twice.csv", "x,tx,y,z,qx,qy,qz,qw\n", {"line 1", "column 'tx' (field 2)"}},
      {"only_comments.txt", "# nothing\n\n", {"holds no pose"}},
      {"backwards.txt", "2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", {"pose 1 has time 1 s, not after pose 0's 2 s"}},
      {"kitti_bad.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n", {"line 2", "expected 12 values, found 11"}},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const std::string path = WriteFile(c.name, c.text);
    auto t = ReadTrajectory(path);
    REQUIRE_FALSE(t.ok());
    CheckError(t.status(), StatusCode::kDataLoss, path, c.parts);
  }
  const std::string missing = test::ScratchFile("missing_poses.txt");
  CheckError(ReadTrajectory(missing).status(), StatusCode::kNotFound, missing, {});
}

TEST_CASE("scan session: pose file format names parse both ways") {
  for (const PoseFileFormat f : {PoseFileFormat::kAuto, PoseFileFormat::kKitti, PoseFileFormat::kTum,
                                 PoseFileFormat::kCsv}) {
    auto parsed = ParsePoseFileFormat(PoseFileFormatName(f));
    REQUIRE(parsed.ok());
    CHECK(*parsed == f);
  }
  CHECK(ParsePoseFileFormat("TUM").ok());
  const Status bad = ParsePoseFileFormat("xml").status();
  CHECK(bad.code() == StatusCode::kInvalidArgument);
  CHECK(bad.message().find("'xml': expected auto, kitti, tum or csv") != std::string::npos);
}

}  // namespace scan_session_test
}  // namespace commerge::platform
