// SPDX-License-Identifier: BSD-3-Clause
// Scan Context affinity tiles (core/exchange/scan_context_affinity.hpp), one core: cells per second of the exact
// mode (every column shift), the sector-key mode (default and other candidate counts) and, for scale, the SOLiD
// tile kernel (AffinityTileKernel, D = 40) on N x N keyframes; and how often sector-key equals exact.
// Usage: bench_scan_context_affinity [--size N] [--reps R] [--exact-max-s S]
//   --size N         one size (default: 800, then 3000)
//   --reps R         timed repetitions of each figure, median of the CPU time reported (default 3; 1 for N > 1000)
//   --exact-max-s S  the exact mode runs at a size only when its time, projected from the first size, is below S
//                    seconds (default 60); the agreement figures then compare against it
// Data (synthetic, seeded): two robots drive one 600 m ray-cast street (MakeStreetScene, 16 beams x 720 columns)
// in both lanes, keyframes evenly spaced, each at a random heading, so the matrix holds a diagonal of nearby
// places (distances ~0.1-0.3) and far pairs (~0.3-0.6); Scan Contexts 20 x 60 (ComputeScanContext defaults).
// The SOLiD figure uses random unit 40-D descriptors: its cost does not depend on the values.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "core/descriptor/scan_context.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/scan_context_affinity.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "profiling/bench_common.hpp"

