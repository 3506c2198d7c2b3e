// SPDX-License-Identifier: BSD-3-Clause
// `commerge run`: the main job. Robots (RobotAgent) and the server (MergeServer) live in one process; every
// message between them is LCM-encoded (platform/lcm/message_codec), counted in a byte ledger at its encoded
// size and decoded again before the receiver sees it, exactly as it would cross the network.
#include "apps/run_pipeline.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <atomic>
#include <thread>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/robot_agent.hpp"
#include "core/common/bytes.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/eval/alignment_metrics.hpp"
#include "core/eval/byte_ledger.hpp"
#include "core/exchange/exchange_policy.hpp"
#include "core/geometry/se3.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_reader.hpp"
#include "platform/io/pcd.hpp"
#include "platform/io/ply.hpp"
#include "platform/io/poses.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/memory/peak_rss.hpp"
#include "platform/report/png_writer.hpp"
#include "platform/report/report_charts.hpp"

namespace commerge::app {

namespace {

using Clock = std::chrono::steady_clock;
double SecondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string Bytes(std::uint64_t b) { return FormatBytes(static_cast<std::int64_t>(b)); }

// Progress on stderr: rewritten in place on a terminal, one line every 10 s otherwise.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0) {}
  void Update(const std::string& line) {
    if (!enabled_) return;
    const auto now = Clock::now();
    const double interval = tty_ ? 0.25 : 10.0;
    if (std::chrono::duration<double>(now - last_).count() < interval) return;
    last_ = now;
    if (tty_) {
      std::fprintf(stderr, "\r%-110s", line.c_str());
      dirty_ = true;
    } else {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
  }
  void Done() {
    if (enabled_ && tty_ && dirty_) std::fprintf(stderr, "\r%-110s\r", "");
    dirty_ = false;
  }

 private:
  bool enabled_, tty_, dirty_ = false;
  Clock::time_point last_{};
};

constexpr std::uint64_t kRawPointBytes = 16;  // x, y, z, intensity as float32 (KITTI .bin)

struct RobotRun {
  platform::RobotDataset data;
  std::unique_ptr<SolidDescriptor> solid;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotAgent> agent;
  std::vector<std::size_t> keyframe_scan;  ///< scan index (within the slice) of each keyframe
  double seconds = 0.0;
  std::size_t scans = 0;
  /// The paper's baseline: every keyframe's scan as recorded (full resolution, 16 B per point as in the
  /// KITTI .bin), the "GB-scale local maps" a robot would ship without selection.
  std::uint64_t raw_keyframe_bytes = 0;
  /// Accepted intra-robot loops (checked against ground truth after the run, when there is one).
  struct Loop {
    std::uint32_t query = 0, match = 0;
    Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  };
  std::vector<Loop> loops;
};

/// Intra-robot loops whose ICP transform is off the ground truth by more than these are counted as false.
constexpr double kFalseLoopTranslationM = 2.0;
constexpr double kFalseLoopRotationDeg = 10.0;

/// The robot's loops against its ground truth: how many are false (beyond the limits above), and the median
/// and largest translation error [m]. checked = -1 without ground truth.
struct LoopErrors {
  long long checked = -1;
  long long wrong = 0;
  double median_m = 0.0;
  double max_m = 0.0;
};

Eigen::Isometry3d LoopError(const RobotRun& r, const RobotRun::Loop& l) {
  const Eigen::Isometry3d& gt_q = r.data.ground_truth[r.keyframe_scan[l.query]];
  const Eigen::Isometry3d& gt_m = r.data.ground_truth[r.keyframe_scan[l.match]];
  return (gt_m.inverse() * gt_q).inverse() * l.T_match_query;
}

double RotationDeg(const Eigen::Isometry3d& T) { return RotationAngleRad(T.linear()) * 180.0 / 3.14159265358979323846; }

LoopErrors CheckLoops(const RobotRun& r) {
  LoopErrors out;
  if (r.data.ground_truth.empty()) return out;
  out.checked = 0;
  std::vector<double> errors;
  for (const RobotRun::Loop& l : r.loops) {
    if (l.query >= r.keyframe_scan.size() || l.match >= r.keyframe_scan.size()) continue;
    const Eigen::Isometry3d error = LoopError(r, l);
    ++out.checked;
    out.wrong += error.translation().norm() > kFalseLoopTranslationM || RotationDeg(error) > kFalseLoopRotationDeg;
    errors.push_back(error.translation().norm());
  }
  if (!errors.empty()) {
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(errors.size() / 2), errors.end());
    out.median_m = errors[errors.size() / 2];
    out.max_m = *std::max_element(errors.begin(), errors.end());
  }
  return out;
}

// The robot's accepted loops, one line each: keyframes, the loop edge's T_match_query, and with ground truth its error
// E = (T_match_query_gt)^-1 T_match_query expressed in the query's frame (translation and rotation angle).
Status WriteLoops(const RobotRun& r, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return IoError("cannot write " + path);
  std::fprintf(f, "# query match  tx ty tz qx qy qz qw (T_match_query: ICP, refined by GICP where the robot did)%s\n",
               r.data.ground_truth.empty() ? "" : "  ex ey ez [m] e_rot [deg] (error against ground truth)");
  for (const RobotRun::Loop& l : r.loops) {
    const Eigen::Quaterniond q(l.T_match_query.linear());
    const Eigen::Vector3d& t = l.T_match_query.translation();
    std::fprintf(f, "%u %u %.4f %.4f %.4f %.6f %.6f %.6f %.6f", l.query, l.match, t.x(), t.y(), t.z(), q.x(), q.y(),
                 q.z(), q.w());
    if (!r.data.ground_truth.empty() && l.query < r.keyframe_scan.size() && l.match < r.keyframe_scan.size()) {
      const Eigen::Isometry3d error = LoopError(r, l);
      std::fprintf(f, " %.4f %.4f %.4f %.4f", error.translation().x(), error.translation().y(),
                   error.translation().z(), RotationDeg(error));
    }
    std::fprintf(f, "\n");
  }
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok) return IoError("error writing " + path);
  return Status::Ok();
}

// The wire: encode, count, decode. The receiver only ever sees the decoded copy.
class Wire {
 public:
  explicit Wire(ByteLedger* ledger) : ledger_(ledger) {}
  template <typename Msg, typename Encode, typename Decode>
  Result<Msg> Send(const Msg& msg, int robot, MessageKind kind, Direction dir, Encode encode, Decode decode) {
    if (Status st = encode(msg, &buffer_); !st.ok()) return st;
    ledger_->Record(robot, kind, dir, buffer_.size());
    return decode(Span<const std::uint8_t>(buffer_));
  }
  void set_ledger(ByteLedger* ledger) { ledger_ = ledger; }

 private:
  ByteLedger* ledger_;
  std::vector<std::uint8_t> buffer_;
};

// Messages one robot sent, decoded, in order: delivered to the server after the robots ran (they run in
// parallel threads; the server's state does not depend on how their streams interleave).
struct OutboxEntry {
  bool is_batch = true;
  std::size_t encoded_bytes = 0;
  KeyframeBatch batch;
  PoseUpdate update;
};

