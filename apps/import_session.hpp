// SPDX-License-Identifier: BSD-3-Clause
// `commerge import DIR --poses FILE [--gt FILE] --out OUT`: a scan session as offline mergers store one (a folder of
// .pcd / .ply / .bin scans and a KITTI, TUM or CSV pose file; platform/io/scan_session.hpp) into the KITTI-layout
// directory that `run`, `robot --data` and `feed` read:
//   OUT/velodyne/%06d.bin   scan k of the session (its order: by the number in the file name, else by name), float32
//                           x y z intensity, non-finite points dropped (counted per file in the summary)
//   OUT/poses.txt           pose k of the pose file (KITTI-12 T_frame_sensor)
//   OUT/times.txt           when the pose file has times: time k [s], as in the file
//   OUT/poses_gt.txt        with --gt: pose k of the ground-truth file (KITTI-12), which `commerge run` reads as
//                           ground truth
//   OUT/import_info.txt     "key: value" lines: the sources, formats, order, counts
#pragma once

#include <string>

#include "core/common/status.hpp"

namespace commerge::app {

struct SessionImportOptions {
  std::string dir;                   ///< folder of scans (the positional argument)
  std::string poses;                 ///< --poses: one pose per scan, paired by index
  std::string gt;                    ///< --gt: optional ground truth, one pose per scan ("" = none)
  std::string out;                   ///< --out
  std::string pose_format = "auto";  ///< --pose-format auto|kitti|tum|csv (for --poses)
  std::string gt_format = "auto";    ///< --gt-format auto|kitti|tum|csv (for --gt)
  bool force = false;                ///< --force: replace an earlier import in --out
  double progress_s = 5.0;           ///< --progress-s: seconds between progress lines on stderr
};

/// The output directory of either import (a recording or a session): created when missing; one that holds files is
/// refused unless `force`, which removes only what an import writes (velodyne/, point_times/, poses.txt,
/// poses_gt.txt, times.txt, import_info.txt) and nothing else.
Status PrepareImportOutput(const std::string& out, bool force);

/// Runs the import and prints its summary on stdout (errors on stderr, prefixed "commerge import: "). Returns
/// kExitOk, kExitUsage (bad options, an invalid argument such as scans and poses of different counts, --out
/// that would overwrite the input) or kExitFailure (unreadable input, i/o errors, a non-empty --out without --force).
int RunSessionImport(const SessionImportOptions& o);

}  // namespace commerge::app
