// SPDX-License-Identifier: BSD-3-Clause
// `commerge run` between its steps (run_pipeline.cpp runs them, run_report.cpp prints and writes the results):
// the robots of the run, the server, the byte ledgers, and one outcome per exchange mode.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "apps/app_memory.hpp"
#include "apps/run_pipeline.hpp"
#include "core/agent/merge_round.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/robot_agent.hpp"
#include "core/descriptor/solid.hpp"
#include "core/eval/alignment_metrics.hpp"
#include "core/eval/byte_ledger.hpp"
#include "core/eval/loop_errors.hpp"
#include "core/eval/path_agreement.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/io/kitti_dataset_reader.hpp"

namespace commerge::app {

using RunClock = std::chrono::steady_clock;
double SecondsSince(RunClock::time_point t0);
/// printf-style formatting of one number.
std::string Fmt(const char* format, double v);

/// The paper's raw baseline counts every keyframe's scan as recorded: x, y, z, intensity as float32.
constexpr std::uint64_t kRawPointBytes = 16;

struct RobotRun {
  platform::RobotDataset data;
  std::unique_ptr<PlaceDescriptor> descriptor;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotAgent> agent;
  std::vector<std::size_t> keyframe_scan;  ///< scan index (within the slice) of each keyframe
  double seconds = 0.0;
  std::size_t scans = 0;
  /// The paper's baseline: every keyframe's scan as recorded (full resolution, kRawPointBytes per point), the
  /// "GB-scale local maps" a robot would ship without selection.
  std::uint64_t raw_keyframe_bytes = 0;
  /// Accepted intra-robot loops (checked against ground truth after the run, when there is one).
  struct Loop {
    std::uint32_t query = 0, match = 0;
    Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  };
  std::vector<Loop> loops;
};

/// A robot's loops against its ground truth are LoopErrors (core/eval/loop_errors.hpp); a loop is false beyond
/// these (FalseLoopCriterion's defaults).
constexpr double kFalseLoopTranslationM = FalseLoopCriterion{}.max_translation_m;
constexpr double kFalseLoopRotationDeg = FalseLoopCriterion{}.max_rotation_deg;

/// Keyframe trajectories of one robot: estimated (its map frame) and ground truth, with their times.
struct Trajectories {
  std::vector<Eigen::Isometry3d> estimated, ground_truth;
  std::vector<double> times_s;
  Eigen::Isometry3d T_gt_map = Eigen::Isometry3d::Identity();  ///< the robot's map frame in the ground truth
};

/// A placement against ground truth (paper's e_rmse, and the transform error).
struct PairEval {
  bool has_gt = false;
  double rmse_m = 0.0, max_error_m = 0.0;
  TransformError transform_error;
  std::string note;
};

/// One exchange mode's round and what it cost.
struct ModeOutcome {
  ExchangeMode mode = ExchangeMode::kStageABC;
  std::unique_ptr<ByteLedger> ledger;  ///< policies, fresh poses and scans of this mode
  MergeRoundResult round;
  std::vector<PairEval> pair_eval;   ///< per round.pairs entry (successful ones evaluated)
  std::vector<PairEval> robot_eval;  ///< robot r against robot 0 through the frame solution
  std::size_t scans_missing = 0;     ///< requested scans the robots no longer had
  double exchange_s = 0.0, merge_s = 0.0;
  std::uint64_t scan_bytes() const { return ledger->KindTotal(MessageKind::kScans).bytes; }
  std::size_t scans_requested() const;
  std::size_t pairs_merged() const;
};

struct RunJob {
  explicit RunJob(const RunOptions& o) : options(o), tag(o.tag.c_str()) {}
  const RunOptions& options;
  const char* tag;
  RunClock::time_point start = RunClock::now();
  std::vector<ExchangeMode> modes;
  DescriptorInputParams descriptor_input;
  double tau_intra = 0.05;  ///< the robots' loop gate (RobotDescriptor::tau_intra)
  std::string descriptor_text;
  std::vector<RobotRun> robots;
  MemorySetup memory;
  std::string report_dir;
  std::unique_ptr<MergeServer> server;
  ByteLedgerParams ledger_params;
  std::unique_ptr<ByteLedger> stream_ledger;  ///< keyframe records and pose updates, the same in every mode
  std::vector<Trajectories> trajectories;
  std::vector<LoopErrors> loop_errors;
  std::vector<ModeOutcome> outcomes;
  /// The joint pose graph over the final mode's accepted pairs (SolveJoint, after the modes): how its corrected
  /// keyframes agree along the shared path (pairs 0 when not measured).
  struct Joint {
    std::size_t edges = 0, used_edges = 0;
    PathAgreement agreement;
    std::string error;  ///< the solver's, when it refused
  } joint;
  double robots_s = 0.0, cascade_s = 0.0;
  std::int64_t robots_peak_rss = 0;
  /// Bytes the send-all mode puts on the wire (every stored scan and its fresh pose, beside the stream),
  /// counted whether or not that mode ran.
  std::uint64_t send_all_bytes = 0;

  int num_robots() const { return static_cast<int>(robots.size()); }
  std::uint64_t stream_bytes() const { return stream_ledger->Total().bytes; }
  std::uint64_t raw_keyframe_bytes() const;
};

// run_report.cpp: the results, side by side; the output files and pictures.
/// Solves the joint pose graph over the final mode's accepted pairs into job->joint.
void SolveJoint(RunJob* job);
/// Prints the mode table and the final mode's result (and keeps the text for the report's summary.md).
std::string PrintResults(const RunJob& job);
/// Writes transforms.txt, trajectories/, merged_map.pcd/.ply, and with --report the pictures, summary.md and
/// metrics.tsv. Returns the merged map's size: "N points", and the scans left out when it was full.
std::string WriteRunOutputs(const RunJob& job, const std::string& summary);
/// report/keyframes_<r>.tsv for every robot (--dump-keyframes).
void DumpKeyframes(const RunJob& job);
/// The robot's loops file (trajectories/robot_<r>_loops.txt).
Status WriteLoops(const RobotRun& r, const std::string& path);
/// The loop of `r` against its ground truth: E = (T_match_query_gt)^-1 T_match_query, in the query's frame
/// (core/eval LoopErrorTransform).
Eigen::Isometry3d LoopError(const RobotRun& r, const RobotRun::Loop& l);
/// Rotation angle of T [deg] (core/eval RotationAngleDeg).
double RotationDeg(const Eigen::Isometry3d& T);

}  // namespace commerge::app
