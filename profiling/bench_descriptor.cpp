// SPDX-License-Identifier: BSD-3-Clause
// Descriptor cost on one ~120k-point scan: SOLiD (R + A, unit R) and Scan Context per scan, plus the
// keyframe record codec, the compact keyframe batch per keyframe, and the SOLiD / Scan Context distances per pair.
// Usage: bench_descriptor [--reps N]   (default 30 timed calls after one warm-up call)
// Uses KITTI 00 frame 0 from the shared data when present, else a seeded synthetic LiDAR-like scan.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/agent/robot_agent.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/solid.hpp"
#include "profiling/bench_common.hpp"

using commerge::PointXYZI;

int main(int argc, char** argv) {
  int reps = 30;
  if (!commerge::bench::ParseReps(argc, argv, &reps)) return 2;
  std::string source;
  const std::vector<PointXYZI> cloud = commerge::bench::LoadBenchScan(&source);
  std::printf("scan: %s, %zu points, %d timed reps\n", source.c_str(), cloud.size(), reps);

  commerge::SolidDescriptor solid;
  std::vector<float> rsolid(solid.dimension()), rsolid2(solid.dimension());
  if (!solid.Compute(cloud, rsolid).ok() || !solid.last_result().valid) {
    std::fprintf(stderr, "SOLiD failed on the scan\n");
    return 1;
  }
  const auto solid_ms = commerge::bench::TimeMs(reps, [&] { (void)solid.Compute(cloud, rsolid); });
  const commerge::SolidResult& r = solid.last_result();
  std::printf("SOLiD (HDL-64E preset, skip policy): median %.3f ms, min %.3f ms per scan (%.1f ns/point); "
              "counted %u, above FOV %u, below FOV %u, out of range %u\n",
              commerge::bench::Median(solid_ms), *std::min_element(solid_ms.begin(), solid_ms.end()),
              1e6 * commerge::bench::Median(solid_ms) / static_cast<double>(cloud.size()), r.num_counted, r.num_above_fov,
              r.num_below_fov, r.num_out_of_range);

  commerge::ScanContextDescriptor sc;
  std::vector<float> grid(sc.dimension()), grid2(sc.dimension());
  (void)sc.Compute(cloud, grid);
  const auto sc_ms = commerge::bench::TimeMs(reps, [&] { (void)sc.Compute(cloud, grid); });
  std::printf("Scan Context (20 x 60): median %.3f ms per scan\n", commerge::bench::Median(sc_ms));

  // Per-pair costs, amortised over many calls.
  std::vector<PointXYZI> half(cloud.begin(), cloud.begin() + static_cast<std::ptrdiff_t>(cloud.size() / 2));
  (void)solid.Compute(half, rsolid2);
  (void)sc.Compute(half, grid2);
  constexpr int kPairs = 20000;
  volatile double sink = 0.0;
  const auto solid_pair = commerge::bench::TimeMs(1, [&] {
    for (int i = 0; i < kPairs; ++i) sink = sink + solid.Distance(rsolid, rsolid2);
  });
  const auto sc_pair = commerge::bench::TimeMs(1, [&] {
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
  const auto enc = commerge::bench::TimeMs(1, [&] {
    for (int i = 0; i < kPairs; ++i) (void)commerge::EncodeKeyframeRecord(rec, out);
  });
  const auto dec = commerge::bench::TimeMs(1, [&] {
    for (int i = 0; i < kPairs; ++i) sink = sink + static_cast<double>(commerge::DecodeKeyframeRecord(out)->descriptor[0]);
  });
  std::printf("keyframe record (%zu B): encode %.2f us, decode %.2f us\n", commerge::kKeyframeRecordBytes,
              1e3 * enc[0] / kPairs, 1e3 * dec[0] / kPairs);

  // A compact batch of 256 keyframes 1 m apart, the descriptor drifting from one to the next, at the default bits.
  std::vector<commerge::CompactKeyframe> keyframes(256);
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    keyframes[k].pose.keyframe_index = static_cast<std::uint32_t>(k);
    keyframes[k].pose.T_map_sensor.translation() = Eigen::Vector3d(static_cast<double>(k), 0.01 * k, 0.0);
    double norm2 = 0.0;
    for (std::size_t j = 0; j < rsolid.size(); ++j) {
      const double v = static_cast<double>(rsolid[j]) * (1.0 + 0.05 * ((k * 7 + j * 3) % 5)) + 1e-3;
      keyframes[k].descriptor[j] = static_cast<float>(v);
      norm2 += v * v;
    }
    for (float& v : keyframes[k].descriptor) v = static_cast<float>(static_cast<double>(v) / std::sqrt(norm2));
  }
  std::vector<std::uint8_t> batch;
  std::vector<commerge::CompactKeyframe> decoded;
  const commerge::Span<const commerge::CompactKeyframe> in(keyframes.data(), keyframes.size());
  constexpr int kBatches = 50;
  const auto benc = commerge::bench::TimeMs(1, [&] {
    for (int i = 0; i < kBatches; ++i) {
      (void)commerge::EncodeCompactBatch(in, commerge::kDefaultRecordDescriptorBits, &batch);
    }
  });
  const auto bdec = commerge::bench::TimeMs(1, [&] {
    for (int i = 0; i < kBatches; ++i) {
      (void)commerge::DecodeCompactBatch(commerge::Span<const std::uint8_t>(batch.data(), batch.size()), keyframes.size(),
                                         &decoded);
      sink = sink + static_cast<double>(decoded[0].descriptor[0]);
    }
  });
  const double per = 1e3 / (kBatches * static_cast<double>(keyframes.size()));
  std::printf("compact batch (%zu keyframes, %d bits, %.1f B a keyframe): encode %.2f us, decode %.2f us a keyframe "
              "(%.4f %% of one SOLiD computation)\n",
              keyframes.size(), commerge::kDefaultRecordDescriptorBits,
              static_cast<double>(batch.size()) / static_cast<double>(keyframes.size()), benc[0] * per, bdec[0] * per,
              100.0 * bdec[0] * per / (1e3 * commerge::bench::Median(solid_ms)));
  return 0;
}
