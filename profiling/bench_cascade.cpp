// SPDX-License-Identifier: BSD-3-Clause
// The server cascade end to end on a generated two-robot street mission: stage sizes, data volume per stage,
// time per stage, optimality, and the share of selected loops that are true (ground truth), for both stage-C
// loop sets (both endpoints selected = default, the paper's literal any-endpoint set = all of L_seq). Stage C is
// also solved by GLPK's glp_intopt on the same compatibility graph for the speed comparison.
//
// Usage: bench_cascade [--keyframes N] [--overlap M] [--glpk-limit-s S]
//   N keyframes per robot (default 700), M of them overlapping (default 220); the robots drive one straight
//   street in opposite directions in the same lane (keyframes 0.5 m apart along the road), VLP-16-like sensor
//   (16 x 1024 rays), SOLiD on the raw scans.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/cloud/scan_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/keyframe_drive.hpp"
#include "platform/memory/peak_rss.hpp"
#include "profiling/glpk_reference.hpp"

using namespace commerge;

namespace {

double Mb(std::uint64_t bytes) { return static_cast<double>(bytes) / 1e6; }

}  // namespace

int main(int argc, char** argv) {
  int keyframes = 700, overlap = 220;
  double glpk_limit_s = 60.0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--keyframes") == 0 && i + 1 < argc) {
      keyframes = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--overlap") == 0 && i + 1 < argc) {
      overlap = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--glpk-limit-s") == 0 && i + 1 < argc) {
      glpk_limit_s = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--keyframes N] [--overlap M] [--glpk-limit-s S]\n", argv[0]);
      return 2;
    }
  }
  if (keyframes < 2 || overlap < 1 || overlap > keyframes || !(glpk_limit_s > 0)) {
    std::fprintf(stderr, "bench_cascade: need 2 <= keyframes, 1 <= overlap <= keyframes, glpk limit > 0\n");
    return 2;
  }
  // Street long enough for both paths; alpha from the west end eastwards, beta from the east end westwards.
  const float length_m = static_cast<float>(2 * keyframes - overlap + 20);
  const BoxScene scene = MakeStreetScene(7, length_m);
  SpinningLidar lidar;
  lidar.beams = 16;
  lidar.azimuth_steps = 1024;
  lidar.min_elevation_deg = -15.0f;
  lidar.max_elevation_deg = 15.0f;
  lidar.max_range_m = 80.0f;
  const SolidParams solid = SolidPreset(LidarSensor::kVelodyneVlp16);
  StraightDrive a, b;
  a.start_x_m = -length_m / 2 + 10.0f;
  a.lane_y_m = 0.0f;
  a.keyframes = keyframes;
  a.seed = 100000;
  b.start_x_m = a.start_x_m + static_cast<float>(2 * keyframes - overlap - 1) + 0.5f;
  b.lane_y_m = 0.0f;
  b.yaw_rad = kPiF;
  b.keyframes = keyframes;
  b.seed = 200000;
  const auto t_sim = std::chrono::steady_clock::now();
  auto alpha = SimulateStraightDrive(scene, lidar, solid, a);
  auto beta = SimulateStraightDrive(scene, lidar, solid, b);
  if (!alpha.ok() || !beta.ok()) {
    std::fprintf(stderr, "bench_cascade: simulation failed\n");
    return 1;
  }
  std::printf("mission: 2 robots x %d keyframes (1 m), %d overlapping, street %.0f m, %d boxes; simulated in %.1f s\n",
              keyframes, overlap, static_cast<double>(length_m), static_cast<int>(scene.boxes.size()),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t_sim).count());

  auto input = [](const SimulatedKeyframes& r) {
    CascadeRobotInput in;
    in.descriptors.values = Span<const float>(r.descriptors);
    in.descriptors.dim = static_cast<std::size_t>(r.dim);
    in.descriptors.valid = Span<const std::uint8_t>(r.valid);
    in.positions_m = Span<const Eigen::Vector3d>(r.own_frame_m);
    return in;  // stored point counts unknown: the policy assumes 4 300 points per 1 m-voxel scan
  };
  const std::uint64_t scan_bytes = EncodedScanBytes(ExchangePolicyParams{}.assumed_points_per_scan);
  std::printf("all scans of both robots: %d x %.3f MB = %.1f MB\n\n", 2 * keyframes, Mb(scan_bytes),
              Mb(scan_bytes * 2 * static_cast<std::uint64_t>(keyframes)));

  for (StageCLoopSet set : {StageCLoopSet::kBothEndpointsSelected, StageCLoopSet::kAnyEndpointSelected}) {
    ExchangeCascadeParams params;
    params.stage_c.loop_set = set;
    params.stage_c.time_limit_s = 10.0;
    auto r = RunExchangeCascade(input(*alpha), input(*beta), params);
    if (!r.ok()) {
      std::fprintf(stderr, "cascade: %s\n", r.status().ToString().c_str());
      return 1;
    }
    std::printf("== stage C loop set: %s ==\n", StageCLoopSetName(set));
    if (r->outcome != CascadeOutcome::kPolicy) {
      std::printf("  no policy: %s\n\n", r->no_candidate_reason.c_str());
      continue;
    }
    const auto true_loops = [&](const std::vector<SequentialLoopCell>& loops) {
      std::size_t t = 0;
      for (const auto& l : loops) t += (alpha->gt_m[l.alpha_index] - beta->gt_m[l.beta_index]).norm() < 5.0;
      return t;
    };
    const auto& sa = r->stage_a;
    const std::size_t seq_scans = r->stage_b_vertices_alpha + r->stage_b_vertices_beta;
    const std::size_t b_scans = r->stage_b.selected_left.size() + r->stage_b.selected_right.size();
    std::printf("  stage A: %zu clusters, best span rows %zu..%zu cols %zu..%zu (area %llu), |L_seq| = %zu loops "
                "(%zu true), %zu scans = %.1f MB, %.3f s\n",
                sa.num_clusters, sa.best.row_min, sa.best.row_max, sa.best.col_min, sa.best.col_max,
                static_cast<unsigned long long>(sa.best.span_area()), sa.cells.size(), true_loops(sa.cells),
                seq_scans, Mb(scan_bytes * seq_scans), r->stage_a_s);
    std::printf("  stage B: %s, %zu + %zu scans = %.1f MB (N_MM %d, share %d, %lld nodes), %.3f s\n",
                BalancedCoverStatusName(r->stage_b.status), r->stage_b.selected_left.size(),
                r->stage_b.selected_right.size(), Mb(scan_bytes * b_scans), r->stage_b.max_matching_size,
                r->stage_b.min_share_per_robot, static_cast<long long>(r->stage_b.nodes_explored), r->stage_b_s);
    const auto& sc = r->stage_c;
    std::printf("  stage C: |L_V| = %zu loops (%zu dropped by max_loops), %zu compatible pairs, |L_K| = %zu (%zu true), "
                "f_K = %.4f, %s, gap %.2g, %lld nodes, %.3f s\n",
                sc.candidate_loops.size(), sc.loops_dropped, sc.compatible_pairs, sc.selected_loops.size(),
                true_loops(sc.selected_loops), sc.clique.objective, CliqueSearchStatusName(sc.clique.status),
                sc.clique.gap(), static_cast<long long>(sc.clique.nodes), r->stage_c_s);
    std::printf("  policy : %zu + %zu scans, predicted %.2f MB (%.3f %% of all scans)\n",
                r->policy.alpha.keyframes.size(), r->policy.beta.keyframes.size(), Mb(r->policy.predicted_bytes()),
                100.0 * static_cast<double>(r->policy.predicted_bytes()) /
                    static_cast<double>(scan_bytes * 2 * static_cast<std::uint64_t>(keyframes)));
    // Stage C by GLPK on the same compatibility graph (small enough graphs only: the model is dense).
    if (sc.candidate_loops.size() <= 1000) {
      auto graph = BuildCompatibilityGraph(sc.candidate_loops, alpha->own_frame_m, beta->own_frame_m,
                                           params.stage_c.tau_con_m);
      if (graph.ok()) {
        const bench::GlpkRun glpk = bench::GlpkMaxClique(*graph, CliqueObjective::kEdgeWeight, glpk_limit_s);
        const double speedup = glpk.ms / 1e3 / std::max(r->stage_c_s, 1e-6);
        if (glpk.optimal) {
          const bool agree = std::abs(glpk.objective - sc.clique.objective) <= 1e-6 * std::max(1.0, glpk.objective);
          std::printf("  stage C by glp_intopt: optimal %.4f in %.3f s -> ours %.0fx faster, optima %s\n",
                      glpk.objective, glpk.ms / 1e3, speedup, agree ? "agree" : "DIFFER");
        } else {
          std::printf("  stage C by glp_intopt: not solved within %.0f s (best integer objective %.4f) -> ours at "
                      "least %.0fx faster\n",
                      glpk_limit_s, glpk.objective, speedup);
        }
      }
    } else {
      std::printf("  stage C by glp_intopt: skipped (%zu loops: the dense MILP has ~n^2/2 rows)\n",
                  sc.candidate_loops.size());
    }
    std::printf("\n");
  }
  std::printf("peak RSS %s\n", FormatBytes(static_cast<std::uint64_t>(platform::ReadRss().peak_bytes)).c_str());
  return 0;
}
