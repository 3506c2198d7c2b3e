// SPDX-License-Identifier: BSD-3-Clause
// Random-access bytes for the container readers (ROS 1 bags; later MCAP): a file read in pieces, or a buffer in
// memory (tests, fuzzers). A reader never holds more than the piece it asks for.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// Total size [bytes].
  virtual std::uint64_t size() const noexcept = 0;
  /// Copies `n` bytes at `offset` into `out`. Errors: the range ends past size() (DataLoss "truncated"), i/o.
  virtual Status ReadAt(std::uint64_t offset, std::size_t n, std::uint8_t* out) = 0;
  /// What to call the source in error messages (the file's path, or "<memory>").
  virtual const std::string& name() const noexcept = 0;
};

/// A buffer that must outlive the source.
class MemoryByteSource final : public ByteSource {
 public:
  MemoryByteSource(Span<const std::uint8_t> bytes, std::string name = "<memory>")
      : bytes_(bytes), name_(std::move(name)) {}
  std::uint64_t size() const noexcept override { return bytes_.size(); }
  Status ReadAt(std::uint64_t offset, std::size_t n, std::uint8_t* out) override;
  const std::string& name() const noexcept override { return name_; }

 private:
  Span<const std::uint8_t> bytes_;
  std::string name_;
};

/// A file opened for reading. Errors of Open name the path.
class FileByteSource final : public ByteSource {
 public:
  static Result<std::unique_ptr<FileByteSource>> Open(const std::string& path);
  ~FileByteSource() override;
  FileByteSource(const FileByteSource&) = delete;
  FileByteSource& operator=(const FileByteSource&) = delete;
  std::uint64_t size() const noexcept override { return size_; }
  Status ReadAt(std::uint64_t offset, std::size_t n, std::uint8_t* out) override;
  const std::string& name() const noexcept override { return path_; }

 private:
  FileByteSource(std::FILE* f, std::string path, std::uint64_t size) : f_(f), path_(std::move(path)), size_(size) {}
  std::FILE* f_ = nullptr;
  std::string path_;
  std::uint64_t size_ = 0;
};

}  // namespace commerge::platform
