// SPDX-License-Identifier: BSD-3-Clause
// `commerge demo`: the README's main-job command. Generates a small two-robot urban world (`commerge sim`) and
// runs the whole pipeline on it (`commerge run`): robots with drifting odometry stream descriptors and poses,
// the server's cascade picks the few scans to exchange, registration merges the submaps, and the report
// compares every exchange mode with sending all scans. Ends with the alignment RMSE against ground truth.
#include <cstdio>
#include <memory>
#include <string>

#include "apps/app_common.hpp"
#include "apps/app_memory.hpp"
#include "apps/cmd_sim.hpp"
#include "apps/commands.hpp"
#include "apps/run_pipeline.hpp"

namespace commerge::app {

namespace {

struct DemoOptions {
  std::string out_dir = "out/demo";
  std::uint64_t seed = 7;
  int keyframes_per_robot = 800;
  int threads = 2;
  double max_rmse_m = 1.0;
  MemoryFlags memory;
};

int RunDemo(const DemoOptions& o) {
  // The world: both robots drive the same laps of a small street grid in the same direction, one starting half
  // a lap later, with a flat road and a smooth vehicle (no roll / pitch wobble): the case the paper's place
  // recognition parameters were tuned for. `commerge sim` and `commerge run` reproduce any other setting.
  SimOptions sim;
  sim.world = "urban";
  sim.overlap = "complete";
  sim.lidar = "vlp16";
  sim.robots = 2;
  sim.keyframes = o.keyframes_per_robot;
  sim.seed = o.seed;
  sim.direction = "same";
  sim.wobble_deg = 0.0;
  sim.out_dir = o.out_dir + "/data";
  sim.force = true;
  sim.threads = o.threads;
  sim.tag = "commerge demo (sim)";
  std::printf("commerge demo: 1/2 generating the world (commerge sim --world urban --robots 2 --overlap complete "
              "--lidar vlp16 --keyframes %d --seed %llu --direction same --wobble-deg 0 --out %s)\n",
              o.keyframes_per_robot, static_cast<unsigned long long>(o.seed), sim.out_dir.c_str());
  if (int rc = RunSim(sim); rc != kExitOk) return rc;

  RunOptions run;
  run.datasets = {sim.out_dir + "/robot_0", sim.out_dir + "/robot_1"};
  run.out_dir = o.out_dir;
  run.sensor = "vlp-16";
  // The simulator writes one scan per metre; a keyframe every 0.9 m keeps every scan despite odometry noise.
  run.keyframe_spacing_m = 0.9;
  run.threads = o.threads;
  run.memory = o.memory;
  // Two small robots: size the budget for them unless the user asks otherwise.
  if (run.memory.max_keyframes == 0) run.memory.max_keyframes = 2 * o.keyframes_per_robot + 100;
  if (run.memory.scan_store_mb == 0) run.memory.scan_store_mb = 64;
  run.tag = "commerge demo";
  std::printf("\ncommerge demo: 2/2 the pipeline (commerge run %s %s --lidar vlp-16 --keyframe-spacing-m 0.9 "
              "--out %s)\n",
              run.datasets[0].c_str(), run.datasets[1].c_str(), o.out_dir.c_str());
  RunSummary summary;
  const int rc = RunMergeJob(run, &summary);
  if (rc != kExitOk) return rc;
  if (summary.final_rmse_m.size() < 2 || !(summary.final_rmse_m[1] >= 0.0)) {
    std::fprintf(stderr, "commerge demo: robot 1 was not merged into robot 0's frame\n");
    return kExitFailure;
  }
  const double rmse = summary.final_rmse_m[1];
  if (rmse > o.max_rmse_m) {
    std::fprintf(stderr, "commerge demo: alignment RMSE %.3f m exceeds %.2f m: the merge is wrong\n", rmse, o.max_rmse_m);
    return kExitFailure;
  }
  std::printf("\ncommerge demo: correct merge, alignment RMSE %.3f m (< %.2f m); %.2f %% fewer bytes than sending every "
              "scan; report in %s/report/\n",
              rmse, o.max_rmse_m, summary.final_reduction_percent, o.out_dir.c_str());
  return kExitOk;
}

}  // namespace

Command AddDemoCommand(CLI::App& root) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* cmd = root.add_subcommand(
      "demo", "The main job on a generated two-robot urban world: commerge sim, then commerge run with every "
              "exchange mode side by side; fails unless the merge is correct (alignment RMSE below --max-rmse-m)");
  cmd->add_option("--out", o->out_dir, "Output directory (data/, merged map, trajectories, report/)")->capture_default_str();
  cmd->add_option("--seed", o->seed, "World seed")->capture_default_str();
  cmd->add_option("--keyframes", o->keyframes_per_robot, "Keyframes per robot (1 m apart)")
      ->check(CLI::Range(50, 100000))
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (scan casting, robots)")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_option("--max-rmse-m", o->max_rmse_m, "Largest alignment RMSE that counts as a correct merge [m]")
      ->capture_default_str();
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o]() -> int { return RunDemo(*o); }};
}

}  // namespace commerge::app
