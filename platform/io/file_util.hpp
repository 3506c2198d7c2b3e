// SPDX-License-Identifier: BSD-3-Clause
// Small helpers shared by the file readers and writers in platform/io.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

struct FileCloser {
  void operator()(std::FILE* f) const noexcept {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

/// fopen(path, "rb"); errors: not found (names the path), or i/o error with strerror.
Result<FilePtr> OpenForRead(const std::string& path);
/// fopen(path, "wb"); errors name the path and strerror.
Result<FilePtr> OpenForWrite(const std::string& path);
/// fclose with error check (a full disk shows up here).
Status CloseChecked(FilePtr file, const std::string& path);
/// Size of an open regular file in bytes (fstat; the file position is not changed).
Result<std::uint64_t> FileSize(std::FILE* f, const std::string& path);
/// Why a short fread happened: "unexpected end of file (...)" or strerror(errno).
std::string ShortReadReason(std::FILE* f);
/// Whole file as text (for line-based formats).
Result<std::string> ReadTextFile(const std::string& path);

/// Removes points with a non-finite x, y or z, in place and order-preserving; when `robot_ids` is
/// non-null and non-empty it is filtered alongside. Returns the number removed.
std::size_t DropNonFinite(std::vector<PointXYZI>* points, std::vector<std::uint16_t>* robot_ids);

}  // namespace commerge::platform
