// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/kitti_dataset_writer.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <system_error>
#include <vector>

#include "platform/io/kitti_bin.hpp"
#include "platform/io/poses.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::platform {

namespace fs = std::filesystem;

std::string SimRobotDirName(int robot) { return "robot_" + std::to_string(robot); }

std::string KittiScanFileName(std::size_t k) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu.bin", k);
  return name;
}

Status WriteTimes(const std::string& path, Span<const double> times_s) {
  std::string text;
  text.reserve(times_s.size() * 12);
  for (std::size_t i = 0; i < times_s.size(); ++i) {
    if (!std::isfinite(times_s[i])) {
      return InvalidArgument(path + ": time " + std::to_string(i) + " is not finite");
    }
    io_detail::AppendNumber(&text, times_s[i]);
    text.push_back('\n');
  }
  return io_detail::WriteTextFile(path, text);
}

Result<KittiDatasetWriter> KittiDatasetWriter::Create(const std::string& root, int robots, bool force) {
  if (robots < 1) return InvalidArgument("dataset writer: robots must be >= 1");
  if (root.empty()) return InvalidArgument("dataset writer: empty output directory");
  std::error_code ec;
  const fs::path dir(root);
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) return InvalidArgument(root + ": exists and is not a directory");
    const bool empty = fs::is_empty(dir, ec);
    if (ec) return IoError(root + ": cannot list: " + ec.message());
    if (!empty) {
      if (!force) {
        return Status(StatusCode::kInvalidArgument,
                      root + ": already exists and is not empty (use --force to replace the dataset in it)");
      }
      const std::regex robot_dir("robot_[0-9]+");
      std::vector<fs::path> doomed;
      for (const auto& entry : fs::directory_iterator(dir, ec)) {
        const std::string name = entry.path().filename().string();
        if (name == "sim_info.txt" || name == "start_transforms.txt" ||
            (std::regex_match(name, robot_dir) && entry.is_directory())) {
          doomed.push_back(entry.path());
        }
      }
      if (ec) return IoError(root + ": cannot list: " + ec.message());
      for (const fs::path& p : doomed) {
        fs::remove_all(p, ec);
        if (ec) return IoError(p.string() + ": cannot remove: " + ec.message());
      }
    }
  }
  for (int r = 0; r < robots; ++r) {
    const fs::path velodyne = dir / SimRobotDirName(r) / "velodyne";
    fs::create_directories(velodyne, ec);
    if (ec) return IoError(velodyne.string() + ": cannot create: " + ec.message());
  }
  return KittiDatasetWriter(root, robots);
}

std::string KittiDatasetWriter::RobotDir(int robot) const { return (fs::path(root_) / SimRobotDirName(robot)).string(); }

Status KittiDatasetWriter::WriteScan(int robot, std::size_t k, Span<const PointXYZI> points) const {
  if (robot < 0 || robot >= robots_) return InvalidArgument("dataset writer: no robot " + std::to_string(robot));
  return WriteKittiBin(RobotDir(robot) + "/velodyne/" + KittiScanFileName(k), points);
}

Status KittiDatasetWriter::WriteTrajectory(int robot, Span<const Eigen::Isometry3d> odometry,
                                           Span<const Eigen::Isometry3d> ground_truth, Span<const double> times_s,
                                           const Eigen::Isometry3d& T_gt_robotstart) const {
  if (robot < 0 || robot >= robots_) return InvalidArgument("dataset writer: no robot " + std::to_string(robot));
  if (odometry.size() != ground_truth.size() || times_s.size() != ground_truth.size()) {
    return InvalidArgument("dataset writer: robot " + std::to_string(robot) + ": " + std::to_string(odometry.size()) +
                           " odometry poses, " + std::to_string(ground_truth.size()) + " ground-truth poses and " +
                           std::to_string(times_s.size()) + " times differ");
  }
  const std::string dir = RobotDir(robot);
  if (Status st = WriteKittiPoses(dir + "/poses.txt", odometry); !st.ok()) return st;
  if (Status st = WriteKittiPoses(dir + "/poses_gt.txt", ground_truth); !st.ok()) return st;
  if (Status st = WriteTimes(dir + "/times.txt", times_s); !st.ok()) return st;
  if (Status st = WriteKittiPoses(dir + "/T_gt_robotstart.txt", Span<const Eigen::Isometry3d>(&T_gt_robotstart, 1));
      !st.ok()) {
    return st;
  }
  // KITTI's calib.txt: projection matrices are unused here; Tr (velodyne -> pose frame) is the identity.
  const std::string identity = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  return io_detail::WriteTextFile(dir + "/calib.txt", "P0: " + identity + "P1: " + identity + "P2: " + identity +
                                                          "P3: " + identity + "Tr: " + identity);
}

Status KittiDatasetWriter::WriteStartTransforms(Span<const Eigen::Isometry3d> T_gt_robotstart) const {
  return WriteKittiPoses(root_ + "/start_transforms.txt", T_gt_robotstart);
}

Status KittiDatasetWriter::WriteInfo(const std::string& text) const {
  return io_detail::WriteTextFile(root_ + "/sim_info.txt", text);
}

}  // namespace commerge::platform
