// SPDX-License-Identifier: BSD-3-Clause
// Affinity kernel + stage A (sequential matching) on N x N keyframes, one core: time, GFLOP/s of the
// distance kernel and peak RSS.
// Usage: bench_affinity [--size N] [--reps R] [--tile ROWS COLS]
// Figures per size: the distance kernel alone, affinity + stage A (the paper's threshold), stage A with the
// sequence-smoothed threshold (w = 8).
//   --size N      one size per process, so the peak RSS (VmHWM) belongs to that size alone
//   (none)        runs 2000, 10000 and 20000, each by re-invoking this program with --size
//   --reps R      timed repetitions per figure, median reported (default 5)
//   --tile R C    stage A tile grid (default: SequentialMatchParams, 256 x 256)
// Data (synthetic, seeded): two random-walk trajectories of unit-normalised R-SOLiD-like descriptors (D = 40,
// non-negative, consecutive keyframes ~0.06 apart); beta revisits a segment of alpha of N / 5 keyframes
// (+ noise), which gives a diagonal band below tau_inter = 0.10; everything else is far (d ~ 0.3 ... 1).
// GFLOP/s counts (2 D + 4) flops per cell: D multiplies and D adds of the dot product, then
// ||a||^2 + ||b||^2, the doubling of a.b, the subtraction and the square root (max and min not counted).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "core/exchange/affinity.hpp"
#include "core/exchange/sequential_matching.hpp"
#include "platform/memory/peak_rss.hpp"
#include "profiling/bench_common.hpp"

