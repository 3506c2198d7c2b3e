// SPDX-License-Identifier: BSD-3-Clause
// `commerge run DATASET_DIRS...`: the main job on recorded or generated data (see run_pipeline.hpp).
#include <cstdio>
#include <memory>

#include "apps/app_common.hpp"
#include "apps/app_descriptor_flags.hpp"
#include "apps/commands.hpp"
#include "apps/merge_flags.hpp"
#include "apps/run_pipeline.hpp"

namespace commerge::app {

Command AddRunCommand(CLI::App& root) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = root.add_subcommand(
      "run",
      "Robots and server in one process on KITTI-layout datasets (one per robot), every message LCM-encoded and "
      "counted: the exchange cascade per robot pair, the requested scans, submap registration, one frame per robot, "
      "alignment RMSE against ground truth, and the comparison with sending every scan. DATASET is DIR or "
      "DIR:FIRST-LAST (scans FIRST..LAST-1 of DIR as one robot: split a single-robot sequence by time).");
  cmd->add_option("datasets", o->datasets, "one KITTI-layout directory per robot (velodyne/*.bin, poses.txt, "
                                           "optional poses_gt.txt, times.txt)")
      ->required()
      ->expected(2, 8);
  AddRunFlags(cmd, o.get());
  return {cmd, [o, cmd]() {
            if (Status st = ApplyMergeProfile(*cmd, o->profile, o->sensor, &o->server); !st.ok()) {
              std::fprintf(stderr, "commerge run: %s\n", st.message().c_str());
              return static_cast<int>(kExitUsage);
            }
            if (cmd->count("--descriptor") == 0) o->descriptor.name = ProfileDescriptor(o->profile, o->descriptor.name);
            ApplySensorTauInter(cmd->count("--tau-inter") > 0, o->sensor, &o->server);
            return RunMergeJob(*o);
          }};
}

}  // namespace commerge::app
