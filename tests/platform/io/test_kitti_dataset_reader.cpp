// SPDX-License-Identifier: BSD-3-Clause
// The KITTI-layout dataset reader (platform/io/kitti_dataset_reader.hpp): "DIR" / "DIR:FIRST-LAST" parsing,
// scan order, consistent slicing of scans, poses, ground truth and times, ground truth composed with
// T_gt_robotstart.txt (checked against hand-computed poses) or its older name T_world_robotstart.txt, the
// poses_lidar.txt alias, --gt-from-poses,
// and errors that name the file. Datasets are tiny (6 scans of 1-3 points), written by hand in a scratch dir.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/geometry/angles.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_reader.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::platform {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kScans = 6;

double Deg(double d) { return d * kPi / 180.0; }

Eigen::Isometry3d YawPose(double yaw_rad, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// Odometry estimate of scan k and true pose of scan k in the robot's start frame.
Eigen::Isometry3d Estimated(std::size_t k) {
  const double kd = static_cast<double>(k);
  return YawPose(Deg(5.0 * kd), Eigen::Vector3d(2.0 * kd, 0.5 * kd, 0.25));
}
Eigen::Isometry3d Truth(std::size_t k) { return YawPose(Deg(10.0 * static_cast<double>(k)), Eigen::Vector3d(static_cast<double>(k), 0, 0)); }

// The start pose, written exactly as text: yaw +90 deg, at (10, 20, 0).
const char* const kStartLine = "0 -1 0 10 1 0 0 20 0 0 1 0\n";

// gt = start * truth(k), by hand: R_z(90) (k, 0, 0) = (0, k, 0), so t = (10, 20 + k, 0); yaw 90 + 10 k deg.
Eigen::Isometry3d ExpectedGt(std::size_t k) {
  const double kd = static_cast<double>(k);
  return YawPose(Deg(90.0 + 10.0 * kd), Eigen::Vector3d(10.0, 20.0 + kd, 0.0));
}

double TimeOf(std::size_t k) { return 0.1 * static_cast<double>(k) + 0.05; }

std::string PoseLine(const Eigen::Isometry3d& T) {
  std::string line;
  char buf[40];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buf, sizeof(buf), "%.17g", T.matrix()(r, c));
      line += (line.empty() ? "" : " ") + std::string(buf);
    }
  }
  return line + "\n";
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  REQUIRE(out.good());
  out << text;
  out.close();
  REQUIRE(out.good());
}

template <class F>
std::string Lines(std::size_t n, F line_of) {
  std::string text;
  for (std::size_t k = 0; k < n; ++k) text += line_of(k);
  return text;
}

std::string PosesText(std::size_t n, Eigen::Isometry3d (*pose)(std::size_t)) {
  return Lines(n, [pose](std::size_t k) { return PoseLine(pose(k)); });
}

std::string TimesText(std::size_t n) {
  return Lines(n, [](std::size_t k) {
    char buf[40];
    std::snprintf(buf, sizeof(buf), "%.17g\n", TimeOf(k));
    return std::string(buf);
  });
}

std::string ScanPath(const std::string& root, std::size_t k) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu.bin", k);
  return root + "/velodyne/" + name;
}

// A fresh dataset root with velodyne/ and `scans` scans, written last to first (so directory order is not
// creation order); scan k holds (k % 3) + 1 points with x = k. Plus files the reader must skip.
std::string MakeScans(const std::string& name, std::size_t scans) {
  const std::string root = test::ScratchDir() + "/kdr_" + name;
  std::error_code ec;
  fs::remove_all(root, ec);
  REQUIRE(fs::create_directories(root + "/velodyne"));
  for (std::size_t i = scans; i-- > 0;) {
    std::vector<PointXYZI> points(i % 3 + 1);
    for (std::size_t j = 0; j < points.size(); ++j) {
      points[j] = {static_cast<float>(i), static_cast<float>(j), 0.5f, 7.0f};
    }
    REQUIRE(WriteKittiBin(ScanPath(root, i), points).ok());
  }
  WriteText(root + "/velodyne/README.txt", "not a scan\n");
  WriteText(root + "/velodyne/000099.bin.tmp", "not a scan either\n");
  return root;
}

