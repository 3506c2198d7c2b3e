// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/file_util.hpp"

#include <cerrno>
#include <cstring>
#include <sys/stat.h>

namespace commerge::platform {

Result<FilePtr> OpenForRead(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    const int err = errno;
    if (err == ENOENT) return NotFound(path + ": no such file");
    return IoError(path + ": cannot open for reading: " + std::strerror(err));
  }
  struct stat st {};
  if (fstat(fileno(f), &st) == 0 && S_ISDIR(st.st_mode)) {
    std::fclose(f);
    return InvalidArgument(path + ": is a directory, expected a file");
  }
  return FilePtr(f);
}

Result<FilePtr> OpenForWrite(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return IoError(path + ": cannot open for writing: " + std::strerror(errno));
  return FilePtr(f);
}

Status CloseChecked(FilePtr file, const std::string& path) {
  std::FILE* f = file.release();
  const bool flush_failed = std::fflush(f) != 0 || std::ferror(f) != 0;
  const int close_rc = std::fclose(f);
  if (flush_failed || close_rc != 0) return IoError(path + ": write failed: " + std::strerror(errno));
  return Status::Ok();
}

Result<std::uint64_t> FileSize(std::FILE* f, const std::string& path) {
  struct stat st {};
  if (fstat(fileno(f), &st) != 0) return IoError(path + ": cannot stat: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) return InvalidArgument(path + ": not a regular file");
  return static_cast<std::uint64_t>(st.st_size);
}

std::string ShortReadReason(std::FILE* f) {
  if (std::feof(f) && !std::ferror(f)) return "unexpected end of file (did it change while being read?)";
  return std::strerror(errno);
}

Result<std::string> ReadTextFile(const std::string& path) {
  auto file = OpenForRead(path);
  if (!file.ok()) return file.status();
  auto size = FileSize(file->get(), path);
  if (!size.ok()) return size.status();
  std::string text(static_cast<std::size_t>(*size), '\0');
  if (!text.empty() && std::fread(&text[0], 1, text.size(), file->get()) != text.size()) {
    return IoError(path + ": read failed: " + ShortReadReason(file->get()));
  }
  return text;
}

std::size_t DropNonFinite(std::vector<PointXYZI>* points, std::vector<std::uint16_t>* robot_ids) {
  const bool with_ids = robot_ids && !robot_ids->empty();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < points->size(); ++i) {
    if (!IsFinite((*points)[i])) continue;
    (*points)[kept] = (*points)[i];
    if (with_ids) (*robot_ids)[kept] = (*robot_ids)[i];
    ++kept;
  }
  const std::size_t dropped = points->size() - kept;
  points->resize(kept);
  if (with_ids) robot_ids->resize(kept);
  return dropped;
}

}  // namespace commerge::platform