// Takes what the robot has to say now and puts it on its wire (encode -> bytes -> decode).
Status FlushRobot(RobotRun& r, std::vector<std::uint8_t>* buffer, std::vector<OutboxEntry>* outbox, bool all) {
  KeyframeBatch batch;
  PoseUpdate update;
  while (true) {
    const std::size_t unsent = r.agent->mapper().num_keyframes() - r.agent->keyframes_sent();
    if (unsent == 0 || (!all && unsent < 256)) break;
    auto taken = r.agent->TakeKeyframeBatch(0, &batch);
    if (!taken.ok()) return taken.status();
    if (!*taken) continue;  // only keyframes without a valid descriptor: their poses are queued
    if (Status st = platform::EncodeKeyframeBatch(batch, buffer); !st.ok()) return st;
    auto rx = platform::DecodeKeyframeBatch(Span<const std::uint8_t>(*buffer));
    if (!rx.ok()) return rx.status();
    OutboxEntry e;
    e.encoded_bytes = buffer->size();
    e.batch = std::move(*rx);
    outbox->push_back(std::move(e));
  }
  while (r.agent->TakePoseUpdate(0, &update)) {
    if (Status st = platform::EncodePoseUpdate(update, buffer); !st.ok()) return st;
    auto rx = platform::DecodePoseUpdate(Span<const std::uint8_t>(*buffer));
    if (!rx.ok()) return rx.status();
    OutboxEntry e;
    e.is_batch = false;
    e.encoded_bytes = buffer->size();
    e.update = std::move(*rx);
    outbox->push_back(std::move(e));
  }
  return Status::Ok();
}

struct PairEval {
  bool has_gt = false;
  double rmse_m = 0.0, max_error_m = 0.0;
  TransformError transform_error;
  std::string note;
};

struct ModeOutcome {
  ExchangeMode mode = ExchangeMode::kStageABC;
  ExchangePlan plan;
  std::unique_ptr<ByteLedger> ledger;
  std::vector<PairMergeResult> pairs;
  std::vector<double> pair_seconds;   ///< registration time of every attempt
  std::vector<int> pair_widenings;    ///< times the pair's selection was widened after a refusal
  std::vector<PairEval> pair_eval;
  bool frames_ok = false;
  FrameSolution frames;
  std::string frames_error;
  std::vector<PairEval> robot_eval;  ///< robot r against robot 0 through the frame solution
  std::size_t scans_missing = 0;
  double exchange_s = 0.0, merge_s = 0.0;
  std::uint64_t scan_bytes() const { return ledger->KindTotal(MessageKind::kScans).bytes; }
};

// Keyframe trajectories: estimated (robot map frame) and ground truth (world), per robot.
struct Trajectories {
  std::vector<Eigen::Isometry3d> estimated, ground_truth;
  std::vector<double> times_s;
  Eigen::Isometry3d T_world_map = Eigen::Isometry3d::Identity();  ///< ground truth of the robot's map frame
};

Trajectories KeyframeTrajectories(const RobotRun& r) {
  Trajectories t;
  const RobotMapper& m = r.agent->mapper();
  for (std::size_t k = 0; k < m.num_keyframes(); ++k) {
    t.estimated.push_back(m.pose(k));
    const std::size_t s = r.keyframe_scan[k];
    if (!r.data.ground_truth.empty()) t.ground_truth.push_back(r.data.ground_truth[s]);
    t.times_s.push_back(r.data.times_s.empty() ? static_cast<double>(s) : r.data.times_s[s]);
  }
  if (!t.ground_truth.empty() && !t.estimated.empty()) t.T_world_map = t.ground_truth[0] * t.estimated[0].inverse();
  return t;
}

PairEval Evaluate(const Trajectories& a, const Trajectories& b, const Eigen::Isometry3d& T_a_b) {
  PairEval e;
  if (a.ground_truth.empty() || b.ground_truth.empty()) {
    e.note = "no ground truth";
    return e;
  }
  auto rmse = InterRobotAlignmentRmse(Span<const Eigen::Isometry3d>(a.estimated), Span<const Eigen::Isometry3d>(a.ground_truth),
                                      Span<const Eigen::Isometry3d>(b.estimated), Span<const Eigen::Isometry3d>(b.ground_truth),
                                      T_a_b);
  if (!rmse.ok()) {
    e.note = rmse.status().message();
    return e;
  }
  e.has_gt = true;
  e.rmse_m = rmse->rmse_m;
  e.max_error_m = rmse->max_error_m;
  e.transform_error = ComputeTransformError(T_a_b, a.T_world_map.inverse() * b.T_world_map);
  return e;
}

std::string PoseText(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d t = T.translation();
  return "t = (" + Fmt("%.2f", t.x()) + ", " + Fmt("%.2f", t.y()) + ", " + Fmt("%.2f", t.z()) + ") m, yaw " +
         Fmt("%.2f", YawRad(T.linear()) * 180.0 / 3.14159265358979323846) + " deg";
}

// Appends robot r's stored scans placed with T_world_robot, voxelised in batches so memory stays bounded.
void AddRobotMap(const RobotRun& r, std::uint16_t id, const Eigen::Isometry3d& T_world_robot, double voxel_m,
                 std::vector<PointXYZI>* map, std::vector<std::uint16_t>* ids) {
  std::vector<PointXYZI> scan, batch, voxels;
  std::vector<std::uint8_t> spill;
  VoxelGrid grid;
  VoxelGridParams vp;
  vp.voxel_size_m = voxel_m;
  const RobotMapper& m = r.agent->mapper();
  auto flush = [&]() {
    if (batch.empty()) return;
    if (grid.Downsample(Span<const PointXYZI>(batch), vp, &voxels).ok()) {
      map->insert(map->end(), voxels.begin(), voxels.end());
      ids->insert(ids->end(), voxels.size(), id);
    }
    batch.clear();
  };
  for (std::size_t k = 0; k < m.num_keyframes(); ++k) {
    if (!r.store->GetPoints(static_cast<std::uint32_t>(k), &scan, &spill).ok()) continue;
    const Eigen::Isometry3f T = (T_world_robot * m.pose(k)).cast<float>();
    for (const PointXYZI& p : scan) {
      const Eigen::Vector3f q = T * Eigen::Vector3f(p.x, p.y, p.z);
      batch.push_back({q.x(), q.y(), q.z(), p.intensity});
    }
    if (batch.size() > 2000000) flush();
  }
  flush();
}

// Min-pooled descriptor distance matrix (rows = alpha keyframes) for the report picture.
platform::HeatmapInput AffinityPicture(const RobotKeyframeDb& a, const RobotKeyframeDb& b, int max_cells) {
  platform::HeatmapInput h;
  h.rows = static_cast<int>(std::min<std::size_t>(a.size(), static_cast<std::size_t>(max_cells)));
  h.cols = static_cast<int>(std::min<std::size_t>(b.size(), static_cast<std::size_t>(max_cells)));
  h.values.assign(static_cast<std::size_t>(h.rows) * static_cast<std::size_t>(h.cols), std::nanf(""));
  const std::size_t D = kKeyframeDescriptorDim;
  // Subsample very large matrices (at most ~40M distances): the picture needs the structure, not every cell.
  const std::size_t stride_a = std::max<std::size_t>(1, a.size() * b.size() / 40000000 + 1);
  for (std::size_t i = 0; i < a.size(); i += (stride_a > 1 ? stride_a : 1)) {
    if (!a.valid[i]) continue;
    const int pr = static_cast<int>(i * static_cast<std::size_t>(h.rows) / a.size());
    const float* x = &a.descriptors[i * D];
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (!b.valid[j]) continue;
      const float* y = &b.descriptors[j * D];
      float dot = 0.0f;
      for (std::size_t d = 0; d < D; ++d) dot += x[d] * y[d];
      const float dist = std::sqrt(std::max(0.0f, 2.0f - 2.0f * dot));
      const int pc = static_cast<int>(j * static_cast<std::size_t>(h.cols) / b.size());
      float& v = h.values[static_cast<std::size_t>(pr) * static_cast<std::size_t>(h.cols) + static_cast<std::size_t>(pc)];
      if (std::isnan(v) || dist < v) v = dist;
    }
  }
  h.vmin = 0.0f;
  h.vmax = 0.6f;
  h.max_grid_px = 800;
  return h;
}