namespace {

constexpr std::size_t kDim = 40;

// Wall and CPU milliseconds of each of `reps` calls of f(). The CPU time (std::clock, this process) is the
// figure to trust on a shared machine: it excludes the time other processes held the core.
struct Timings {
  std::vector<double> wall_ms, cpu_ms;
};
template <class F>
Timings TimeBoth(int reps, F&& f) {
  Timings t;
  for (int i = 0; i < reps; ++i) {
    const std::clock_t c0 = std::clock();
    t.wall_ms.push_back(commerge::bench::TimeMs(1, f)[0]);
    t.cpu_ms.push_back(1e3 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  }
  return t;
}

void Normalise(float* v) {
  double n2 = 0.0;
  for (std::size_t k = 0; k < kDim; ++k) n2 += static_cast<double>(v[k]) * static_cast<double>(v[k]);
  const auto inv = static_cast<float>(1.0 / std::sqrt(n2));
  for (std::size_t k = 0; k < kDim; ++k) v[k] *= inv;
}

// count keyframes of a trajectory: each descriptor a small random step from the previous one.
std::vector<float> Trajectory(std::size_t count, std::mt19937* rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 0.01f);
  std::vector<float> v(count * kDim), cur(kDim);
  for (float& x : cur) x = u(*rng);
  Normalise(cur.data());
  for (std::size_t i = 0; i < count; ++i) {
    std::copy(cur.begin(), cur.end(), v.begin() + static_cast<std::ptrdiff_t>(i * kDim));
    for (float& x : cur) x = std::fabs(x + g(*rng));
    Normalise(cur.data());
  }
  return v;
}

// beta[j0 + t] = alpha[i0 + t] + noise, t < len: the revisit.
void PlantRevisit(const std::vector<float>& alpha, std::vector<float>* beta, std::size_t i0, std::size_t j0,
                  std::size_t len, std::mt19937* rng) {
  std::normal_distribution<float> g(0.0f, 0.003f);
  for (std::size_t t = 0; t < len; ++t) {
    float* dst = beta->data() + (j0 + t) * kDim;
    const float* src = alpha.data() + (i0 + t) * kDim;
    for (std::size_t k = 0; k < kDim; ++k) dst[k] = std::fabs(src[k] + g(*rng));
    Normalise(dst);
  }
}

constexpr std::size_t kSmoothingHalfWindow = 8;

int RunSize(std::size_t n, int reps, std::size_t tile_rows, std::size_t tile_cols) {
  using commerge::bench::Median;
  using commerge::bench::TimeMs;
  std::mt19937 rng(1234);
  const std::vector<float> alpha_all = Trajectory(n, &rng);
  std::vector<float> beta = Trajectory(n, &rng);
  PlantRevisit(alpha_all, &beta, n / 4, n / 2, n / 5, &rng);
  const commerge::DescriptorSetView alpha{alpha_all, kDim, {}};
  const commerge::DescriptorSetView beta_view{beta, kDim, {}};
  commerge::SequentialMatchParams params;  // tau_inter 0.10, tau_area 10000
  params.tile_rows = tile_rows;
  params.tile_cols = tile_cols;

  std::printf("== %zu x %zu keyframes, D = %zu, tau_inter = %.2f, tau_area = %llu, tile %zu x %zu, %d reps ==\n", n,
              n, kDim, params.tau_inter, static_cast<unsigned long long>(params.tau_area), params.tile_rows,
              params.tile_cols, reps);

  // 1. Distance kernel alone (tiles computed and discarded; includes the tile minimum).
  auto kernel = commerge::AffinityTileKernel::Create(alpha, beta_view, params.tile_rows, params.tile_cols);
  if (!kernel.ok()) return 1;
  float sink = 0.0f;
  const Timings kernel_t = TimeBoth(reps, [&] {
    (void)commerge::ForEachAffinityTile(*kernel, params.tile_rows, params.tile_cols, [&](const commerge::AffinityTile& t) {
      sink = std::min(sink, t.min_distance);
      return commerge::Status::Ok();
    });
  });
  const double cells = static_cast<double>(n) * static_cast<double>(n);
  const double flops = cells * (2.0 * kDim + 4.0);
  const double kernel_cpu = Median(kernel_t.cpu_ms);
  std::printf("kernel only:        wall median %8.1f ms (min %8.1f), CPU median %8.1f ms  -> %6.2f GFLOP/s, %6.1f "
              "Mcells/s (CPU)\n",
              Median(kernel_t.wall_ms), *std::min_element(kernel_t.wall_ms.begin(), kernel_t.wall_ms.end()), kernel_cpu,
              flops / kernel_cpu / 1e6, cells / kernel_cpu / 1e3);

  // 2. Full stage A: kernel creation (norms, beta pack), streaming labelling, second pass over the span.
  commerge::SequentialMatchResult full;
  bool ok = true;
  const Timings stage_a_t = TimeBoth(reps, [&] {
    auto r = commerge::RunSequentialMatching(alpha, beta_view, params);
    ok &= r.ok();
    if (r.ok()) full = std::move(r.value());
  });
  if (!ok) return 1;
  std::printf("affinity + stage A: wall median %8.1f ms (min %8.1f), CPU median %8.1f ms\n", Median(stage_a_t.wall_ms),
              *std::min_element(stage_a_t.wall_ms.begin(), stage_a_t.wall_ms.end()), Median(stage_a_t.cpu_ms));
  std::printf("  found %s: rows %zu-%zu, cols %zu-%zu, %zu loop cells; %zu clusters, %llu cells below tau\n",
              full.found ? "yes" : "no", full.best.row_min, full.best.row_max, full.best.col_min, full.best.col_max,
              full.cells.size(), full.num_clusters, static_cast<unsigned long long>(full.num_cells_below_threshold));

  // 2b. Stage A with the sequence-smoothed threshold (core/README.md "Sequence-smoothed stage A"): same sets, w = 8.
  commerge::SequentialMatchParams smoothed_params = params;
  smoothed_params.sequence_half_window = kSmoothingHalfWindow;
  commerge::SequentialMatchResult smoothed;
  const Timings smoothed_t = TimeBoth(reps, [&] {
    auto r = commerge::RunSequentialMatching(alpha, beta_view, smoothed_params);
    ok &= r.ok();
    if (r.ok()) smoothed = std::move(r.value());
  });
  if (!ok) return 1;
  std::printf("stage A, --sequence-half-window %zu: wall median %8.1f ms (min %8.1f), CPU median %8.1f ms; found %s, "
              "%zu loop cells, %zu clusters\n",
              kSmoothingHalfWindow, Median(smoothed_t.wall_ms),
              *std::min_element(smoothed_t.wall_ms.begin(), smoothed_t.wall_ms.end()), Median(smoothed_t.cpu_ms),
              smoothed.found ? "yes" : "no", smoothed.cells.size(), smoothed.num_clusters);

  const std::int64_t peak = commerge::platform::ReadRss().peak_bytes;
  std::printf("peak RSS (VmHWM):   %s\n", commerge::FormatBytes(peak).c_str());
  if (sink > 0.0f) std::printf(" ");  // keeps the kernel loop observable
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 5;
  long size = 0;
  std::size_t tile_rows = commerge::SequentialMatchParams{}.tile_rows, tile_cols = commerge::SequentialMatchParams{}.tile_cols;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
      size = std::atol(argv[++i]);
    } else if (std::strcmp(argv[i], "--tile") == 0 && i + 2 < argc) {
      tile_rows = static_cast<std::size_t>(std::atol(argv[++i]));
      tile_cols = static_cast<std::size_t>(std::atol(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: %s [--size N] [--reps R] [--tile ROWS COLS]\n", argv[0]);
      return 2;
    }
  }
  if (reps < 1 || size < 0 || size > 200000 || tile_rows == 0 || tile_cols == 0) {
    std::fprintf(stderr, "--reps must be >= 1, --size in [1, 200000], tile sizes >= 1\n");
    return 2;
  }
  if (size > 0) return RunSize(static_cast<std::size_t>(size), reps, tile_rows, tile_cols);
  int status = 0;
  for (const long n : {2000L, 10000L, 20000L}) {
    const std::string cmd = std::string("\"") + argv[0] + "\" --size " + std::to_string(n) + " --reps " +
                            std::to_string(reps) + " --tile " + std::to_string(tile_rows) + " " +
                            std::to_string(tile_cols);
    std::fflush(stdout);
    if (std::system(cmd.c_str()) != 0) status = 1;
  }
  return status;
}