namespace {

using commerge::ScanContextAffinityMode;

constexpr std::size_t kScDim = 1200;
constexpr std::size_t kSolidDim = 40;

double CpuMs(std::clock_t since) { return 1e3 * static_cast<double>(std::clock() - since) / CLOCKS_PER_SEC; }

// count Scan Contexts of one robot: keyframes every `step_m` from x0 along the street, lane y, random heading.
std::vector<float> RobotScanContexts(const commerge::BoxScene& scene, std::size_t count, float x0, float step_m,
                                     float lane_y_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> yaw(-3.14159f, 3.14159f), jitter(-0.3f, 0.3f);
  commerge::SpinningLidar lidar;
  lidar.beams = 16;
  lidar.azimuth_steps = 720;
  lidar.max_range_m = 90.0f;
  std::vector<float> out(count * kScDim);
  std::vector<commerge::PointXYZI> pts;
  for (std::size_t k = 0; k < count; ++k) {
    pts.clear();
    commerge::CastScan(scene, lidar, x0 + step_m * static_cast<float>(k), lane_y_m + jitter(rng), 1.73f, yaw(rng),
                       seed + static_cast<std::uint32_t>(k), &pts);
    (void)commerge::ComputeScanContext(pts, commerge::ScanContextParams{},
                                       commerge::Span<float>(out.data() + k * kScDim, kScDim));
  }
  return out;
}

// Runs every tile of `source` into `out` (row-major N x M) when out is non-null; returns the CPU ms.
double RunAll(commerge::AffinityTileSource& source, std::vector<float>* out) {
  const std::size_t m = source.num_cols();
  const std::clock_t c0 = std::clock();
  float sink = 0.0f;
  const commerge::Status s = commerge::ForEachAffinityTile(source, 256, 256, [&](const commerge::AffinityTile& t) {
    sink = std::min(sink, t.min_distance);
    if (out) {
      for (std::size_t r = 0; r < t.rows; ++r) {
        std::copy(t.distances + r * t.stride, t.distances + r * t.stride + t.cols,
                  out->begin() + static_cast<std::ptrdiff_t>((t.row_begin + r) * m + t.col_begin));
      }
    }
    return commerge::Status::Ok();
  });
  const double ms = CpuMs(c0);
  if (!s.ok() || sink > 0.0f) std::printf("  (tile error: %s)\n", s.ToString().c_str());
  return ms;
}

struct ModeRun {
  double cpu_ms = 0.0;
  double shifts_per_cell = 0.0;
  std::vector<float> values;
};

ModeRun RunMode(const commerge::DescriptorSetView& a, const commerge::DescriptorSetView& b, ScanContextAffinityMode mode,
                int candidates, int reps) {
  commerge::ScanContextAffinityParams p;
  p.mode = mode;
  p.num_candidate_shifts = candidates;
  ModeRun run;
  std::vector<double> ms;
  for (int r = 0; r < reps; ++r) {
    auto src = commerge::ScanContextTileSource::Create(a, b, p, 256, 256);
    if (!src.ok()) {
      std::printf("  create failed: %s\n", src.status().ToString().c_str());
      return run;
    }
    run.values.assign(a.count() * b.count(), 0.0f);
    ms.push_back(RunAll(*src, &run.values));
    run.shifts_per_cell = static_cast<double>(src->shifts_evaluated()) / static_cast<double>(a.count() * b.count());
  }
  run.cpu_ms = commerge::bench::Median(ms);
  return run;
}

void PrintAgreement(const char* name, const std::vector<float>& key, const std::vector<float>& exact) {
  std::size_t cells = 0, equal = 0, near = 0, near_equal = 0, below = 0;
  double max_diff = 0.0;
  for (std::size_t k = 0; k < exact.size(); ++k) {
    if (std::isinf(exact[k])) continue;
    ++cells;
    equal += key[k] == exact[k];
    below += key[k] < exact[k];
    max_diff = std::max(max_diff, static_cast<double>(key[k] - exact[k]));
    if (exact[k] < 0.3f) {
      ++near;
      near_equal += key[k] == exact[k];
    }
  }
  std::printf("  %-22s equal to exact in %6.2f %% of %zu cells (%6.2f %% of the %zu cells with exact < 0.3), "
              "max difference %.4f, cells below exact %zu\n",
              name, 100.0 * static_cast<double>(equal) / static_cast<double>(std::max<std::size_t>(cells, 1)), cells,
              100.0 * static_cast<double>(near_equal) / static_cast<double>(std::max<std::size_t>(near, 1)), near,
              max_diff, below);
}

// Returns the CPU ms per cell of the exact mode (0 when it did not run).
double RunSize(std::size_t n, int reps, double exact_ms_per_cell_estimate, double exact_max_s) {
  const commerge::BoxScene scene = commerge::MakeStreetScene(7, 600.0f);
  const float step = 560.0f / static_cast<float>(n);
  const std::clock_t c0 = std::clock();
  const std::vector<float> va = RobotScanContexts(scene, n, -280.0f, step, -1.5f, 1000);
  const std::vector<float> vb = RobotScanContexts(scene, n, -280.0f + 0.5f * step, step, 1.5f, 5000);
  const double cells = static_cast<double>(n) * static_cast<double>(n);
  std::printf("== %zu x %zu keyframes, Scan Context 20 x 60, tiles 256 x 256, %d rep(s) (scans cast in %.1f s) ==\n", n,
              n, reps, CpuMs(c0) / 1e3);
  const commerge::DescriptorSetView a{va, kScDim, {}}, b{vb, kScDim, {}};

  // SOLiD kernel for scale.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> sa(n * kSolidDim), sb(n * kSolidDim);
  for (float& x : sa) x = u(rng);
  for (float& x : sb) x = u(rng);
  for (std::vector<float>* v : {&sa, &sb}) {
    for (std::size_t i = 0; i < n; ++i) {
      double n2 = 0.0;
      for (std::size_t k = 0; k < kSolidDim; ++k) {
        const auto x = static_cast<double>((*v)[i * kSolidDim + k]);
        n2 += x * x;
      }
      for (std::size_t k = 0; k < kSolidDim; ++k) (*v)[i * kSolidDim + k] /= static_cast<float>(std::sqrt(n2));
    }
  }
  std::vector<double> solid_ms;
  for (int r = 0; r < std::max(reps, 3); ++r) {
    auto kernel = commerge::AffinityTileKernel::Create({sa, kSolidDim, {}}, {sb, kSolidDim, {}}, 256, 256);
    if (!kernel.ok()) return 0.0;
    solid_ms.push_back(RunAll(*kernel, nullptr));
  }
  const double solid = commerge::bench::Median(solid_ms);
  std::printf("  %-22s CPU %9.1f ms  %10.3f Mcells/s\n", "SOLiD kernel (D = 40)", solid, cells / solid / 1e3);

  const ModeRun key = RunMode(a, b, ScanContextAffinityMode::kSectorKeyShift, 2, reps);
  std::printf("  %-22s CPU %9.1f ms  %10.3f Mcells/s  (%.1f shifts per cell)\n", "sector-key (k 2, w 3)", key.cpu_ms,
              cells / key.cpu_ms / 1e3, key.shifts_per_cell);
  const ModeRun key1 = RunMode(a, b, ScanContextAffinityMode::kSectorKeyShift, 1, 1);
  std::printf("  %-22s CPU %9.1f ms  %10.3f Mcells/s  (%.1f shifts per cell)\n", "sector-key (k 1, w 3)", key1.cpu_ms,
              cells / key1.cpu_ms / 1e3, key1.shifts_per_cell);
  const ModeRun key3 = RunMode(a, b, ScanContextAffinityMode::kSectorKeyShift, 3, 1);
  std::printf("  %-22s CPU %9.1f ms  %10.3f Mcells/s  (%.1f shifts per cell)\n", "sector-key (k 3, w 3)", key3.cpu_ms,
              cells / key3.cpu_ms / 1e3, key3.shifts_per_cell);

  const double projected_s = exact_ms_per_cell_estimate * cells / 1e3;
  if (exact_ms_per_cell_estimate > 0.0 && projected_s > exact_max_s) {
    std::printf("  exact: skipped (projected %.0f s > --exact-max-s %.0f)\n", projected_s, exact_max_s);
    return 0.0;
  }
  const ModeRun exact = RunMode(a, b, ScanContextAffinityMode::kExact, 1, exact_ms_per_cell_estimate > 0.0 ? 1 : reps);
  std::printf("  %-22s CPU %9.1f ms  %10.3f Mcells/s  (%.1f shifts per cell)\n", "exact", exact.cpu_ms,
              cells / exact.cpu_ms / 1e3, exact.shifts_per_cell);
  std::printf("  sector-key (k 2) is %.1fx faster than exact; SOLiD is %.0fx faster than sector-key\n",
              exact.cpu_ms / key.cpu_ms, key.cpu_ms / solid);
  PrintAgreement("sector-key (k 2, w 3)", key.values, exact.values);
  PrintAgreement("sector-key (k 1, w 3)", key1.values, exact.values);
  PrintAgreement("sector-key (k 3, w 3)", key3.values, exact.values);
  return exact.cpu_ms / cells;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 0;
  long size = 0;
  double exact_max_s = 60.0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
      size = std::atol(argv[++i]);
    } else if (std::strcmp(argv[i], "--exact-max-s") == 0 && i + 1 < argc) {
      exact_max_s = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--size N] [--reps R] [--exact-max-s S]\n", argv[0]);
      return 2;
    }
  }
  if (reps < 0 || size < 0 || size > 20000 || !(exact_max_s >= 0.0)) {
    std::fprintf(stderr, "--reps must be >= 1, --size in [1, 20000], --exact-max-s >= 0\n");
    return 2;
  }
  const auto reps_for = [reps](long n) { return reps > 0 ? reps : (n > 1000 ? 1 : 3); };
  if (size > 0) {
    RunSize(static_cast<std::size_t>(size), reps_for(size), 0.0, exact_max_s);
    return 0;
  }
  const double ms_per_cell = RunSize(800, reps_for(800), 0.0, exact_max_s);
  std::fflush(stdout);
  RunSize(3000, reps_for(3000), ms_per_cell, exact_max_s);
  return 0;
}