int CellOf(std::size_t index, std::size_t n, int cells) {
  return n == 0 ? 0 : static_cast<int>(index * static_cast<std::size_t>(cells) / n);
}

struct ReportWriter {
  std::string dir;
  std::vector<std::string> written;
  std::vector<std::string> failed;
  void Write(const std::string& name, const Result<platform::RgbImage>& image) {
    const std::string path = dir + "/" + name;
    if (!image.ok()) {
      failed.push_back(name + ": " + image.status().message());
      return;
    }
    if (Status st = platform::WritePng(path, *image); !st.ok()) {
      failed.push_back(st.message());
      return;
    }
    written.push_back(path);
  }
};

}  // namespace

void AddRunFlags(CLI::App* cmd, RunOptions* o) {
  cmd->add_option("--out", o->out_dir, "output directory (merged map, trajectories, transforms, report/)")
      ->capture_default_str();
  cmd->add_option("--modes", o->modes,
                  "exchange modes run side by side: send-all, A, A+B, A+C, A+B+C (the last gives the final result)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--lidar", o->sensor, "SOLiD sensor preset of the robots' LiDAR (hdl-64e, vlp-16, os1-64, os1-128, "
                                        "os2-128, avia, aeva)")
      ->capture_default_str();
  AddSolidMinZFlag(cmd, &o->solid_min_z_m);
  cmd->add_flag("--gt-from-poses", o->gt_from_poses,
                "without poses_gt.txt, use the poses file as ground truth (real sequences split into robots)");
  cmd->add_option("--tau-inter", o->tau_inter, "stage A descriptor distance threshold")->capture_default_str();
  cmd->add_option("--tau-area", o->tau_area, "stage A minimal cluster span area [cells]")->capture_default_str();
  AddSequenceHalfWindowFlag(cmd, &o->sequence_half_window);
  cmd->add_option("--tau-con-m", o->tau_con_m, "stage C positional consistency bound [m]")->capture_default_str();
  cmd->add_option("--min-submap-scans", o->min_submap_scans,
                  "fewest scans asked of each robot per pair: L_K's keyframes plus the nearest other keyframes of "
                  "stage A's loops (0 = exactly L_K's, the paper's policy)")
      ->check(CLI::Range(0u, kMaxMinScansPerRobot))
      ->capture_default_str();
  cmd->add_option("--max-widen-steps", o->max_widen_steps,
                  "when registration refuses a pair, ask again for up to twice its scans (more of stage A's "
                  "keyframes) and register again, at most this many times (0 = the paper's single exchange)")
      ->check(CLI::Range(0, 8))
      ->capture_default_str();
  cmd->add_option("--keyframe-spacing-m", o->keyframe_spacing_m,
                  "robots take a keyframe every this many metres (paper 1.0; datasets written at exactly 1 m "
                  "keyframes need a little less, e.g. 0.9, or odometry noise skips every other one)")
      ->check(CLI::Range(0.05, 100.0))
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "robots processed in parallel")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_flag("!--no-report", o->report, "skip the PNG report pictures");
  cmd->add_flag("!--no-progress", o->progress, "no progress line on stderr");
  AddMemoryFlags(cmd, &o->memory);
}

