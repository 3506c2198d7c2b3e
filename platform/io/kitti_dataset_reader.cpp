// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/kitti_dataset_reader.hpp"

#include <algorithm>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <system_error>

#include "platform/io/poses.hpp"

namespace commerge::platform {

namespace fs = std::filesystem;

namespace {

bool ParseIndex(const std::string& s, std::size_t* out) {
  if (s.empty() || s.size() > 12) return false;
  std::size_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + static_cast<std::size_t>(c - '0');
  }
  *out = v;
  return true;
}

}  // namespace

Result<RobotDatasetSpec> ParseRobotDatasetSpec(const std::string& argument) {
  RobotDatasetSpec spec;
  spec.dir = argument;
  // The last ':' starts a range unless a '/' follows it (a ':' inside a path, e.g. /mnt/run:2/seq). A last
  // path component containing ':' must therefore be written with a trailing '/'.
  const std::size_t colon = argument.rfind(':');
  if (colon != std::string::npos && argument.find('/', colon) == std::string::npos) {
    const std::string range = argument.substr(colon + 1);
    const std::size_t dash = range.find('-');
    std::size_t first = 0, last = 0;
    if (dash == std::string::npos || range.find('-', dash + 1) != std::string::npos ||
        !ParseIndex(range.substr(0, dash), &first) || !ParseIndex(range.substr(dash + 1), &last)) {
      return InvalidArgument("dataset '" + argument + "': the part after ':' must be FIRST-LAST (scan indices)");
    }
    if (first >= last) {
      return InvalidArgument("dataset '" + argument + "': range " + std::to_string(first) + "-" + std::to_string(last) +
                             " is empty (LAST is exclusive and must exceed FIRST)");
    }
    spec.dir = argument.substr(0, colon);
    spec.first_scan = first;
    spec.end_scan = last;
    spec.has_range = true;
  }
  if (spec.dir.empty()) return InvalidArgument("dataset '" + argument + "': empty directory");
  return spec;
}

Result<RobotDataset> OpenRobotDataset(const RobotDatasetSpec& spec, bool gt_from_poses, const std::string& odometry_file) {
  RobotDataset d;
  d.name = spec.dir + (spec.has_range ? ":" + std::to_string(spec.first_scan) + "-" + std::to_string(spec.end_scan) : "");
  std::error_code ec;
  const fs::path velodyne = fs::path(spec.dir) / "velodyne";
  if (!fs::is_directory(velodyne, ec)) {
    return NotFound("dataset " + spec.dir + ": no velodyne/ directory (expected KITTI layout: velodyne/*.bin, "
                    "poses.txt)");
  }
  std::vector<std::string> files;
  for (fs::directory_iterator it(velodyne, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().extension() == ".bin") files.push_back(it->path().string());
  }
  if (ec) return IoError("dataset " + spec.dir + ": cannot list " + velodyne.string() + ": " + ec.message());
  std::sort(files.begin(), files.end());
  if (files.empty()) return NotFound("dataset " + spec.dir + ": velodyne/ holds no .bin scan");

  std::string poses_path = (fs::path(spec.dir) / "poses.txt").string();
  if (!fs::exists(poses_path, ec)) {
    const std::string alt = (fs::path(spec.dir) / "poses_lidar.txt").string();
    if (!fs::exists(alt, ec)) {
      return NotFound("dataset " + spec.dir + ": neither poses.txt nor poses_lidar.txt (one KITTI-12 pose per scan)");
    }
    poses_path = alt;
  }
  auto poses = ReadKittiPoses(poses_path);
  if (!poses.ok()) return poses.status();
  if (poses->size() != files.size()) {
    return InvalidArgument("dataset " + spec.dir + ": " + poses_path + " has " + std::to_string(poses->size()) +
                           " poses for " + std::to_string(files.size()) + " scans in velodyne/");
  }
  std::vector<Eigen::Isometry3d> reference;  // poses.txt when the odometry comes from another file
  if (!odometry_file.empty()) {
    const std::string odometry_path = (fs::path(spec.dir) / odometry_file).string();
    auto odometry = ReadKittiPoses(odometry_path);
    if (!odometry.ok()) return odometry.status();
    if (odometry->size() != files.size()) {
      return InvalidArgument("dataset " + spec.dir + ": " + odometry_path + " has " + std::to_string(odometry->size()) +
                             " poses for " + std::to_string(files.size()) + " scans in velodyne/");
    }
    reference = std::move(*poses);
    *poses = std::move(*odometry);
  }
  std::vector<Eigen::Isometry3d> gt;
  const std::string gt_path = (fs::path(spec.dir) / "poses_gt.txt").string();
  if (fs::exists(gt_path, ec)) {
    auto g = ReadKittiPoses(gt_path);
    if (!g.ok()) return g.status();
    if (g->size() != files.size()) {
      return InvalidArgument("dataset " + spec.dir + ": " + gt_path + " has " + std::to_string(g->size()) +
                             " poses for " + std::to_string(files.size()) + " scans");
    }
    gt = std::move(*g);
    d.ground_truth_source = gt_path;
    // T_gt_robotstart.txt, or under its older name T_world_robotstart.txt (same content).
    for (const char* start_name : {"T_gt_robotstart.txt", "T_world_robotstart.txt"}) {
      const std::string start_path = (fs::path(spec.dir) / start_name).string();
      if (!fs::exists(start_path, ec)) continue;
      auto s = ReadKittiPoses(start_path);
      if (!s.ok()) return s.status();
      if (s->size() != 1) return InvalidArgument(start_path + ": expected exactly one pose, found " + std::to_string(s->size()));
      for (Eigen::Isometry3d& T : gt) T = (*s)[0] * T;
      d.ground_truth_source += std::string(" (with ") + start_name + ")";
      break;
    }
  } else if (gt_from_poses) {
    gt = reference.empty() ? *poses : reference;
    d.ground_truth_source = poses_path + " (--gt-from-poses)";
  }
  std::vector<double> times;
  const std::string times_path = (fs::path(spec.dir) / "times.txt").string();
  if (fs::exists(times_path, ec)) {
    auto t = ReadTimes(times_path);
    if (!t.ok()) return t.status();
    if (t->size() == files.size()) times = std::move(*t);  // a mismatching times.txt is ignored (times optional)
  }
  const std::size_t first = spec.first_scan;
  const std::size_t end = spec.has_range ? spec.end_scan : files.size();
  if (first >= end || first >= files.size() || end > files.size()) {
    return InvalidArgument("dataset " + d.name + ": range exceeds the " + std::to_string(files.size()) + " scans");
  }
  d.first_scan = first;
  const auto b = static_cast<std::ptrdiff_t>(first), e = static_cast<std::ptrdiff_t>(end);
  d.scan_files.assign(files.begin() + b, files.begin() + e);
  d.poses.assign(poses->begin() + b, poses->begin() + e);
  if (!gt.empty()) d.ground_truth.assign(gt.begin() + b, gt.begin() + e);
  if (!times.empty()) d.times_s.assign(times.begin() + b, times.begin() + e);
  return d;
}

}  // namespace commerge::platform
