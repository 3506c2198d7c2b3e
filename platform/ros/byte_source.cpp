// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/byte_source.hpp"

#include <sys/types.h>

#include <cerrno>
#include <cstring>

#include "platform/io/file_util.hpp"

namespace commerge::platform {

namespace {

static_assert(sizeof(off_t) >= 8, "FileByteSource needs a 64-bit off_t (_FILE_OFFSET_BITS=64)");

/// The range [offset, offset + n) lies inside a source of `size` bytes (no overflow).
bool RangeInsideSource(std::uint64_t offset, std::size_t n, std::uint64_t size) noexcept {
  return offset <= size && static_cast<std::uint64_t>(n) <= size - offset;
}

Status SourceTruncated(const std::string& name, std::uint64_t offset, std::size_t n, std::uint64_t size) {
  return DataLoss(name + ": truncated: wanted " + std::to_string(n) + " bytes at offset " + std::to_string(offset) +
                  ", the source has " + std::to_string(size));
}

}  // namespace

Status MemoryByteSource::ReadAt(std::uint64_t offset, std::size_t n, std::uint8_t* out) {
  if (!RangeInsideSource(offset, n, bytes_.size())) return SourceTruncated(name_, offset, n, bytes_.size());
  if (n != 0) std::memcpy(out, bytes_.data() + offset, n);
  return Status::Ok();
}

Result<std::unique_ptr<FileByteSource>> FileByteSource::Open(const std::string& path) {
  auto file = OpenForRead(path);
  if (!file.ok()) return file.status();
  std::FILE* f = file->get();
  if (fseeko(f, 0, SEEK_END) != 0) return IoError(path + ": cannot seek to the end: " + std::strerror(errno));
  const off_t end = ftello(f);
  if (end < 0) return IoError(path + ": cannot tell the file size: " + std::strerror(errno));
  return std::unique_ptr<FileByteSource>(
      new FileByteSource(file->release(), path, static_cast<std::uint64_t>(end)));
}

FileByteSource::~FileByteSource() {
  if (f_) std::fclose(f_);
}

Status FileByteSource::ReadAt(std::uint64_t offset, std::size_t n, std::uint8_t* out) {
  if (!RangeInsideSource(offset, n, size_)) return SourceTruncated(path_, offset, n, size_);
  if (n == 0) return Status::Ok();
  if (fseeko(f_, static_cast<off_t>(offset), SEEK_SET) != 0) {
    return IoError(path_ + ": cannot seek to offset " + std::to_string(offset) + ": " + std::strerror(errno));
  }
  if (std::fread(out, 1, n, f_) != n) {
    const std::string reason = ShortReadReason(f_);
    std::clearerr(f_);
    return IoError(path_ + ": read of " + std::to_string(n) + " bytes at offset " + std::to_string(offset) +
                   " failed: " + reason);
  }
  return Status::Ok();
}

}  // namespace commerge::platform
