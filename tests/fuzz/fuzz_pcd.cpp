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
#include "tests/fuzz/fuzz_temp_file.hpp"

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
