// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/point_cloud_file.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "platform/io/pcd.hpp"
#include "platform/io/ply.hpp"

namespace commerge::platform {

namespace {

std::string LowercaseExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

Status UnknownExtension(const std::string& path) {
  return InvalidArgument(path + ": unknown point-cloud extension; supported: .bin (KITTI), .pcd, .ply");
}

}  // namespace

Result<PointCloudFile> ReadPointCloud(const std::string& path) {
  const std::string ext = LowercaseExtension(path);
  if (ext == ".bin") return ReadKittiBin(path);
  if (ext == ".pcd") return ReadPcd(path);
  if (ext == ".ply") return ReadPly(path);
  return UnknownExtension(path);
}

Status WritePointCloud(const std::string& path, Span<const PointXYZI> points, Span<const std::uint16_t> robot_ids) {
  const std::string ext = LowercaseExtension(path);
  if (ext == ".bin") {
    if (!robot_ids.empty()) {
      return InvalidArgument(path + ": a KITTI .bin scan has no field for robot ids; write .pcd or .ply to keep them");
    }
    return WriteKittiBin(path, points);
  }
  if (ext == ".pcd") return WritePcd(path, points, PcdEncoding::kBinary, robot_ids);
  if (ext == ".ply") return WritePly(path, points, robot_ids);
  return UnknownExtension(path);
}

}  // namespace commerge::platform
