// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/kitti_bin.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "platform/io/file_util.hpp"

namespace commerge::platform {

namespace {

Result<std::size_t> RecordsOf(std::FILE* f, const std::string& path) {
  auto size = FileSize(f, path);
  if (!size.ok()) return size.status();
  const std::uint64_t bytes = *size;
  if (bytes % sizeof(PointXYZI) != 0) {
    return DataLoss(path + ": size " + std::to_string(bytes) + " bytes is not a multiple of the 16-byte KITTI " +
                    "record (x, y, z, intensity as float32); the file is truncated or not a KITTI scan");
  }
  return static_cast<std::size_t>(bytes / sizeof(PointXYZI));
}

}  // namespace

Result<std::size_t> KittiBinPointCount(const std::string& path) {
  auto file = OpenForRead(path);
  if (!file.ok()) return file.status();
  return RecordsOf(file->get(), path);
}

Result<PointCloudFile> ReadKittiBin(const std::string& path) {
  auto file = OpenForRead(path);
  if (!file.ok()) return file.status();
  std::FILE* f = file->get();
  auto records = RecordsOf(f, path);
  if (!records.ok()) return records.status();
  const std::uint64_t bytes = *records * sizeof(PointXYZI);
  PointCloudFile out;
  out.records_in_file = *records;
  out.points.resize(out.records_in_file);
  if (out.records_in_file > 0 &&
      std::fread(out.points.data(), sizeof(PointXYZI), out.records_in_file, f) != out.records_in_file) {
    return IoError(path + ": read of " + std::to_string(bytes) + " bytes failed: " + ShortReadReason(f));
  }
  out.dropped_nonfinite = DropNonFinite(&out.points, nullptr);
  return out;
}

Status WriteKittiBin(const std::string& path, Span<const PointXYZI> points) {
  auto file = OpenForWrite(path);
  if (!file.ok()) return file.status();
  if (!points.empty() && std::fwrite(points.data(), sizeof(PointXYZI), points.size(), file->get()) != points.size()) {
    return IoError(path + ": write failed: " + std::strerror(errno));
  }
  return CloseChecked(std::move(*file), path);
}

}  // namespace commerge::platform