// The full simulator layout: scans, poses.txt, poses_gt.txt, T_gt_robotstart.txt and times.txt.
std::string MakeFullDataset(const std::string& name) {
  const std::string root = MakeScans(name, kScans);
  WriteText(root + "/poses.txt", PosesText(kScans, &Estimated));
  WriteText(root + "/poses_gt.txt", PosesText(kScans, &Truth));
  WriteText(root + "/T_gt_robotstart.txt", kStartLine);
  WriteText(root + "/times.txt", TimesText(kScans));
  return root;
}

RobotDatasetSpec Spec(const std::string& argument) {
  auto spec = ParseRobotDatasetSpec(argument);
  REQUIRE_MESSAGE(spec.ok(), spec.status().ToString());
  return *spec;
}

void CheckPose(const Eigen::Isometry3d& got, const Eigen::Isometry3d& expected) {
  CHECK((got.matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-9);
}

void CheckErrorMentions(const Status& status, StatusCode code, const std::vector<std::string>& parts) {
  CHECK(status.code() == code);
  for (const std::string& part : parts) {
    INFO("message: ", status.message(), " expected to contain: ", part);
    CHECK(status.message().find(part) != std::string::npos);
  }
}

TEST_CASE("dataset spec: a plain directory and a FIRST-LAST range are parsed") {
  auto plain = ParseRobotDatasetSpec("data/seq_05");
  REQUIRE(plain.ok());
  CHECK(plain->dir == "data/seq_05");
  CHECK_FALSE(plain->has_range);
  CHECK(plain->first_scan == 0);
  CHECK(plain->end_scan == 0);

  auto ranged = ParseRobotDatasetSpec("/abs/data/seq_05:120-480");
  REQUIRE(ranged.ok());
  CHECK(ranged->dir == "/abs/data/seq_05");
  CHECK(ranged->has_range);
  CHECK(ranged->first_scan == 120);
  CHECK(ranged->end_scan == 480);

  auto one = ParseRobotDatasetSpec("d:0-1");
  REQUIRE(one.ok());
  CHECK(one->dir == "d");
  CHECK(one->first_scan == 0);
  CHECK(one->end_scan == 1);
}

TEST_CASE("dataset spec: empty, reversed and malformed ranges are refused naming the argument") {
  struct Case {
    const char* argument;
    const char* part;
  };
  const Case cases[] = {
      {"DIR:5-5", "is empty"},      {"DIR:6-5", "is empty"},     {"DIR:a-b", "FIRST-LAST"},
      {"DIR:3", "FIRST-LAST"},      {"DIR:-4", "FIRST-LAST"},    {"DIR:3-", "FIRST-LAST"},
      {"DIR:+1-3", "FIRST-LAST"},   {"DIR:1-2-3", "FIRST-LAST"}, {"DIR: 1-3", "FIRST-LAST"},
      {"DIR:", "FIRST-LAST"},       {":1-3", "empty directory"}, {"", "empty directory"},
  };
  for (const Case& c : cases) {
    INFO("argument: '", c.argument, "'");
    auto spec = ParseRobotDatasetSpec(c.argument);
    REQUIRE_FALSE(spec.ok());
    CheckErrorMentions(spec.status(), StatusCode::kInvalidArgument, {"'" + std::string(c.argument) + "'", c.part});
  }
}

TEST_CASE("dataset reader: scans in file-name order with poses, composed ground truth and times") {
  const std::string root = MakeFullDataset("full");
  auto d = OpenRobotDataset(Spec(root), false);
  REQUIRE_MESSAGE(d.ok(), d.status().ToString());
  CHECK(d->name == root);
  CHECK(d->first_scan == 0);
  REQUIRE(d->scan_files.size() == kScans);
  REQUIRE(d->poses.size() == kScans);
  REQUIRE(d->ground_truth.size() == kScans);
  REQUIRE(d->times_s.size() == kScans);
  for (std::size_t k = 0; k < kScans; ++k) {
    INFO("scan ", k);
    CHECK(fs::path(d->scan_files[k]) == fs::path(ScanPath(root, k)));
    auto scan = ReadKittiBin(d->scan_files[k]);  // the file's content identifies it
    REQUIRE(scan.ok());
    REQUIRE(scan->points.size() == k % 3 + 1);
    CHECK(static_cast<double>(scan->points[0].x) == static_cast<double>(k));
    CheckPose(d->poses[k], Estimated(k));
    CheckPose(d->ground_truth[k], ExpectedGt(k));
    CHECK(d->times_s[k] == TimeOf(k));
  }
  // A spot check of the composition, written out: scan 3 is at (10, 23, 0) with yaw 120 deg.
  CHECK(d->ground_truth[3].translation().x() == doctest::Approx(10.0));
  CHECK(d->ground_truth[3].translation().y() == doctest::Approx(23.0));
  CHECK(d->ground_truth[3].linear()(0, 0) == doctest::Approx(-0.5));
  CHECK(d->ground_truth[3].linear()(1, 0) == doctest::Approx(std::sqrt(3.0) / 2.0));
  CHECK(d->ground_truth_source.find("poses_gt.txt") != std::string::npos);
  CHECK(d->ground_truth_source.find("T_gt_robotstart.txt") != std::string::npos);
}

TEST_CASE("dataset reader: a range keeps scans FIRST to LAST-1 and slices poses, ground truth and times alike") {
  const std::string root = MakeFullDataset("range");
  struct Range {
    std::size_t first, end;
  };
  for (const Range r : {Range{2, 5}, Range{0, 1}, Range{3, kScans}, Range{0, kScans}}) {
    const std::string argument = root + ":" + std::to_string(r.first) + "-" + std::to_string(r.end);
    INFO("argument ", argument);
    auto d = OpenRobotDataset(Spec(argument), false);
    REQUIRE_MESSAGE(d.ok(), d.status().ToString());
    const std::size_t n = r.end - r.first;
    CHECK(d->name == argument);
    CHECK(d->first_scan == r.first);
    REQUIRE(d->scan_files.size() == n);
    REQUIRE(d->poses.size() == n);
    REQUIRE(d->ground_truth.size() == n);
    REQUIRE(d->times_s.size() == n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = r.first + i;
      CHECK(fs::path(d->scan_files[i]) == fs::path(ScanPath(root, k)));
      CheckPose(d->poses[i], Estimated(k));  // as in the file, not re-based on the slice
      CheckPose(d->ground_truth[i], ExpectedGt(k));
      CHECK(d->times_s[i] == TimeOf(k));
    }
  }
}

TEST_CASE("dataset reader: poses_gt.txt without T_gt_robotstart.txt is the ground truth as it is") {
  const std::string root = MakeFullDataset("gt_plain");
  REQUIRE(fs::remove(root + "/T_gt_robotstart.txt"));
  auto d = OpenRobotDataset(Spec(root + ":1-4"), false);
  REQUIRE_MESSAGE(d.ok(), d.status().ToString());
  REQUIRE(d->ground_truth.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CheckPose(d->ground_truth[i], Truth(1 + i));
  CHECK(fs::path(d->ground_truth_source) == fs::path(root + "/poses_gt.txt"));
}

TEST_CASE("dataset reader: the older name T_world_robotstart.txt composes the ground truth the same way") {
  const std::string root = MakeFullDataset("gt_old_name");
  fs::rename(root + "/T_gt_robotstart.txt", root + "/T_world_robotstart.txt");
  auto d = OpenRobotDataset(Spec(root + ":1-4"), false);
  REQUIRE_MESSAGE(d.ok(), d.status().ToString());
  REQUIRE(d->ground_truth.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CheckPose(d->ground_truth[i], ExpectedGt(1 + i));
  CHECK(d->ground_truth_source.find("T_world_robotstart.txt") != std::string::npos);

  // With both names present, T_gt_robotstart.txt is used (here: the identity, so gt = poses_gt.txt).
  WriteText(root + "/T_gt_robotstart.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  auto both = OpenRobotDataset(Spec(root + ":1-4"), false);
  REQUIRE_MESSAGE(both.ok(), both.status().ToString());
  REQUIRE(both->ground_truth.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CheckPose(both->ground_truth[i], Truth(1 + i));
  CHECK(both->ground_truth_source.find("T_gt_robotstart.txt") != std::string::npos);
  CHECK(both->ground_truth_source.find("T_world_robotstart.txt") == std::string::npos);
}

TEST_CASE("dataset reader: poses_lidar.txt is accepted as the poses file, poses.txt is preferred") {
  const std::string root = MakeScans("lidar_alias", kScans);
  WriteText(root + "/poses_lidar.txt", PosesText(kScans, &Estimated));
  auto d = OpenRobotDataset(Spec(root + ":1-3"), false);
  REQUIRE_MESSAGE(d.ok(), d.status().ToString());
  REQUIRE(d->poses.size() == 2);
  CheckPose(d->poses[0], Estimated(1));
  CheckPose(d->poses[1], Estimated(2));
  CHECK(d->ground_truth.empty());
  CHECK(d->times_s.empty());

  WriteText(root + "/poses.txt", PosesText(kScans, &Truth));
  auto both = OpenRobotDataset(Spec(root + ":1-3"), false);
  REQUIRE(both.ok());
  CheckPose(both->poses[0], Truth(1));
}

TEST_CASE("dataset reader: gt_from_poses takes the sliced poses file as ground truth only without poses_gt.txt") {
  const std::string root = MakeScans("gt_from_poses", kScans);
  WriteText(root + "/poses.txt", PosesText(kScans, &Estimated));

  auto without = OpenRobotDataset(Spec(root + ":1-4"), false);
  REQUIRE(without.ok());
  CHECK(without->ground_truth.empty());
  CHECK(without->ground_truth_source.empty());

  auto with = OpenRobotDataset(Spec(root + ":1-4"), true);
  REQUIRE_MESSAGE(with.ok(), with.status().ToString());
  REQUIRE(with->ground_truth.size() == 3);
  REQUIRE(with->poses.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) {
    CheckPose(with->ground_truth[i], Estimated(1 + i));
    CheckPose(with->poses[i], Estimated(1 + i));
  }
  CHECK(with->ground_truth_source.find("poses.txt") != std::string::npos);
  CHECK(with->ground_truth_source.find("--gt-from-poses") != std::string::npos);

  // A poses_gt.txt wins over --gt-from-poses.
  WriteText(root + "/poses_gt.txt", PosesText(kScans, &Truth));
  auto gt = OpenRobotDataset(Spec(root + ":1-4"), true);
  REQUIRE(gt.ok());
  REQUIRE(gt->ground_truth.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CheckPose(gt->ground_truth[i], Truth(1 + i));
  CHECK(gt->ground_truth_source.find("--gt-from-poses") == std::string::npos);
}

TEST_CASE("dataset reader: a times.txt with the wrong count is ignored") {
  const std::string root = MakeFullDataset("times");
  for (std::size_t lines : {kScans - 1, kScans + 1, std::size_t{0}}) {
    INFO("times.txt lines: ", lines);
    WriteText(root + "/times.txt", TimesText(lines));
    auto d = OpenRobotDataset(Spec(root + ":1-3"), false);
    REQUIRE_MESSAGE(d.ok(), d.status().ToString());
    CHECK(d->times_s.empty());
    CHECK(d->scan_files.size() == 2);
    CHECK(d->ground_truth.size() == 2);
  }
}

TEST_CASE("dataset reader: missing pieces and mismatched counts are refused naming the file") {
  SUBCASE("no directory at all") {
    const std::string root = test::ScratchDir() + "/kdr_does_not_exist";
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kNotFound, {root, "velodyne/"});
  }
  SUBCASE("no velodyne/") {
    const std::string root = test::ScratchDir() + "/kdr_no_velodyne";
    fs::create_directories(root);
    WriteText(root + "/poses.txt", PosesText(2, &Estimated));
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kNotFound, {root, "no velodyne/"});
  }
  SUBCASE("velodyne/ without a .bin") {
    const std::string root = MakeScans("no_bin", 0);
    WriteText(root + "/poses.txt", PosesText(2, &Estimated));
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kNotFound, {root, "velodyne/", "no .bin"});
  }
  SUBCASE("no poses file") {
    const std::string root = MakeScans("no_poses", kScans);
    WriteText(root + "/poses_gt.txt", PosesText(kScans, &Truth));
    auto d = OpenRobotDataset(Spec(root), true);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kNotFound, {root, "poses.txt", "poses_lidar.txt"});
  }
  SUBCASE("fewer poses than scans") {
    const std::string root = MakeScans("few_poses", kScans);
    WriteText(root + "/poses.txt", PosesText(kScans - 1, &Estimated));
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kInvalidArgument, {fs::path(root + "/poses.txt").string(), "5 poses", "6 scans"});
  }
  SUBCASE("more poses than scans, in poses_lidar.txt") {
    const std::string root = MakeScans("many_poses", kScans);
    WriteText(root + "/poses_lidar.txt", PosesText(kScans + 2, &Estimated));
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kInvalidArgument, {"poses_lidar.txt", "8 poses", "6 scans"});
  }
  SUBCASE("poses_gt.txt count differs") {
    const std::string root = MakeFullDataset("few_gt");
    WriteText(root + "/poses_gt.txt", PosesText(kScans - 2, &Truth));
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kInvalidArgument, {"poses_gt.txt", "4 poses", "6 scans"});
  }
  SUBCASE("T_gt_robotstart.txt with two poses") {
    const std::string root = MakeFullDataset("two_starts");
    WriteText(root + "/T_gt_robotstart.txt", std::string(kStartLine) + kStartLine);
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kInvalidArgument, {"T_gt_robotstart.txt", "exactly one", "found 2"});
  }
  SUBCASE("a malformed poses file") {
    const std::string root = MakeScans("bad_poses", 2);
    WriteText(root + "/poses.txt", PoseLine(Estimated(0)) + "1 0 0 0 0 1 0 0 0 0 1\n");
    auto d = OpenRobotDataset(Spec(root), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kDataLoss, {"poses.txt", "line 2"});
  }
}

