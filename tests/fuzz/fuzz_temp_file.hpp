// SPDX-License-Identifier: BSD-3-Clause
// The file a fuzz target writes each input to, for readers that take a path (tests/fuzz/fuzz_pcd.cpp,
// fuzz_rosbag2_db3.cpp): one per process, in /dev/shm when writable (else $TMPDIR, else /tmp), removed at exit.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {

/// The per-process file each input is written to; removed at exit.
class TempInputFile {
 public:
  explicit TempInputFile(const char* suffix) {
    const char* dir = "/dev/shm";
    if (access(dir, W_OK) != 0) {
      const char* tmp = std::getenv("TMPDIR");
      dir = tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
    }
    path_ = std::string(dir) + "/cm_fuzz_" + std::to_string(static_cast<long>(getpid())) + suffix;
  }
  ~TempInputFile() { std::remove(path_.c_str()); }
  TempInputFile(const TempInputFile&) = delete;
  TempInputFile& operator=(const TempInputFile&) = delete;

  const std::string& path() const noexcept { return path_; }

  /// Replaces the file's contents with the input.
  void Write(const std::uint8_t* data, std::size_t size) const {
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    if (f == nullptr) Fail("cannot create the input file %s", path_.c_str());
    const bool written = size == 0 || std::fwrite(data, 1, size, f) == size;
    if (std::fclose(f) != 0 || !written) Fail("cannot write %zu bytes to the input file %s", size, path_.c_str());
  }

 private:
  std::string path_;
};

}  // namespace commerge::fuzz
