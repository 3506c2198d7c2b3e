// SPDX-License-Identifier: BSD-3-Clause
// commerge: a ScanSpillSink that appends spilled scans to one file, with an in-memory index of offsets.
//
// File layout (created empty, truncating an older file of the same name; every integer little-endian):
//   records, back to back: [magic 'C' 'M' 'S' 'P'][keyframe_index u32][encoded_bytes u32][encoded scan]
// The encoded scan carries its own CRC-32 (core/cloud/scan_codec.hpp), which ScanStore checks on load; Load
// here checks the record header against the index. The file is scratch for one run: it is not reopened
// after a restart (no recovery scan) and it is left on disk when the sink is destroyed.
// Memory: the index grows by 16 B per spilled scan (reserve it with `expected_scans`); Load resizes the
// caller's vector. Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/io/file_util.hpp"

namespace commerge::platform {

struct ScanSpillFileOptions {
  std::string file_name = "scan_spill.bin";  ///< created inside the directory given to Open()
  std::uint64_t max_file_bytes = 0;          ///< 0 = unlimited; a Spill that would grow the file beyond it fails
  std::size_t expected_scans = 0;            ///< index entries reserved up front
};

class ScanSpillFile final : public ScanSpillSink {
 public:
  static constexpr std::size_t kRecordHeaderBytes = 12;  ///< magic + keyframe index + size

  /// Creates (truncates) `directory`/`options.file_name` for reading and writing. Errors name the path:
  /// not found or i/o error (missing or read-only directory, ...), invalid argument (empty file name).
  static Result<std::unique_ptr<ScanSpillFile>> Open(const std::string& directory,
                                                     const ScanSpillFileOptions& options = {});

  ScanSpillFile(const ScanSpillFile&) = delete;
  ScanSpillFile& operator=(const ScanSpillFile&) = delete;
  ~ScanSpillFile() override = default;

  /// Appends one record and flushes it to the OS. `keyframe_index` must be greater than every one spilled
  /// before (invalid argument otherwise). I/O errors (full disk, ...) name the path; the failed record is
  /// not indexed and the next Spill overwrites its remains. Resource exhausted beyond max_file_bytes.
  Status Spill(std::uint32_t keyframe_index, Span<const std::uint8_t> encoded) override;

  /// Reads the record of `keyframe_index` into `*encoded`. NotFound when it was never spilled here; data loss
  /// when the record header on disk does not match the index; i/o errors name the path.
  Status Load(std::uint32_t keyframe_index, std::vector<std::uint8_t>* encoded) override;

  const std::string& path() const noexcept { return path_; }
  std::size_t num_records() const noexcept { return index_.size(); }
  /// Bytes of complete records in the file.
  std::uint64_t file_bytes() const noexcept { return end_; }

 private:
  struct Entry {
    std::uint32_t keyframe_index;
    std::uint32_t encoded_bytes;
    std::uint64_t offset;  // of the record header
  };

  ScanSpillFile(std::string path, FilePtr file, const ScanSpillFileOptions& options);

  std::string path_;
  FilePtr file_;
  std::uint64_t max_file_bytes_ = 0;
  std::uint64_t end_ = 0;
  std::vector<Entry> index_;  // increasing keyframe_index
};

}  // namespace commerge::platform
