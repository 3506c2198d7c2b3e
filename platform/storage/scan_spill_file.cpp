// SPDX-License-Identifier: BSD-3-Clause
#include "platform/storage/scan_spill_file.hpp"

#include <sys/types.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <utility>

namespace commerge::platform {
namespace {

constexpr std::uint8_t kMagic[4] = {'C', 'M', 'S', 'P'};

void PutU32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFu);
}
std::uint32_t GetU32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

std::string Kf(std::uint32_t keyframe_index) { return "keyframe " + std::to_string(keyframe_index); }

bool SeekTo(std::FILE* f, std::uint64_t offset) {
  if (offset > static_cast<std::uint64_t>(std::numeric_limits<off_t>::max())) {
    errno = EOVERFLOW;
    return false;
  }
  return fseeko(f, static_cast<off_t>(offset), SEEK_SET) == 0;
}

}  // namespace

Result<std::unique_ptr<ScanSpillFile>> ScanSpillFile::Open(const std::string& directory,
                                                           const ScanSpillFileOptions& options) {
  if (options.file_name.empty() || options.file_name.find('/') != std::string::npos) {
    return InvalidArgument("scan spill file name '" + options.file_name + "' must be a plain, non-empty file name");
  }
  std::string path = directory.empty() ? options.file_name
                                       : (directory.back() == '/' ? directory : directory + "/") + options.file_name;
  std::FILE* f = std::fopen(path.c_str(), "w+b");
  if (f == nullptr) {
    const int err = errno;
    const std::string why = path + ": cannot create the scan spill file: " + std::strerror(err);
    if (err == ENOENT || err == ENOTDIR) return NotFound(why + " (does the directory '" + directory + "' exist?)");
    return IoError(why);
  }
  return Result<std::unique_ptr<ScanSpillFile>>(
      std::unique_ptr<ScanSpillFile>(new ScanSpillFile(std::move(path), FilePtr(f), options)));
}

ScanSpillFile::ScanSpillFile(std::string path, FilePtr file, const ScanSpillFileOptions& options)
    : path_(std::move(path)), file_(std::move(file)), max_file_bytes_(options.max_file_bytes) {
  index_.reserve(options.expected_scans);
}

Status ScanSpillFile::Spill(std::uint32_t keyframe_index, Span<const std::uint8_t> encoded) {
  if (!index_.empty() && keyframe_index <= index_.back().keyframe_index) {
    return InvalidArgument(path_ + ": cannot spill " + Kf(keyframe_index) + " after " +
                           Kf(index_.back().keyframe_index) + ": keyframe indices must increase");
  }
  if (encoded.size() > UINT32_MAX) {
    return InvalidArgument(path_ + ": " + Kf(keyframe_index) + ": scan of " + std::to_string(encoded.size()) +
                           " bytes exceeds the 4 GiB record limit");
  }
  const std::uint64_t record_bytes = kRecordHeaderBytes + encoded.size();
  if (max_file_bytes_ != 0 && end_ + record_bytes > max_file_bytes_) {
    return ResourceExhausted(path_ + ": spilling " + Kf(keyframe_index) + " (" + std::to_string(record_bytes) +
                             " B) would grow the file to " + std::to_string(end_ + record_bytes) +
                             " B, beyond its limit of " + std::to_string(max_file_bytes_) + " B");
  }
  std::FILE* f = file_.get();
  std::uint8_t header[kRecordHeaderBytes];
  std::memcpy(header, kMagic, 4);
  PutU32(header + 4, keyframe_index);
  PutU32(header + 8, static_cast<std::uint32_t>(encoded.size()));
  // Write at the end of the last complete record, so the remains of a failed write are overwritten.
  const bool ok = SeekTo(f, end_) && std::fwrite(header, 1, sizeof header, f) == sizeof header &&
                  (encoded.empty() || std::fwrite(encoded.data(), 1, encoded.size(), f) == encoded.size()) &&
                  std::fflush(f) == 0;
  if (!ok) {
    const int err = errno;
    std::clearerr(f);
    return IoError(path_ + ": cannot write the spilled scan of " + Kf(keyframe_index) + ": " + std::strerror(err));
  }
  index_.push_back(Entry{keyframe_index, static_cast<std::uint32_t>(encoded.size()), end_});
  end_ += record_bytes;
  return Status::Ok();
}

Status ScanSpillFile::Load(std::uint32_t keyframe_index, std::vector<std::uint8_t>* encoded) {
  if (encoded == nullptr) return InvalidArgument(path_ + ": Load: output vector is null");
  encoded->clear();
  const auto it = std::lower_bound(index_.begin(), index_.end(), keyframe_index,
                                   [](const Entry& e, std::uint32_t k) { return e.keyframe_index < k; });
  if (it == index_.end() || it->keyframe_index != keyframe_index) {
    return NotFound(path_ + ": " + Kf(keyframe_index) + " was never spilled to this file (" +
                    std::to_string(index_.size()) + " scans spilled)");
  }
  std::FILE* f = file_.get();
  std::uint8_t header[kRecordHeaderBytes];
  if (!SeekTo(f, it->offset) || std::fread(header, 1, sizeof header, f) != sizeof header) {
    const std::string why = ShortReadReason(f);
    std::clearerr(f);
    return IoError(path_ + ": cannot read the record of " + Kf(keyframe_index) + " at offset " +
                   std::to_string(it->offset) + ": " + why);
  }
  if (std::memcmp(header, kMagic, 4) != 0 || GetU32(header + 4) != keyframe_index ||
      GetU32(header + 8) != it->encoded_bytes) {
    return DataLoss(path_ + ": the record at offset " + std::to_string(it->offset) + " is not the one of " +
                    Kf(keyframe_index) + " (" + std::to_string(it->encoded_bytes) +
                    " B): the file was changed behind the sink's back");
  }
  encoded->resize(it->encoded_bytes);
  if (it->encoded_bytes != 0 && std::fread(encoded->data(), 1, encoded->size(), f) != encoded->size()) {
    const std::string why = ShortReadReason(f);
    std::clearerr(f);
    encoded->clear();
    return IoError(path_ + ": cannot read the spilled scan of " + Kf(keyframe_index) + ": " + why);
  }
  return Status::Ok();
}

}  // namespace commerge::platform