TEST_CASE("dataset reader: a range beyond the scans is refused naming the argument") {
  const std::string root = MakeFullDataset("beyond");
  for (const char* range : {":4-7", ":6-7", ":10-20", ":0-7"}) {
    const std::string argument = root + range;
    INFO("argument ", argument);
    auto d = OpenRobotDataset(Spec(argument), false);
    REQUIRE_FALSE(d.ok());
    CheckErrorMentions(d.status(), StatusCode::kInvalidArgument, {argument, "range exceeds", "6 scans"});
  }
}

TEST_CASE("dataset reader: a reversed or empty range built by hand is refused, not sliced") {
  const std::string root = MakeFullDataset("reversed");
  RobotDatasetSpec spec;
  spec.dir = root;
  spec.has_range = true;
  spec.first_scan = 4;
  spec.end_scan = 2;
  auto d = OpenRobotDataset(spec, false);
  REQUIRE_FALSE(d.ok());
  CHECK(d.status().code() == StatusCode::kInvalidArgument);
  spec.end_scan = 4;
  CHECK_FALSE(OpenRobotDataset(spec, false).ok());
}

TEST_CASE("dataset spec: a colon inside the path is part of the directory") {
  const RobotDatasetSpec a = Spec("/mnt/run:2/seq");
  CHECK(a.dir == "/mnt/run:2/seq");
  CHECK_FALSE(a.has_range);
  const RobotDatasetSpec b = Spec("/mnt/run:2/seq:3-9");
  CHECK(b.dir == "/mnt/run:2/seq");
  CHECK(b.has_range);
  CHECK(b.first_scan == 3);
  CHECK(b.end_scan == 9);
  const RobotDatasetSpec c = Spec("data:v2/");
  CHECK(c.dir == "data:v2/");
  CHECK_FALSE(c.has_range);
}

}  // namespace
}  // namespace commerge::platform
