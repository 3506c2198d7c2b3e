// SPDX-License-Identifier: BSD-3-Clause
// Robot-side cost per keyframe on ~120k-point scans: SOLiD on the raw scan, 1 m voxelisation, scan encoding
// into the store, and the loop search over a descriptor database of --db-keyframes entries (the search is an
// exact linear scan, so its cost grows with the mission). Also prints memory per stored keyframe.
// Usage: bench_robot_keyframe [--reps N] [--db-keyframes N]
// Uses KITTI 00 frames 0-15 from the shared data when present, else generated HDL-64E-like street scans.
#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/cloud/scan_codec.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/bytes.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/loop_detector.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/memory/peak_rss.hpp"
#include "profiling/bench_common.hpp"

using namespace commerge;
using Clock = std::chrono::steady_clock;

namespace {

double Ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }


}  // namespace

int main(int argc, char** argv) {
  int reps = 3;
  long db_keyframes = 20000;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--db-keyframes") == 0 && i + 1 < argc) {
      db_keyframes = std::atol(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--reps N] [--db-keyframes N]\n", argv[0]);
      return 2;
    }
  }
  if (reps < 1 || db_keyframes < 1 || db_keyframes > 10000000) {
    std::fprintf(stderr, "--reps must be >= 1 and --db-keyframes in [1, 10^7]\n");
    return 2;
  }

  const std::string data = commerge::bench::SharedDataDir();
  std::vector<std::vector<PointXYZI>> scans;
  std::string source = "KITTI 00 frames 0-15 (HDL-64E)";
  for (int f = 0; f < 16; ++f) {
    char name[64];
    std::snprintf(name, sizeof name, "/kitti/kitti00_frames0-15/velodyne/%06d.bin", f);
    auto scan = platform::ReadKittiBin(data + name);
    if (!scan.ok()) break;
    scans.push_back(std::move(scan->points));
  }
  if (scans.empty()) {
    source = "generated street scans (HDL-64E-like; KITTI data absent)";
    const BoxScene scene = MakeStreetScene(5);
    for (int f = 0; f < 16; ++f) {
      scans.emplace_back();
      CastScan(scene, SpinningLidar{}, static_cast<float>(f), 0.0f, 1.73f, 0.0f, static_cast<std::uint32_t>(f), &scans.back());
    }
  }

  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneHdl64e));
  if (!solid.ok()) return 1;
  DescriptorDatabase db(*solid, static_cast<std::size_t>(db_keyframes) + 1);
  {  // a mission's worth of unit descriptors (random: the linear scan's cost does not depend on the values)
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> d(solid->dimension());
    for (long k = 0; k < db_keyframes; ++k) {
      float norm = 0.0f;
      for (float& x : d) {
        x = u(rng);
        norm += x * x;
      }
      for (float& x : d) x /= std::sqrt(norm);
      if (!db.Add(Span<const float>(d), true).ok()) return 1;
    }
  }
  ScanStoreParams sp;
  sp.capacity_bytes = 64 << 20;
  sp.max_scans = 20000;
  auto store = ScanStore::Create(sp);
  if (!store.ok()) return 1;

  VoxelGrid grid(150000);
  std::vector<PointXYZI> voxels;
  std::vector<float> descriptor(solid->dimension());
  std::vector<std::uint8_t> encoded(EncodedScanBytes(65536));
  std::vector<double> t_desc, t_vox, t_enc, t_loop, t_total;
  std::size_t raw_points = 0, voxel_points = 0, encoded_bytes = 0, stored = 0;
  std::uint32_t next_index = 0;
  for (int r = 0; r < reps; ++r) {
    for (const auto& scan : scans) {
      const auto t0 = Clock::now();
      auto info = solid->Compute(Span<const PointXYZI>(scan), Span<float>(descriptor));
      const auto t1 = Clock::now();
      auto vs = grid.Downsample(Span<const PointXYZI>(scan), VoxelGridParams{1.0}, &voxels);
      const auto t2 = Clock::now();
      auto enc = EncodeScan(Span<const PointXYZI>(voxels), Span<std::uint8_t>(encoded));
      if (!info.ok() || !vs.ok() || !enc.ok()) return 1;
      auto put = (*store)->Put(next_index++, Span<const std::uint8_t>(encoded.data(), enc->bytes_written));
      const auto t3 = Clock::now();
      const DescriptorDatabase::Match m = db.NearestBefore(Span<const float>(descriptor), db.size());
      const auto t4 = Clock::now();
      if (!put.ok() || !m.found) return 1;
      t_desc.push_back(Ms(t0, t1));
      t_vox.push_back(Ms(t1, t2));
      t_enc.push_back(Ms(t2, t3));
      t_loop.push_back(Ms(t3, t4));
      t_total.push_back(Ms(t0, t4));
      raw_points += scan.size();
      voxel_points += voxels.size();
      encoded_bytes += enc->bytes_written;
      ++stored;
    }
  }
  const double n = static_cast<double>(stored);
  const double per_keyframe_scan = static_cast<double>(encoded_bytes) / n + ScanStore::kRecordHeaderBytes +
                                   ScanStore::kIndexEntryBytes;
  const double per_keyframe_other = static_cast<double>(BudgetRecordSizes::kDescriptorRecordBytes +
                                                        BudgetRecordSizes::kPoseGraphBytesPerKeyframe);
  std::printf("source:              %s, %zu scans x %d reps\n", source.c_str(), scans.size(), reps);
  std::printf("points per scan:     raw %.0f, after 1 m voxels %.0f\n", static_cast<double>(raw_points) / n,
              static_cast<double>(voxel_points) / n);
  std::printf("ms per keyframe (median): SOLiD %.2f | voxel %.2f | encode+store %.3f | loop search over %ld "
              "descriptors %.2f | total %.2f\n",
              commerge::bench::Median(t_desc), commerge::bench::Median(t_vox), commerge::bench::Median(t_enc), db_keyframes, commerge::bench::Median(t_loop), commerge::bench::Median(t_total));
  std::printf("memory per stored keyframe: scan %.0f B (encoded %.0f B + record header %zu B + index %zu B), "
              "descriptor + pose graph budget %.0f B, total %.1f KiB\n",
              per_keyframe_scan, static_cast<double>(encoded_bytes) / n, ScanStore::kRecordHeaderBytes,
              ScanStore::kIndexEntryBytes, per_keyframe_other, (per_keyframe_scan + per_keyframe_other) / 1024.0);
  std::printf("raw scan for comparison: %.0f B (%.1fx the stored scan)\n", static_cast<double>(raw_points) / n * 16.0,
              static_cast<double>(raw_points) / n * 16.0 / per_keyframe_scan);
  std::printf("peak RSS:            %s\n", FormatBytes(platform::ReadRss().peak_bytes).c_str());
  return 0;
}