int RunMergeJob(const RunOptions& o, RunSummary* summary_out) {
  const char* tag = o.tag.c_str();
  const auto t_job = Clock::now();
  // ---- inputs
  std::vector<ExchangeMode> modes;
  for (const std::string& name : o.modes) {
    auto m = ExchangeModeFromName(name);
    if (!m.ok()) {
      std::fprintf(stderr, "%s: --modes: %s\n", tag, m.status().message().c_str());
      return kExitUsage;
    }
    modes.push_back(*m);
  }
  if (modes.empty()) {
    std::fprintf(stderr, "%s: --modes is empty\n", tag);
    return kExitUsage;
  }
  const int num_robots = static_cast<int>(o.datasets.size());
  if (num_robots < 2 || num_robots > kFrameSolverMaxRobots) {
    std::fprintf(stderr, "%s: %d datasets given; one per robot, 2..%d\n", tag, num_robots, kFrameSolverMaxRobots);
    return kExitUsage;
  }
  auto solid_params = SolidParamsFromFlags(o.sensor, o.solid_min_z_m);
  if (!solid_params.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, solid_params.status().message().c_str());
    return kExitUsage;
  }
  std::vector<RobotRun> robots(static_cast<std::size_t>(num_robots));
  for (int r = 0; r < num_robots; ++r) {
    auto spec = platform::ParseRobotDatasetSpec(o.datasets[static_cast<std::size_t>(r)]);
    if (!spec.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, spec.status().message().c_str());
      return kExitUsage;
    }
    auto data = platform::OpenRobotDataset(*spec, o.gt_from_poses);
    if (!data.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, data.status().message().c_str());
      return kExitFailure;
    }
    robots[static_cast<std::size_t>(r)].data = std::move(*data);
  }

  // ---- memory: the budget of the whole run (robots and server), checked before any work
  MemoryFlags memory = o.memory;
  if (memory.robots == 0) memory.robots = num_robots;
  MemorySetup setup;
  if (int rc = SetUpMemory(AppKind::kRun, memory, &setup, /*print_table=*/false); rc != kExitOk) return rc;
  if (setup.config.max_robots < num_robots) {
    std::fprintf(stderr, "%s: --robots %d is fewer than the %d datasets\n", tag, setup.config.max_robots, num_robots);
    return kExitUsage;
  }
  std::printf("%s: %d robots; %s\n", tag, num_robots, setup.verdict.c_str());
  std::error_code ec;
  const std::string report_dir = o.out_dir + "/report";
  std::filesystem::create_directories(report_dir, ec);
  if (!ec) std::filesystem::create_directories(o.out_dir + "/trajectories", ec);
  if (ec) {
    std::fprintf(stderr, "%s: cannot create %s: %s\n", tag, o.out_dir.c_str(), ec.message().c_str());
    return kExitFailure;
  }

  // ---- server
  MergeServerParams server_params;
  server_params.cascade.stage_a.tau_inter = o.tau_inter;
  server_params.cascade.stage_a.tau_area = static_cast<std::uint64_t>(std::max<std::int64_t>(0, o.tau_area));
  server_params.cascade.stage_a.sequence_half_window = o.sequence_half_window;
  server_params.cascade.stage_c.tau_con_m = o.tau_con_m;
  server_params.cascade.policy.min_scans_per_robot = o.min_submap_scans;
  server_params.max_widen_steps = o.max_widen_steps;
  server_params.max_submap_points = static_cast<std::size_t>(setup.config.max_submap_points);
  MergeServer server(num_robots, static_cast<std::size_t>(setup.config.max_keyframes_per_robot), server_params);
  if (Status st = ValidateMergeServerParams(server_params); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  ByteLedgerParams ledger_params;
  ledger_params.max_robots = static_cast<std::size_t>(num_robots);
  ByteLedger stream_ledger(ledger_params);
  Wire wire(&stream_ledger);

  // ---- robots: keyframes, SOLiD, scan store, loop closure; descriptors and poses stream to the server
  Progress progress(o.progress);
  RobotMapperCapacity capacity;
  capacity.max_keyframes = static_cast<std::size_t>(setup.config.max_keyframes_per_robot);
  capacity.max_points_per_raw_scan = static_cast<std::size_t>(setup.config.max_points_per_raw_scan);
  capacity.max_points_per_stored_scan = static_cast<std::size_t>(setup.config.max_points_per_stored_scan);
  std::size_t total_scans = 0;
  for (const RobotRun& r : robots) total_scans += r.data.scan_files.size();
  const auto t_robots = Clock::now();
  for (int ri = 0; ri < num_robots; ++ri) {
    RobotRun& r = robots[static_cast<std::size_t>(ri)];
    auto solid = SolidDescriptor::Create(*solid_params);
    auto store_params = ScanStoreParamsFromBudget(setup.config, ScanStorePolicy::kEvictOldest);
    if (!solid.ok() || !store_params.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, (!solid.ok() ? solid.status() : store_params.status()).message().c_str());
      return kExitFailure;
    }
    r.solid = std::make_unique<SolidDescriptor>(std::move(*solid));
    auto store = ScanStore::Create(*store_params);
    if (!store.ok()) {
      std::fprintf(stderr, "%s: robot %d scan store: %s\n", tag, ri, store.status().message().c_str());
      return kExitFailure;
    }
    r.store = std::move(*store);
    RobotAgentParams agent_params;
    agent_params.mapper.keyframer.keyframe_spacing_m = o.keyframe_spacing_m;
    r.agent = std::make_unique<RobotAgent>(ri, agent_params, capacity, r.solid.get(), r.store.get());
  }
  // Each robot in its own thread (they share nothing); at most --threads at once.
  std::vector<std::vector<OutboxEntry>> outboxes(static_cast<std::size_t>(num_robots));
  std::vector<Status> robot_status(static_cast<std::size_t>(num_robots));
  std::vector<std::atomic<std::size_t>> scans_done(static_cast<std::size_t>(num_robots));
  for (auto& c : scans_done) c = 0;
  std::atomic<int> robots_finished{0};
  auto run_robot = [&](int ri) {
    RobotRun& r = robots[static_cast<std::size_t>(ri)];
    std::vector<OutboxEntry>& outbox = outboxes[static_cast<std::size_t>(ri)];
    std::vector<std::uint8_t> buffer;
    const auto t0 = Clock::now();
    const Eigen::Isometry3d T_first_inv = r.data.poses.front().inverse();
    Status st;
    for (std::size_t s = 0; s < r.data.scan_files.size() && st.ok(); ++s) {
      auto cloud = platform::ReadKittiBin(r.data.scan_files[s]);
      if (!cloud.ok()) {
        st = cloud.status();
        break;
      }
      // The robot knows only its own odometry, from its own start: the slice's first pose is its origin.
      auto step = r.agent->AddScan(Span<const PointXYZI>(cloud->points), T_first_inv * r.data.poses[s]);
      if (!step.ok()) {
        st = Status(step.status().code(), "scan " + r.data.scan_files[s] + ": " + step.status().message());
        break;
      }
      if (step->is_keyframe) {
        r.keyframe_scan.push_back(s);
        r.raw_keyframe_bytes += static_cast<std::uint64_t>(cloud->points.size()) * kRawPointBytes;
      }
      if (step->loop.verdict == LoopVerdict::kAccepted) {
        r.loops.push_back({step->loop.loop.query, step->loop.loop.match, step->loop.loop.T_match_query});
      }
      ++r.scans;
      scans_done[static_cast<std::size_t>(ri)] = s + 1;
      st = FlushRobot(r, &buffer, &outbox, false);
    }
    if (st.ok()) st = r.agent->Finish();
    if (st.ok()) st = FlushRobot(r, &buffer, &outbox, true);
    robot_status[static_cast<std::size_t>(ri)] = st;
    r.seconds = SecondsSince(t0);
    ++robots_finished;
  };
  {
    const int threads = std::max(1, std::min(o.threads, num_robots));
    std::atomic<int> next{0};
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) {
      pool.emplace_back([&]() {
        for (int ri = next++; ri < num_robots; ri = next++) run_robot(ri);
      });
    }
    // Progress while the robots work.
    while (true) {
      std::size_t done = 0;
      for (const auto& c : scans_done) done += c;
      std::string line = "robots: " + Fmt("%.0f", 100.0 * static_cast<double>(done) / static_cast<double>(total_scans)) +
                         " % of " + std::to_string(total_scans) + " scans (";
      for (int ri = 0; ri < num_robots; ++ri) {
        line += (ri ? ", " : "") + std::to_string(scans_done[static_cast<std::size_t>(ri)]) + "/" +
                std::to_string(robots[static_cast<std::size_t>(ri)].data.scan_files.size());
      }
      const double el = SecondsSince(t_robots);
      line += "), " + Fmt("%.1f", static_cast<double>(done) / std::max(el, 1e-9)) + " scans/s";
      progress.Update(line);
      if (robots_finished.load() == num_robots) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    for (std::thread& t : pool) t.join();
  }
  for (int ri = 0; ri < num_robots; ++ri) {
    const Status& st = robot_status[static_cast<std::size_t>(ri)];
    if (!st.ok()) {
      progress.Done();
      std::fprintf(stderr, "%s: robot %d: %s\n", tag, ri, st.message().c_str());
      return kExitFailure;
    }
    // The streams reach the server, each in its robot's order.
    for (const OutboxEntry& e : outboxes[static_cast<std::size_t>(ri)]) {
      stream_ledger.Record(ri, e.is_batch ? MessageKind::kKeyframes : MessageKind::kPoseUpdates,
                           Direction::kRobotToServer, e.encoded_bytes);
      Status rx = e.is_batch ? server.OnKeyframeBatch(e.batch) : server.OnPoseUpdate(e.update);
      if (!rx.ok()) {
        progress.Done();
        std::fprintf(stderr, "%s: server refused a message of robot %d: %s\n", tag, ri, rx.message().c_str());
        return kExitFailure;
      }
    }
    outboxes[static_cast<std::size_t>(ri)].clear();
  }
  progress.Done();
  const std::int64_t robots_peak_rss = platform::ReadRss().peak_bytes;
  const double robots_s = SecondsSince(t_robots);
  std::printf("\nrobots (%.1f s):\n", robots_s);
  std::vector<Trajectories> traj;
  std::vector<LoopErrors> loop_errors(static_cast<std::size_t>(num_robots));  // checked once, printed twice
  for (int ri = 0; ri < num_robots; ++ri) {
    const RobotRun& r = robots[static_cast<std::size_t>(ri)];
    const RobotMapper& m = r.agent->mapper();
    const ScanStoreStats& ss = r.store->stats();
    const LoopErrors& le = loop_errors[static_cast<std::size_t>(ri)] = CheckLoops(r);
    const std::string false_text =
        (le.checked < 0 ? std::string()
                        : " (" + std::to_string(le.wrong) + " false against ground truth" +
                              (le.checked > 0 ? ", error median " + Fmt("%.3f", le.median_m) + " m, max " +
                                                    Fmt("%.3f", le.max_m) + " m"
                                              : std::string()) +
                              ")") +
        ", " + std::to_string(m.stats().loops_refined) + " refined by GICP, " +
        std::to_string(m.stats().loops_implausible) + " refused as implausible";
    std::printf("  robot %d  %-40s %zu scans -> %zu keyframes (%llu invalid descriptors), %llu loops%s, store %zu "
                "scans %s (%llu evicted), %.1f s; ground truth: %s\n",
                ri, r.data.name.c_str(), r.scans, m.num_keyframes(),
                static_cast<unsigned long long>(m.stats().invalid_descriptors),
                static_cast<unsigned long long>(m.stats().loops_accepted), false_text.c_str(), ss.num_scans,
                Bytes(ss.used_bytes).c_str(), static_cast<unsigned long long>(ss.num_evicted), r.seconds,
                r.data.ground_truth.empty() ? "none" : r.data.ground_truth_source.c_str());
    traj.push_back(KeyframeTrajectories(r));
  }
  const MergeServerStats& sst = server.stats();
  std::printf("  streamed to the server: keyframes %s (%llu records in %llu batches), pose updates %s (%llu)\n",
              Bytes(stream_ledger.KindTotal(MessageKind::kKeyframes).bytes).c_str(),
              static_cast<unsigned long long>(sst.records), static_cast<unsigned long long>(sst.batches),
              Bytes(stream_ledger.KindTotal(MessageKind::kPoseUpdates).bytes).c_str(),
              static_cast<unsigned long long>(sst.pose_updates));

  // ---- server: the cascade per pair
  const auto t_cascade = Clock::now();
  if (Status st = server.RunCascades(); !st.ok()) {
    std::fprintf(stderr, "%s: server: %s\n", tag, st.message().c_str());
    return kExitFailure;
  }
  const double cascade_s = SecondsSince(t_cascade);
  std::printf("\nserver cascade (%.3f s):\n", cascade_s);
  for (int a = 0; a < num_robots; ++a) {
    for (int b = a + 1; b < num_robots; ++b) {
      const ExchangeCascadeResult* c = server.cascade(a, b);
      if (!c) continue;
      std::string padded;
      if (c->policy.alpha.padded_scans + c->policy.beta.padded_scans > 0) {
        padded = " (policy " + std::to_string(c->policy.alpha.keyframes.size()) + " + " +
                 std::to_string(c->policy.beta.keyframes.size()) + " scans with " +
                 std::to_string(c->policy.alpha.padded_scans) + " + " + std::to_string(c->policy.beta.padded_scans) +
                 " more of stage A's keyframes, --min-submap-scans)";
      }
      std::printf("  pair %d-%d: %s; L_seq %zu loops (%zu x %zu keyframes), stage B %zu + %zu scans (%s), |L_K| = %zu%s; "
                  "A %.3f s, B %.3f s, C %.3f s%s%s\n",
                  a, b, CascadeOutcomeName(c->outcome), c->stage_a.cells.size(), c->stage_b_vertices_alpha,
                  c->stage_b_vertices_beta, c->stage_b.selected_left.size(), c->stage_b.selected_right.size(),
                  BalancedCoverStatusName(c->stage_b.status), c->stage_c.selected_loops.size(), padded.c_str(),
                  c->stage_a_s, c->stage_b_s, c->stage_c_s, c->no_candidate_reason.empty() ? "" : "; ",
                  c->no_candidate_reason.c_str());
    }
  }

  // ---- every mode: plan, policies to the robots, scans back, submaps, registration, frames
  std::vector<ModeOutcome> outcomes;
  for (ExchangeMode mode : modes) {
    ModeOutcome out;
    out.mode = mode;
    out.ledger = std::make_unique<ByteLedger>(ledger_params);
    wire.set_ledger(out.ledger.get());
    server.ClearScans();
    auto plan = server.Plan(mode);
    if (!plan.ok()) {
      std::fprintf(stderr, "%s: plan %s: %s\n", tag, ExchangeModeName(mode), plan.status().message().c_str());
      return kExitFailure;
    }
    out.plan = std::move(*plan);
    // Policies to the robots, their answers (the requested keyframes' current poses, then the scans) to the server.
    std::vector<ScanChunk> chunks;
    auto deliver = [&](const std::vector<ScanRequest>& requests) -> bool {
      for (const ScanRequest& req : requests) {
        RobotRun& r = robots[static_cast<std::size_t>(req.robot_id)];
        ScanRequest delivered = req;
        if (mode != ExchangeMode::kSendAll) {  // send-all needs no policy: every robot sends everything
          auto rx = wire.Send(req, req.robot_id, MessageKind::kPolicies, Direction::kServerToRobot,
                              platform::EncodeScanRequest, platform::DecodeScanRequest);
          if (!rx.ok()) {
            std::fprintf(stderr, "%s: policy: %s\n", tag, rx.status().message().c_str());
            return false;
          }
          delivered = std::move(*rx);
        }
        chunks.clear();
        PoseUpdate fresh_poses;
        auto answer = r.agent->AnswerRequest(delivered, 0, &chunks, &fresh_poses, /*remember_poses=*/false);
        if (!answer.ok()) {
          std::fprintf(stderr, "%s: robot %d: %s\n", tag, req.robot_id, answer.status().message().c_str());
          return false;
        }
        if (!fresh_poses.keyframes.empty()) {  // current poses of the requested keyframes, before their scans
          auto rx = wire.Send(fresh_poses, req.robot_id, MessageKind::kPoseUpdates, Direction::kRobotToServer,
                              platform::EncodePoseUpdate, platform::DecodePoseUpdate);
          if (!rx.ok()) {
            std::fprintf(stderr, "%s: pose update: %s\n", tag, rx.status().message().c_str());
            return false;
          }
          if (Status st = server.OnPoseUpdate(*rx); !st.ok()) {
            std::fprintf(stderr, "%s: server refused a pose update: %s\n", tag, st.message().c_str());
            return false;
          }
        }
        out.scans_missing += answer->missing.size();
        for (const ScanChunk& c : chunks) {
          auto rx = wire.Send(c, req.robot_id, MessageKind::kScans, Direction::kRobotToServer,
                              platform::EncodeScanChunk, platform::DecodeScanChunk);
          if (!rx.ok()) {
            std::fprintf(stderr, "%s: scan chunk: %s\n", tag, rx.status().message().c_str());
            return false;
          }
          if (Status st = server.OnScanChunk(*rx); !st.ok()) {
            std::fprintf(stderr, "%s: server refused a scan chunk: %s\n", tag, st.message().c_str());
          }
        }
      }
      return true;
    };
    // Registers the pairs of `selections`; a pair already in out.pairs (a widened retry) replaces its result.
    auto merge = [&](const std::vector<PairSelection>& selections) -> bool {
      for (const PairSelection& sel : selections) {
        const auto t0 = Clock::now();
        auto merged = server.MergePair(sel);
        if (!merged.ok()) {
          std::fprintf(stderr, "%s: merge %d-%d: %s\n", tag, sel.alpha, sel.beta, merged.status().message().c_str());
          return false;
        }
        PairEval e;
        if (merged->attempted && merged->registration.success()) {
          e = Evaluate(traj[static_cast<std::size_t>(sel.alpha)], traj[static_cast<std::size_t>(sel.beta)],
                       merged->registration.T_target_source);
        }
        std::size_t i = 0;
        while (i < out.pairs.size() && !(out.pairs[i].alpha == sel.alpha && out.pairs[i].beta == sel.beta)) ++i;
        if (i == out.pairs.size()) {
          out.pairs.emplace_back();
          out.pair_eval.emplace_back();
          out.pair_seconds.push_back(0.0);
          out.pair_widenings.push_back(0);
        } else {
          ++out.pair_widenings[i];
        }
        out.pair_seconds[i] += SecondsSince(t0);
        out.pair_eval[i] = e;
        out.pairs[i] = std::move(*merged);
        progress.Update("mode " + std::string(ExchangeModeName(mode)) + ": merged pair " + std::to_string(sel.alpha) +
                        "-" + std::to_string(sel.beta));
      }
      return true;
    };
    const auto t_ex = Clock::now();
    if (!deliver(out.plan.requests)) return kExitFailure;
    out.exchange_s = SecondsSince(t_ex);
    const auto t_merge = Clock::now();
    if (!merge(out.plan.pairs)) return kExitFailure;
    // Widening: pairs that registration refused ask for more of stage A's scans and register again.
    double widen_exchange_s = 0.0;
    for (int step = 0; step < server.params().max_widen_steps; ++step) {
      auto wider = server.WidenPlan(out.plan, Span<const PairMergeResult>(out.pairs),
                                    static_cast<std::int32_t>(out.plan.requests.size() + 1));
      if (!wider.ok()) {
        std::fprintf(stderr, "%s: widen %s: %s\n", tag, ExchangeModeName(mode), wider.status().message().c_str());
        return kExitFailure;
      }
      if (wider->pairs.empty()) break;
      const auto t_wx = Clock::now();
      if (!deliver(wider->requests)) return kExitFailure;
      widen_exchange_s += SecondsSince(t_wx);
      for (ScanRequest& q : wider->requests) out.plan.requests.push_back(std::move(q));
      out.plan.predicted_scan_bytes += wider->predicted_scan_bytes;
      if (!merge(wider->pairs)) return kExitFailure;
      AdoptSelections(Span<const PairSelection>(wider->pairs), &out.plan.pairs);
    }
    auto frames = server.SolveFrames(Span<const PairMergeResult>(out.pairs));
    out.exchange_s += widen_exchange_s;
    out.merge_s = SecondsSince(t_merge) - widen_exchange_s;
    if (frames.ok()) {
      out.frames_ok = true;
      out.frames = std::move(*frames);
      for (int r = 0; r < num_robots; ++r) {
        const RobotFrame& f = out.frames.robots[static_cast<std::size_t>(r)];
        PairEval e;
        if (r > 0 && f.connected_to_robot0) e = Evaluate(traj[0], traj[static_cast<std::size_t>(r)], f.T_world_map);
        out.robot_eval.push_back(e);
      }
    } else {
      out.frames_error = frames.status().message();
      out.robot_eval.assign(static_cast<std::size_t>(num_robots), PairEval{});
    }
    progress.Done();
    outcomes.push_back(std::move(out));
  }

  // ---- results, side by side
  const std::uint64_t stream_bytes = stream_ledger.Total().bytes;
  const ModeOutcome* send_all = nullptr;
  for (const ModeOutcome& m : outcomes) {
    if (m.mode == ExchangeMode::kSendAll) send_all = &m;
  }
  std::string summary;
  auto line = [&summary](const std::string& s) {
    std::printf("%s\n", s.c_str());
    summary += s + "\n";
  };
  line("");
  line("| mode | scans sent | scan bytes | policies | pose refresh | total exchanged | vs send-all | pairs merged | e_rmse (robots vs robot 0) | merge s |");
  line("|---|---|---|---|---|---|---|---|---|---|");
  for (const ModeOutcome& m : outcomes) {
    std::size_t scans = 0, merged = 0;
    for (const ScanRequest& q : m.plan.requests) scans += q.keyframes.size();
    for (const PairMergeResult& p : m.pairs) merged += p.attempted && p.registration.success();
    const std::uint64_t total = stream_bytes + m.ledger->Total().bytes;
    std::string vs = "-";
    if (send_all) {
      const double all = static_cast<double>(stream_bytes + send_all->ledger->Total().bytes);
      vs = Fmt("%.2f %% less", 100.0 * (1.0 - static_cast<double>(total) / all));
    }
    std::string rmse;
    for (std::size_t r = 1; r < m.robot_eval.size(); ++r) {
      if (!rmse.empty()) rmse += ", ";
      rmse += m.robot_eval[r].has_gt ? Fmt("%.3f m", m.robot_eval[r].rmse_m) : std::string("-");
    }
    line("| " + std::string(ExchangeModeName(m.mode)) + " | " + std::to_string(scans) + " | " + Bytes(m.scan_bytes()) +
         " | " + Bytes(m.ledger->KindTotal(MessageKind::kPolicies).bytes) + " | " +
         Bytes(m.ledger->KindTotal(MessageKind::kPoseUpdates).bytes) + " | " + Bytes(total) + " | " + vs + " | " +
         std::to_string(merged) + "/" + std::to_string(m.pairs.size()) + " | " + (rmse.empty() ? "-" : rmse) + " | " +
         Fmt("%.2f", m.merge_s) + " |");
  }
  line("(total exchanged = streamed keyframe records " + Bytes(stream_ledger.KindTotal(MessageKind::kKeyframes).bytes) +
       " + streamed pose updates " + Bytes(stream_ledger.KindTotal(MessageKind::kPoseUpdates).bytes) +
       ", the same in every mode, + policies + the requested keyframes' current poses + scans; LCM-encoded sizes)");
  std::uint64_t raw_bytes = 0;
  for (const RobotRun& r : robots) raw_bytes += r.raw_keyframe_bytes;
  if (raw_bytes > 0) {
    line("(the paper's baseline, every keyframe's scan at full resolution as recorded (16 B per point), would be " +
         Bytes(raw_bytes) + "; " + std::string(ExchangeModeName(outcomes.back().mode)) + " exchanges " +
         Fmt("%.2f %% less", 100.0 * (1.0 - static_cast<double>(stream_bytes + outcomes.back().ledger->Total().bytes) /
                                              static_cast<double>(raw_bytes))) +
         ". send-all above ships the robots' stored voxel-downsampled scans, a much smaller baseline)");
  }

  const ModeOutcome& final_mode = outcomes.back();
  line("");
  line("final result (" + std::string(ExchangeModeName(final_mode.mode)) + "):");
  for (std::size_t i = 0; i < final_mode.pairs.size(); ++i) {
    const PairMergeResult& p = final_mode.pairs[i];
    const PairEval& e = final_mode.pair_eval[i];
    std::string s = "  pair " + std::to_string(p.alpha) + "-" + std::to_string(p.beta) + ": ";
    if (!p.attempted) {
      s += "not merged: " + p.reason;
    } else {
      const RegistrationResult& g = p.registration;
      s += std::to_string(p.alpha_scans) + " + " + std::to_string(p.beta_scans) + " scans, submaps " +
           std::to_string(p.alpha_submap_points) + " / " + std::to_string(p.beta_submap_points) + " points; " +
           RegistrationVerdictName(g.verdict) + " (coarse inliers " + std::to_string(g.num_coarse_inliers) +
           ", overlap " + Fmt("%.2f", g.overlap_ratio) + ", fitness " + Fmt("%.3f m", g.fitness_rmse_m) + "), " +
           Fmt("%.2f s", final_mode.pair_seconds[i]);
      if (final_mode.pair_widenings[i] > 0) {
        s += " (selection widened " + std::to_string(final_mode.pair_widenings[i]) +
             "x after registration refused it; README \"Server cascade\")";
      }
      if (g.success()) {
        s += "\n    T_" + std::to_string(p.alpha) + "_" + std::to_string(p.beta) + ": " + PoseText(g.T_target_source);
        if (e.has_gt) {
          s += "\n    against ground truth: " + Fmt("%.3f m", e.transform_error.translation_m) + ", " +
               Fmt("%.2f deg", e.transform_error.rotation_deg) + "; e_rmse " + Fmt("%.3f m", e.rmse_m) + " (max " +
               Fmt("%.3f m", e.max_error_m) + ")";
        }
      }
    }
    line(s);
  }
  if (!final_mode.frames_ok) {
    line("  frames: " + final_mode.frames_error);
  } else {
    for (int r = 0; r < num_robots; ++r) {
      const RobotFrame& f = final_mode.frames.robots[static_cast<std::size_t>(r)];
      std::string s = "  robot " + std::to_string(r) + ": ";
      if (r == 0) {
        s += "world frame (robot 0's map)";
      } else if (!f.connected_to_robot0) {
        s += "not connected to robot 0 (no consistent merge)";
      } else {
        s += "T_world_robot " + PoseText(f.T_world_map);
        const PairEval& e = final_mode.robot_eval[static_cast<std::size_t>(r)];
        if (e.has_gt) s += "; e_rmse " + Fmt("%.3f m", e.rmse_m);
      }
      line(s);
    }
    for (std::size_t i = 0; i < final_mode.frames.measurements.size(); ++i) {
      const MeasurementOutcome& mo = final_mode.frames.measurements[i];
      if (mo.verdict == MeasurementVerdict::kRejected) {
        line("  a pairwise merge was rejected as inconsistent with the others (cycle error " +
             Fmt("%.2f m", mo.cycle_translation_m) + ", " + Fmt("%.1f deg", mo.cycle_rotation_deg) + ")");
      }
    }
  }

  // ---- files: transforms, trajectories (TUM), merged map (PCD + PLY), report pictures
  {
    std::string t = "# commerge run: robot frames in the world frame (robot 0's map frame), mode " +
                    std::string(ExchangeModeName(final_mode.mode)) + "\n# robot connected T_world_robot (row-major 3x4)\n";
    for (int r = 0; r < num_robots; ++r) {
      const bool ok = final_mode.frames_ok && final_mode.frames.robots[static_cast<std::size_t>(r)].connected_to_robot0;
      const Eigen::Isometry3d T = ok ? final_mode.frames.robots[static_cast<std::size_t>(r)].T_world_map
                                     : Eigen::Isometry3d::Identity();
      t += std::to_string(r) + " " + (ok ? "1" : "0");
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 4; ++j) t += " " + Fmt("%.9g", T.matrix()(i, j));
      }
      t += "\n";
    }
    t += "# pairwise: alpha beta verdict T_alpha_beta (row-major 3x4)\n";
    for (const PairMergeResult& p : final_mode.pairs) {
      t += std::to_string(p.alpha) + " " + std::to_string(p.beta) + " " +
           (p.attempted ? std::string(RegistrationVerdictName(p.registration.verdict)) : std::string("not-attempted"));
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 4; ++j) t += " " + Fmt("%.9g", p.registration.T_target_source.matrix()(i, j));
      }
      t += "\n";
    }
    if (std::FILE* f = std::fopen((o.out_dir + "/transforms.txt").c_str(), "w")) {
      std::fputs(t.c_str(), f);
      std::fclose(f);
    }
  }
  std::vector<PointXYZI> map_after, map_before;
  std::vector<std::uint16_t> ids_after, ids_before;
  for (int r = 0; r < num_robots; ++r) {
    const RobotRun& rr = robots[static_cast<std::size_t>(r)];
    const bool connected = final_mode.frames_ok && final_mode.frames.robots[static_cast<std::size_t>(r)].connected_to_robot0;
    const Eigen::Isometry3d T = connected ? final_mode.frames.robots[static_cast<std::size_t>(r)].T_world_map
                                          : Eigen::Isometry3d::Identity();
    std::vector<platform::StampedPose> est, gt;
    const Trajectories& tr = traj[static_cast<std::size_t>(r)];
    for (std::size_t k = 0; k < tr.estimated.size(); ++k) {
      est.push_back({tr.times_s[k], T * tr.estimated[k]});
      if (!tr.ground_truth.empty()) gt.push_back({tr.times_s[k], tr.ground_truth[k]});
    }
    const std::string base = o.out_dir + "/trajectories/robot_" + std::to_string(r);
    Status st = platform::WriteTumPoses(base + (connected ? "_world.tum" : "_own_frame.tum"), Span<const platform::StampedPose>(est));
    if (st.ok() && !gt.empty()) st = platform::WriteTumPoses(base + "_gt.tum", Span<const platform::StampedPose>(gt));
    if (st.ok()) st = WriteLoops(rr, base + "_loops.txt");
    if (!st.ok()) std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    if (connected) AddRobotMap(rr, static_cast<std::uint16_t>(r), T, 1.0, &map_after, &ids_after);
    AddRobotMap(rr, static_cast<std::uint16_t>(r), Eigen::Isometry3d::Identity(), 1.0, &map_before, &ids_before);
  }
  for (Status st : {platform::WritePcd(o.out_dir + "/merged_map.pcd", Span<const PointXYZI>(map_after),
                                       platform::PcdEncoding::kBinary, Span<const std::uint16_t>(ids_after)),
                    platform::WritePly(o.out_dir + "/merged_map.ply", Span<const PointXYZI>(map_after),
                                       Span<const std::uint16_t>(ids_after))}) {
    if (!st.ok()) std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
  }
  if (o.report) {
    ReportWriter rep{report_dir, {}, {}};
    // Affinity matrix per pair with stage A's cluster and the final mode's loops.
    for (int a = 0; a < num_robots; ++a) {
      for (int b = a + 1; b < num_robots; ++b) {
        const ExchangeCascadeResult* c = server.cascade(a, b);
        if (!c) continue;
        const RobotKeyframeDb& A = server.robot(a);
        const RobotKeyframeDb& B = server.robot(b);
        platform::HeatmapInput h = AffinityPicture(A, B, 800);
        if (c->stage_a.found) {
          platform::HeatmapRect rect;
          rect.row0 = CellOf(c->stage_a.best.row_min, A.size(), h.rows);
          rect.row1 = CellOf(c->stage_a.best.row_max, A.size(), h.rows);
          rect.col0 = CellOf(c->stage_a.best.col_min, B.size(), h.cols);
          rect.col1 = CellOf(c->stage_a.best.col_max, B.size(), h.cols);
          h.rects.push_back(rect);
        }
        for (const SequentialLoopCell& l : c->stage_c.selected_loops) {
          platform::HeatmapMark mark;
          mark.row = CellOf(l.alpha_index, A.size(), h.rows);
          mark.col = CellOf(l.beta_index, B.size(), h.cols);
          h.marks.push_back(mark);
        }
        h.title = "R-SOLiD distance, robot " + std::to_string(a) + " x robot " + std::to_string(b) +
                  " (red: stage A cluster, dots: L_K)";
        h.row_label = "robot " + std::to_string(a) + " keyframe";
        h.col_label = "robot " + std::to_string(b) + " keyframe";
        rep.Write("affinity_" + std::to_string(a) + "_" + std::to_string(b) + ".png", platform::RenderHeatmap(h));
      }
    }
    // Trajectories in the world frame with the scans the final mode selected.
    platform::TrajectoryPlotInput tp;
    tp.title = "trajectories (world = robot 0), discs: scans sent in mode " + std::string(ExchangeModeName(final_mode.mode));
    for (int r = 0; r < num_robots; ++r) {
      platform::TrajectorySeries s;
      s.name = "robot " + std::to_string(r);
      s.robot_index = r;
      const bool connected = final_mode.frames_ok && final_mode.frames.robots[static_cast<std::size_t>(r)].connected_to_robot0;
      const Eigen::Isometry3d T = connected ? final_mode.frames.robots[static_cast<std::size_t>(r)].T_world_map
                                            : Eigen::Isometry3d::Identity();
      if (!connected) s.name += " (own frame: not merged)";
      for (const Eigen::Isometry3d& P : traj[static_cast<std::size_t>(r)].estimated) {
        const Eigen::Vector3d p = (T * P).translation();
        s.path.push_back({static_cast<float>(p.x()), static_cast<float>(p.y())});
      }
      for (const ScanRequest& q : final_mode.plan.requests) {
        if (q.robot_id != r) continue;
        for (std::uint32_t k : q.keyframes) {
          if (k < s.path.size()) s.highlighted.push_back(static_cast<int>(k));
        }
      }
      tp.robots.push_back(std::move(s));
    }
    rep.Write("trajectories_selected.png", platform::RenderTrajectories(tp));
    std::vector<std::string> names;
    for (int r = 0; r < num_robots; ++r) names.push_back("robot " + std::to_string(r));
    platform::TopViewInput before;
    before.points = Span<const PointXYZI>(map_before);
    before.robot_ids = Span<const std::uint16_t>(ids_before);
    before.robot_names = names;
    before.title = "before merging: every robot's map in its own frame";
    rep.Write("map_before.png", platform::RenderTopView(before));
    platform::TopViewInput after = before;
    after.points = Span<const PointXYZI>(map_after);
    after.robot_ids = Span<const std::uint16_t>(ids_after);
    after.title = "after merging (" + std::string(ExchangeModeName(final_mode.mode)) + "): world = robot 0";
    rep.Write("map_after.png", platform::RenderTopView(after));
    platform::BarChartInput bars;
    bars.series = {"keyframes", "pose updates", "policies", "scans"};
    bars.log_scale = true;
    bars.title = "bytes exchanged per mode (LCM-encoded)";
    bars.value_label = "bytes";
    for (const ModeOutcome& m : outcomes) {
      bars.groups.push_back(ExchangeModeName(m.mode));
      bars.values.push_back(static_cast<double>(stream_ledger.KindTotal(MessageKind::kKeyframes).bytes));
      bars.values.push_back(static_cast<double>(stream_ledger.KindTotal(MessageKind::kPoseUpdates).bytes +
                                                m.ledger->KindTotal(MessageKind::kPoseUpdates).bytes));
      bars.values.push_back(static_cast<double>(m.ledger->KindTotal(MessageKind::kPolicies).bytes));
      bars.values.push_back(static_cast<double>(m.scan_bytes()));
    }
    rep.Write("bytes_per_mode.png", platform::RenderBarChart(bars));
    for (const std::string& f : rep.failed) std::fprintf(stderr, "%s: report: %s\n", tag, f.c_str());
    if (std::FILE* f = std::fopen((report_dir + "/summary.md").c_str(), "w")) {
      std::fputs(("# commerge run\n\n```\n" + summary + "```\n").c_str(), f);
      std::fclose(f);
    }
  }
  const platform::RssFigures rss = platform::ReadRss();
  {
    // Machine-readable figures (profiling/bench_scenarios.sh reads them).
    std::string t = "key\tvalue\n";
    auto kv = [&t](const std::string& k, const std::string& v) { t += k + "\t" + v + "\n"; };
    kv("robots", std::to_string(num_robots));
    std::size_t keyframes = 0;
    for (const RobotRun& r : robots) keyframes += r.agent->mapper().num_keyframes();
    kv("keyframes_total", std::to_string(keyframes));
    kv("robots_s", Fmt("%.3f", robots_s));
    kv("cascade_s", Fmt("%.3f", cascade_s));
    kv("stream_bytes", std::to_string(stream_bytes));
    kv("raw_keyframe_scan_bytes", std::to_string(raw_bytes));
    for (int ri = 0; ri < num_robots; ++ri) {
      const RobotRun& r = robots[static_cast<std::size_t>(ri)];
      kv("robot." + std::to_string(ri) + ".loops", std::to_string(r.loops.size()));
      const LoopErrors& le = loop_errors[static_cast<std::size_t>(ri)];
      kv("robot." + std::to_string(ri) + ".false_loops", std::to_string(le.checked < 0 ? -1 : le.wrong));
      if (le.checked > 0) {
        kv("robot." + std::to_string(ri) + ".loop_error_median_m", Fmt("%.4f", le.median_m));
        kv("robot." + std::to_string(ri) + ".loop_error_max_m", Fmt("%.4f", le.max_m));
      }
    }
    kv("peak_rss_after_robots_bytes", std::to_string(robots_peak_rss));
    kv("peak_rss_end_bytes", std::to_string(rss.peak_bytes));
    for (const ModeOutcome& m : outcomes) {
      const std::string p = std::string("mode.") + ExchangeModeName(m.mode) + ".";
      std::size_t scans = 0, merged_pairs = 0, widened_pairs = 0;
      for (const ScanRequest& q : m.plan.requests) scans += q.keyframes.size();
      for (const PairMergeResult& pr : m.pairs) merged_pairs += pr.attempted && pr.registration.success();
      for (int w : m.pair_widenings) widened_pairs += w > 0;
      kv(p + "scans", std::to_string(scans));
      kv(p + "widened_pairs", std::to_string(widened_pairs));
      kv(p + "scan_bytes", std::to_string(m.scan_bytes()));
      kv(p + "total_bytes", std::to_string(stream_bytes + m.ledger->Total().bytes));
      kv(p + "pairs_merged", std::to_string(merged_pairs) + "/" + std::to_string(m.pairs.size()));
      kv(p + "merge_s", Fmt("%.3f", m.merge_s));
      double worst = -1.0;
      std::size_t connected = 0;
      for (std::size_t r = 1; r < m.robot_eval.size(); ++r) {
        if (m.robot_eval[r].has_gt) {
          worst = std::max(worst, m.robot_eval[r].rmse_m);
          ++connected;
        }
      }
      kv(p + "robots_merged", std::to_string(connected) + "/" + std::to_string(num_robots - 1));
      kv(p + "worst_rmse_m", Fmt("%.3f", worst));
    }
    if (std::FILE* f = std::fopen((report_dir + "/metrics.tsv").c_str(), "w")) {
      std::fputs(t.c_str(), f);
      std::fclose(f);
    }
  }
  std::printf("\nwrote %s (merged_map.pcd/.ply %zu points, transforms.txt, trajectories/, report/)\n", o.out_dir.c_str(),
              map_after.size());
  std::printf("time %.1f s; peak RSS after the robots %s, at the end %s (robots and server in one process)\n",
              SecondsSince(t_job), FormatBytes(robots_peak_rss).c_str(), FormatBytes(rss.peak_bytes).c_str());
  std::size_t merged = 0;
  for (const PairMergeResult& p : final_mode.pairs) merged += p.attempted && p.registration.success();
  if (summary_out) {
    summary_out->pairs_merged = static_cast<int>(merged);
    summary_out->final_rmse_m.clear();
    for (const PairEval& e : final_mode.robot_eval) summary_out->final_rmse_m.push_back(e.has_gt ? e.rmse_m : -1.0);
    if (send_all) {
      const double all = static_cast<double>(stream_bytes + send_all->ledger->Total().bytes);
      summary_out->final_reduction_percent =
          100.0 * (1.0 - static_cast<double>(stream_bytes + final_mode.ledger->Total().bytes) / all);
    }
  }
  if (merged == 0) {
    std::fprintf(stderr, "%s: no robot pair could be merged (see above)\n", tag);
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace commerge::app
