// SPDX-License-Identifier: BSD-3-Clause
// Descriptor cost on one ~120k-point scan: SOLiD (R + A, unit R) and Scan Context per scan, plus the
// keyframe record codec and the SOLiD / Scan Context distances per pair.
// Usage: bench_descriptor [--reps N]   (default 30 timed calls after one warm-up call)
// Uses KITTI 00 frame 0 from the shared data when present, else a seeded synthetic LiDAR-like scan.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "platform/io/kitti_bin.hpp"

using commerge::PointXYZI;

namespace {

double MedianMs(std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  const std::size_t n = ms.size();
  return n % 2 ? ms[n / 2] : 0.5 * (ms[n / 2 - 1] + ms[n / 2]);
}

template <class F>
std::vector<double> Time(int reps, F&& f) {
  std::vector<double> ms(static_cast<std::size_t>(reps));
  for (double& t : ms) {
    const auto start = std::chrono::steady_clock::now();
    f();
    t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return ms;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 30;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--reps N]\n", argv[0]);
      return 2;
    }
  }
  if (reps < 1) {
    std::fprintf(stderr, "--reps must be >= 1\n");
    return 2;
  }

  const char* data_env = std::getenv("COMMERGE_SHARED_DATA");
  const std::string data_dir = data_env && *data_env ? data_env : CM_SHARED_DATA_DIR;
  const std::string kitti_path = data_dir + "/kitti/kitti00_frames0-15/velodyne/000000.bin";
  std::vector<PointXYZI> cloud;
  std::string source;
  if (auto scan = commerge::platform::ReadKittiBin(kitti_path); scan.ok()) {
    cloud = std::move(scan->points);
    source = "KITTI " + kitti_path;
  } else {
    commerge::CastScan(commerge::MakeStreetScene(42), commerge::SpinningLidar{}, 0.0f, 0.0f, 1.73f, 0.0f, 42, &cloud);
    source = "synthetic ray-cast street scan, seed 42 (KITTI scan unavailable: " + scan.status().ToString() + ")";
  }
  std::printf("scan: %s, %zu points, %d timed reps\n", source.c_str(), cloud.size(), reps);

  commerge::SolidDescriptor solid;
  std::vector<float> rsolid(solid.dimension()), rsolid2(solid.dimension());
  if (!solid.Compute(cloud, rsolid).ok() || !solid.last_result().valid) {
    std::fprintf(stderr, "SOLiD failed on the scan\n");
    return 1;
  }
  const auto solid_ms = Time(reps, [&] { (void)solid.Compute(cloud, rsolid); });
  const commerge::SolidResult& r = solid.last_result();
  std::printf("SOLiD (HDL-64E preset, skip policy): median %.3f ms, min %.3f ms per scan (%.1f ns/point); "
              "counted %u, above FOV %u, below FOV %u, out of range %u\n",
              MedianMs(solid_ms), *std::min_element(solid_ms.begin(), solid_ms.end()),
              1e6 * MedianMs(solid_ms) / static_cast<double>(cloud.size()), r.num_counted, r.num_above_fov,
              r.num_below_fov, r.num_out_of_range);

  commerge::ScanContextDescriptor sc;
  std::vector<float> grid(sc.dimension()), grid2(sc.dimension());
  (void)sc.Compute(cloud, grid);
  const auto sc_ms = Time(reps, [&] { (void)sc.Compute(cloud, grid); });
  std::printf("Scan Context (20 x 60): median %.3f ms per scan\n", MedianMs(sc_ms));

  // Per-pair costs, amortised over many calls.
  std::vector<PointXYZI> half(cloud.begin(), cloud.begin() + static_cast<std::ptrdiff_t>(cloud.size() / 2));
  (void)solid.Compute(half, rsolid2);
  (void)sc.Compute(half, grid2);
  constexpr int kPairs = 20000;
  volatile double sink = 0.0;
  const auto solid_pair = Time(1, [&] {
    for (int i = 0; i < kPairs; ++i) sink = sink + solid.Distance(rsolid, rsolid2);
  });
  const auto sc_pair = Time(1, [&] {
    for (int i = 0; i < kPairs / 100; ++i) sink = sink + sc.Distance(grid, grid2);
  });
  std::printf("distance per pair: SOLiD %.1f ns, Scan Context (60 shifts) %.1f us\n", 1e6 * solid_pair[0] / kPairs,
              1e3 * sc_pair[0] / (kPairs / 100));

  commerge::KeyframeRecord rec;
  rec.keyframe_index = 17;
  rec.descriptor_valid = true;
  std::copy(rsolid.begin(), rsolid.end(), rec.descriptor.begin());
  std::array<std::uint8_t, commerge::kKeyframeRecordBytes> wire{};
  const commerge::Span<std::uint8_t> out(wire.data(), wire.size());
  const auto enc = Time(1, [&] {
    for (int i = 0; i < kPairs; ++i) (void)commerge::EncodeKeyframeRecord(rec, out);
  });
  const auto dec = Time(1, [&] {
    for (int i = 0; i < kPairs; ++i) sink = sink + static_cast<double>(commerge::DecodeKeyframeRecord(out)->descriptor[0]);
  });
  std::printf("keyframe record (%zu B): encode %.2f us, decode %.2f us\n", commerge::kKeyframeRecordBytes,
              1e3 * enc[0] / kPairs, 1e3 * dec[0] / kPairs);
  return 0;
}
