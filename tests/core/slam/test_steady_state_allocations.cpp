// SPDX-License-Identifier: BSD-3-Clause
// The robot's per-keyframe hot path does not touch the heap once its workspaces have seen one scan
// (counted through the global operator new every commerge binary links, platform/memory/new_delete.cpp).
#include <doctest/doctest.h>

#include <memory>
#include <vector>

#include "core/cloud/scan_codec.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/loop_detector.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/memory/allocator.hpp"

using namespace commerge;

TEST_CASE("Descriptor, voxel grid, scan encoding, store and loop search allocate nothing in steady state") {
  SpinningLidar lidar;
  lidar.azimuth_steps = 512;
  std::vector<PointXYZI> scan_a, scan_b;
  const BoxScene scene = MakeStreetScene(9);
  CastScan(scene, lidar, 0.0f, 0.0f, 1.73f, 0.0f, 1, &scan_a);
  CastScan(scene, lidar, 3.0f, 0.0f, 1.73f, 0.2f, 2, &scan_b);
  if (scan_b.size() > scan_a.size()) std::swap(scan_a, scan_b);  // warm up on the larger one

  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneHdl64e));
  REQUIRE(solid.ok());
  VoxelGrid grid(scan_a.size());
  std::vector<PointXYZI> voxels;
  voxels.reserve(scan_a.size());
  std::vector<float> descriptor(solid->dimension());
  std::vector<std::uint8_t> encoded(EncodedScanBytes(scan_a.size()));
  ScanStoreParams sp;
  sp.capacity_bytes = 1 << 20;
  sp.max_scans = 16;
  sp.policy = ScanStorePolicy::kEvictOldest;
  auto store = ScanStore::Create(sp);
  REQUIRE(store.ok());
  DescriptorDatabase db(*solid, 64);

  std::uint32_t index = 0;
  auto keyframe = [&](const std::vector<PointXYZI>& scan) {
    auto info = solid->Compute(Span<const PointXYZI>(scan), Span<float>(descriptor));
    auto vox = grid.Downsample(Span<const PointXYZI>(scan), VoxelGridParams{1.0}, &voxels);
    REQUIRE((info.ok() && vox.ok()));
    auto enc = EncodeScan(Span<const PointXYZI>(voxels), Span<std::uint8_t>(encoded));
    REQUIRE(enc.ok());
    REQUIRE((*store)->Put(index++, Span<const std::uint8_t>(encoded.data(), enc->bytes_written)).ok());
    REQUIRE(db.Add(Span<const float>(descriptor), info->valid).ok());
    return db.NearestBefore(Span<const float>(descriptor), db.size()).found;
  };
  REQUIRE(keyframe(scan_a));  // warm-up: workspaces reach their size
  const std::uint64_t before = platform::OperatorNewCalls();
  for (int i = 0; i < 40; ++i) CHECK(keyframe(i % 2 ? scan_a : scan_b));  // 40 x 8 KiB+ scans: the store evicts
  const std::uint64_t after = platform::OperatorNewCalls();
  CHECK(after - before == 0);
  CHECK((*store)->stats().num_evicted > 0);
}
