// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the PCD reader (platform/io/pcd.hpp): the input is a whole .pcd file. ReadPcd takes a
// path, so each input is written to a per-process temporary file (TempInputFile: /dev/shm, else $TMPDIR, else
// /tmp, with the pid in its name; rewritten per input, removed at exit) and read from there. Every input must be
// read or refused, never crash (ASan, UBSan). Also checked, for every input:
//   * a refusal is a Status whose message starts with the path;
//   * an accepted cloud has finite points only, records_in_file == points + dropped_nonfinite (so
//     records_in_file >= points.size()), and robot_ids empty or one per point;
//   * no single allocation exceeds kPcdAllocationBound(size). The reader checks every count against the file size
//     before it allocates: ascii at most one point per 2 bytes, binary one per record (at least 3 bytes: x y z of
//     SIZE 1), binary_compressed at most kLzfMaxExpansion (88) x the compressed bytes, which fit in the file, and
//     the compressed block, its column and record buffers and the file's text are each at most that. Its largest
//     block is then the points vector of binary_compressed: 16 bytes per point, 88 / 3 points per file byte, i.e.
//     ~470 x the input; + 64 KiB of slack (stdio buffers, header strings).
// Seeds: tests/fuzz/ros_seeds.py (SEEDS/pcd/: ascii, binary, and a binary_compressed file written by PCL).
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/cloud/point.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/lzf.hpp"
#include "platform/io/pcd.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {
namespace {

/// The smallest record that holds x, y and z [bytes]: three fields of SIZE 1.
constexpr std::size_t kMinRecordBytes = 3;

/// The largest single allocation allowed for an input of `size` bytes (see the comment at the top).
std::size_t PcdAllocationBound(std::size_t size) {
  const std::size_t decompressed = static_cast<std::size_t>(platform::kLzfMaxExpansion) * size;
  const std::size_t points = decompressed / kMinRecordBytes + 1;
  return std::max(decompressed, points * sizeof(PointXYZI)) + (std::size_t{64} << 10);
}

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

/// A static object: destroyed (the file removed) when libFuzzer exits normally.
const TempInputFile& InputFile() {
  static const TempInputFile file(".pcd");
  return file;
}

/// Fails unless the accepted `cloud` is consistent; returns a value that depends on every point.
double CheckCloud(const platform::PointCloudFile& cloud) {
  if (cloud.records_in_file < cloud.points.size()) {
    Fail("pcd: %zu points from %zu records in the file", cloud.points.size(), cloud.records_in_file);
  }
  if (cloud.records_in_file != cloud.points.size() + cloud.dropped_nonfinite) {
    Fail("pcd: %zu records in the file, but %zu points + %zu dropped as non-finite", cloud.records_in_file,
         cloud.points.size(), cloud.dropped_nonfinite);
  }
  if (!cloud.robot_ids.empty() && cloud.robot_ids.size() != cloud.points.size()) {
    Fail("pcd: %zu robot ids for %zu points", cloud.robot_ids.size(), cloud.points.size());
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const PointXYZI& p = cloud.points[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      Fail("pcd: point %zu of %zu is not finite (%g %g %g)", i, cloud.points.size(), static_cast<double>(p.x),
           static_cast<double>(p.y), static_cast<double>(p.z));
    }
    sum += static_cast<double>(p.x) + static_cast<double>(p.intensity);
  }
  return sum;
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  const TempInputFile& file = InputFile();
  file.Write(data, size);
  const std::size_t bound = PcdAllocationBound(size);
  const bool watched = AllocationWatch::Available();
  AllocationWatch watch;
  {
    Result<platform::PointCloudFile> cloud = platform::ReadPcd(file.path());
    if (!cloud.ok()) {
      const std::string& m = cloud.status().message();
      if (m.compare(0, file.path().size(), file.path()) != 0) {
        Fail("pcd: ReadPcd refused the input with '%s', which does not start with the path %s",
             cloud.status().ToString().c_str(), file.path().c_str());
      }
    } else {
      volatile double sink = CheckCloud(*cloud);
      (void)sink;
    }
  }
  if (watched && watch.largest_bytes() > bound) {
    Fail("pcd: reading %zu bytes allocated one block of %zu bytes, above the bound of %zu", size,
         watch.largest_bytes(), bound);
  }
  return 0;
}
