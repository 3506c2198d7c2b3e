// SPDX-License-Identifier: BSD-3-Clause
// `commerge run`: the main job. Robots (RobotAgent) and the server (MergeServer) live in one process; every
// message between them is LCM-encoded (platform/lcm/message_codec), counted in a byte ledger at its encoded
// size and decoded again before the receiver sees it, exactly as it would cross the network. The server's side
// is the same MergeRound `commerge server` drives, here with direct calls: one round per exchange mode, all
// planned from one run of the cascades.
//
// Steps (RunMergeJob): read the inputs -> check the memory budget -> map every robot (threads) and stream its
// keyframes to the server -> the cascades -> one merge round per mode -> results and files (run_report.cpp).
#include "apps/run_pipeline.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "apps/merge_flags.hpp"
#include "apps/run_job.hpp"
#include "core/common/bytes.hpp"
#include "core/common/number_text.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/exchange/exchange_policy.hpp"
#include "core/geometry/se3.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/memory/peak_rss.hpp"

namespace commerge::app {

double SecondsSince(RunClock::time_point t0) { return std::chrono::duration<double>(RunClock::now() - t0).count(); }

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::size_t ModeOutcome::scans_requested() const {
  std::size_t n = 0;
  for (const ScanRequest& q : round.plan.requests) n += q.keyframes.size();
  return n;
}

std::size_t ModeOutcome::pairs_merged() const {
  std::size_t n = 0;
  for (const PairMergeResult& p : round.pairs) n += p.merged();
  return n;
}

std::uint64_t RunJob::raw_keyframe_bytes() const {
  std::uint64_t n = 0;
  for (const RobotRun& r : robots) n += r.raw_keyframe_bytes;
  return n;
}

namespace {

// RunProgress on stderr: rewritten in place on a terminal, one line every 10 s otherwise.
class RunProgress {
 public:
  explicit RunProgress(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0) {}
  void Update(const std::string& line) {
    if (!enabled_) return;
    const auto now = RunClock::now();
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
  RunClock::time_point last_{};
};

int Fail(const RunJob& job, int code, const std::string& message) {
  std::fprintf(stderr, "%s: %s\n", job.tag, message.c_str());
  return code;
}

// ---- step 1: inputs

int ReadInputs(RunJob* job) {
  const RunOptions& o = job->options;
  for (const std::string& name : o.modes) {
    auto m = ExchangeModeFromName(name);
    if (!m.ok()) return Fail(*job, kExitUsage, "--modes: " + m.status().message());
    job->modes.push_back(*m);
  }
  if (job->modes.empty()) return Fail(*job, kExitUsage, "--modes is empty");
  const int num_robots = static_cast<int>(o.datasets.size());
  if (num_robots < 2 || num_robots > kFrameSolverMaxRobots) {
    return Fail(*job, kExitUsage, std::to_string(num_robots) + " datasets given; one per robot, 2.." +
                                      std::to_string(kFrameSolverMaxRobots));
  }
  auto descriptor = MakeRobotDescriptor(o.descriptor, o.sensor);  // checks the flags once, for every robot
  if (!descriptor.ok()) return Fail(*job, kExitUsage, descriptor.status().message());
  job->descriptor_input = descriptor->input;
  job->descriptor_text = descriptor->text;
  job->tau_intra = descriptor->tau_intra;
  job->robots.resize(static_cast<std::size_t>(num_robots));
  for (int r = 0; r < num_robots; ++r) {
    auto spec = platform::ParseRobotDatasetSpec(o.datasets[static_cast<std::size_t>(r)]);
    if (!spec.ok()) return Fail(*job, kExitUsage, spec.status().message());
    auto data = platform::OpenRobotDataset(*spec, o.gt_from_poses, o.odometry_file);
    if (!data.ok()) return Fail(*job, kExitFailure, data.status().message());
    job->robots[static_cast<std::size_t>(r)].data = std::move(*data);
  }
  return kExitOk;
}

// ---- step 2: the budget of the whole run (robots and server), checked before any work; outputs; the server

// The robots' keyframer: CreateRobots gives it to every robot, MeasureMission replays it to size the pools.
KeyframerParams RunKeyframer(const RunOptions& o) {
  KeyframerParams k;
  k.keyframe_spacing_m = o.keyframe_spacing_m;
  return k;
}

// What the opened datasets will need, before any pool is made: each robot's keyframes (its keyframer on the
// odometry it will map with: the same decisions RobotMapper makes) and the points of the largest scan file.
Result<MissionExtent> MeasureMission(const RunJob& job) {
  MissionExtent m;
  m.robots = job.num_robots();
  std::size_t keyframes = 1, points = 1;
  for (const RobotRun& r : job.robots) {
    Keyframer keyframer(RunKeyframer(job.options));
    for (const Eigen::Isometry3d& pose : r.data.poses) keyframer.Offer(pose);
    keyframes = std::max<std::size_t>(keyframes, keyframer.num_keyframes());
    for (const std::string& file : r.data.scan_files) {
      auto n = platform::KittiBinPointCount(file);
      if (!n.ok()) return n.status();
      points = std::max(points, *n);
    }
  }
  constexpr std::size_t kMaxInt32 = 0x7fffffff;
  m.max_keyframes_per_robot = static_cast<std::int32_t>(std::min(keyframes, kMaxInt32));
  m.max_points_per_raw_scan = static_cast<std::int32_t>(std::min(points, kMaxInt32));
  return m;
}

int SetUpRun(RunJob* job) {
  const RunOptions& o = job->options;
  MemoryFlags memory = o.memory;
  if (memory.robots == 0) memory.robots = job->num_robots();
  memory.descriptor_floats = DescriptorFloatsFor(o.descriptor.name);
  auto mission = MeasureMission(*job);
  if (!mission.ok()) return Fail(*job, kExitFailure, mission.status().message());
  memory.mission = *mission;
  if (int rc = SetUpMemory(AppKind::kRun, memory, &job->memory, /*print_table=*/false); rc != kExitOk) return rc;
  if (job->memory.config.max_robots < job->num_robots()) {
    return Fail(*job, kExitUsage, "--robots " + std::to_string(job->memory.config.max_robots) + " is fewer than the " +
                                      std::to_string(job->num_robots()) + " datasets");
  }
  MergeServerParams shown = o.server;
  shown.record_kind = RecordKindForDescriptor(o.descriptor.name);
  const MemoryConfig& sized = job->memory.config;
  std::printf("%s: %d robots; descriptor: %s; %s; pools for %d keyframes and %d-point scans a "
              "robot, scan stores of %s; %s\n",
              job->tag, job->num_robots(), job->descriptor_text.c_str(), CascadeSettingsText(shown).c_str(),
              sized.max_keyframes_per_robot, sized.max_points_per_raw_scan,
              FormatBytes(sized.scan_store_bytes).c_str(), job->memory.verdict.c_str());
  std::error_code ec;
  job->report_dir = o.out_dir + "/report";
  std::filesystem::create_directories(job->report_dir, ec);
  if (!ec) std::filesystem::create_directories(o.out_dir + "/trajectories", ec);
  if (ec) return Fail(*job, kExitFailure, "cannot create " + o.out_dir + ": " + ec.message());

  MergeServerParams server_params = o.server;
  server_params.record_kind = RecordKindForDescriptor(o.descriptor.name);
  server_params.max_submap_points = static_cast<std::size_t>(job->memory.config.max_submap_points);
  server_params.max_scan_points = static_cast<std::size_t>(job->memory.config.max_points_per_stored_scan);
  server_params.stage_ac_ablation =
      std::find(job->modes.begin(), job->modes.end(), ExchangeMode::kStageAC) != job->modes.end();
  server_params.colocation.max_heading_deg = ColocationHeadingDeg(ScanTraitsFor(o.sensor));
  if (Status st = ValidateMergeServerParams(server_params); !st.ok()) return Fail(*job, kExitUsage, st.message());
  auto server = MergeServer::Create(job->num_robots(),
                                    static_cast<std::size_t>(job->memory.config.max_keyframes_per_robot), server_params);
  if (!server.ok()) return Fail(*job, kExitUsage, server.status().message());
  job->server = std::move(*server);
  job->ledger_params.max_robots = static_cast<std::size_t>(job->num_robots());
  job->stream_ledger = std::make_unique<ByteLedger>(job->ledger_params);
  return kExitOk;
}

// ---- step 3: robots: keyframes, SOLiD, scan store, loop closure; descriptors and poses stream to the server

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

int CreateRobots(RunJob* job) {
  const MemoryConfig& config = job->memory.config;
  RobotMapperCapacity capacity;
  capacity.max_keyframes = static_cast<std::size_t>(config.max_keyframes_per_robot);
  capacity.max_points_per_raw_scan = static_cast<std::size_t>(config.max_points_per_raw_scan);
  capacity.max_points_per_stored_scan = static_cast<std::size_t>(config.max_points_per_stored_scan);
  for (int ri = 0; ri < job->num_robots(); ++ri) {
    RobotRun& r = job->robots[static_cast<std::size_t>(ri)];
    auto descriptor = MakeRobotDescriptor(job->options.descriptor, job->options.sensor);
    auto store_params = ScanStoreParamsFromBudget(config, ScanStorePolicy::kEvictOldest);
    if (!descriptor.ok() || !store_params.ok()) {
      return Fail(*job, kExitFailure, (!descriptor.ok() ? descriptor.status() : store_params.status()).message());
    }
    store_params->touch_at_start = false;  // sized for the datasets' largest scans; resident as they fill it
    r.descriptor = std::move(descriptor->descriptor);
    auto store = ScanStore::Create(*store_params);
    if (!store.ok()) return Fail(*job, kExitFailure, "robot " + std::to_string(ri) + " scan store: " + store.status().message());
    r.store = std::move(*store);
    RobotAgentParams agent_params;
    agent_params.mapper.keyframer = RunKeyframer(job->options);
    agent_params.mapper.descriptor_input = job->descriptor_input;
    agent_params.mapper.loop.max_descriptor_distance = job->tau_intra;
    agent_params.mapper.loop.window_keyframes = job->options.descriptor.tau_window_keyframes;
    agent_params.mapper.loop.max_icp_mean_squared_residual_m2 = job->options.descriptor.tau_icp_m2;
    agent_params.mapper.odometry_sigma_roll_pitch_rad = job->options.descriptor.odometry_roll_pitch_sigma_deg * kPi / 180.0;
    agent_params.mapper.voxel = StoredScanVoxel(job->options.descriptor);
    agent_params.record_descriptor_bits = job->options.descriptor.record_descriptor_bits;
    r.agent = std::make_unique<RobotAgent>(ri, agent_params, capacity, r.descriptor.get(), r.store.get());
  }
  return kExitOk;
}

// One robot's whole mission: every scan of its slice through the agent, its messages into *outbox.
Status MapRobot(RobotRun& r, std::atomic<std::size_t>* scans_done, std::vector<OutboxEntry>* outbox) {
  std::vector<std::uint8_t> buffer;
  const auto t0 = RunClock::now();
  // The robot knows only its own odometry (the poses file); its map frame is its first keyframe's sensor frame.
  Status st;
  for (std::size_t s = 0; s < r.data.scan_files.size() && st.ok(); ++s) {
    auto cloud = platform::ReadKittiBin(r.data.scan_files[s]);
    if (!cloud.ok()) {
      st = cloud.status();
      break;
    }
    auto step = r.agent->AddScan(Span<const PointXYZI>(cloud->points), r.data.poses[s]);
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
    *scans_done = s + 1;
    st = FlushRobot(r, &buffer, outbox, false);
  }
  if (st.ok()) st = r.agent->Finish();
  if (st.ok()) st = FlushRobot(r, &buffer, outbox, true);
  r.seconds = SecondsSince(t0);
  return st;
}

std::string RobotsProgressLine(const RunJob& job, const std::vector<std::atomic<std::size_t>>& scans_done,
                               std::size_t total_scans, RunClock::time_point t0) {
  std::size_t done = 0;
  for (const auto& c : scans_done) done += c;
  std::string line = "robots: " + Fmt("%.0f", 100.0 * static_cast<double>(done) / static_cast<double>(total_scans)) +
                     " % of " + std::to_string(total_scans) + " scans (";
  for (int ri = 0; ri < job.num_robots(); ++ri) {
    line += (ri ? ", " : "") + std::to_string(scans_done[static_cast<std::size_t>(ri)]) + "/" +
            std::to_string(job.robots[static_cast<std::size_t>(ri)].data.scan_files.size());
  }
  return line + "), " + Fmt("%.1f", static_cast<double>(done) / std::max(SecondsSince(t0), 1e-9)) + " scans/s";
}

// Each robot in its own thread (they share nothing); at most --threads at once. Then the streams reach the
// server, each in its robot's order.
int MapRobots(RunJob* job, RunProgress* progress) {
  const int n = job->num_robots();
  std::vector<std::vector<OutboxEntry>> outboxes(static_cast<std::size_t>(n));
  std::vector<Status> robot_status(static_cast<std::size_t>(n));
  std::vector<std::atomic<std::size_t>> scans_done(static_cast<std::size_t>(n));
  for (auto& c : scans_done) c = 0;
  std::size_t total_scans = 0;
  for (const RobotRun& r : job->robots) total_scans += r.data.scan_files.size();
  std::atomic<int> robots_finished{0}, next{0};
  const auto t0 = RunClock::now();
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, std::min(job->options.threads, n)); ++t) {
    pool.emplace_back([&]() {
      for (int ri = next++; ri < n; ri = next++) {
        const std::size_t i = static_cast<std::size_t>(ri);
        robot_status[i] = MapRobot(job->robots[i], &scans_done[i], &outboxes[i]);
        ++robots_finished;
      }
    });
  }
  while (robots_finished.load() < n) {
    progress->Update(RobotsProgressLine(*job, scans_done, total_scans, t0));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  for (std::thread& t : pool) t.join();
  progress->Done();
  job->robots_s = SecondsSince(t0);
  for (int ri = 0; ri < n; ++ri) {
    const Status& st = robot_status[static_cast<std::size_t>(ri)];
    if (!st.ok()) return Fail(*job, kExitFailure, "robot " + std::to_string(ri) + ": " + st.message());
    for (const OutboxEntry& e : outboxes[static_cast<std::size_t>(ri)]) {
      job->stream_ledger->Record(ri, e.is_batch ? MessageKind::kKeyframes : MessageKind::kPoseUpdates,
                                 Direction::kRobotToServer, e.encoded_bytes);
      Status rx = e.is_batch ? job->server->OnKeyframeBatch(e.batch) : job->server->OnPoseUpdate(e.update);
      if (!rx.ok()) {
        return Fail(*job, kExitFailure, "server refused a message of robot " + std::to_string(ri) + ": " + rx.message());
      }
    }
  }
  job->robots_peak_rss = platform::ReadRss().peak_bytes;
  return kExitOk;
}

// ---- step 4: each robot's trajectories and loops against its ground truth, printed

Trajectories KeyframeTrajectories(const RobotRun& r) {
  Trajectories t;
  const RobotMapper& m = r.agent->mapper();
  for (std::size_t k = 0; k < m.num_keyframes(); ++k) {
    t.estimated.push_back(m.pose(k));
    const std::size_t s = r.keyframe_scan[k];
    if (!r.data.ground_truth.empty()) t.ground_truth.push_back(r.data.ground_truth[s]);
    t.times_s.push_back(r.data.times_s.empty() ? static_cast<double>(s) : r.data.times_s[s]);
  }
  if (!t.ground_truth.empty() && !t.estimated.empty()) t.T_gt_map = t.ground_truth[0] * t.estimated[0].inverse();
  return t;
}

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

void PrintRobots(RunJob* job) {
  std::printf("\nrobots (%.1f s):\n", job->robots_s);
  for (int ri = 0; ri < job->num_robots(); ++ri) {
    const RobotRun& r = job->robots[static_cast<std::size_t>(ri)];
    const RobotMapper& m = r.agent->mapper();
    const ScanStoreStats& ss = r.store->stats();
    const LoopErrors le = CheckLoops(r);
    job->loop_errors.push_back(le);
    const std::string false_text =
        (le.checked < 0 ? std::string()
                        : " (" + std::to_string(le.wrong) + " false against ground truth" +
                              (le.checked > 0 ? ", error median " + Fmt("%.3f", le.median_m) + " m, max " +
                                                    Fmt("%.3f", le.max_m) + " m"
                                              : std::string()) +
                              ")") +
        ", " + std::to_string(m.stats().loops_refined) + " refined by GICP, " +
        std::to_string(m.stats().loop_candidates_rejected) + " candidates refused by ICP, " +
        std::to_string(m.stats().loops_implausible) + " refused as implausible" +
        (m.stats().scans_stored_finer > 0
             ? "; " + std::to_string(m.stats().scans_stored_finer) + " scans stored finer than 1 m (--min-scan-points)"
             : std::string()) +
        (m.levels_by_ground() ? "; odometry frame leans " + Fmt("%.1f", m.ground_up().tilt_deg()) +
                                    " deg from its ground's up: descriptors levelled by the ground"
                              : std::string());
    std::printf("  robot %d  %-40s %zu scans -> %zu keyframes (%llu invalid descriptors), %llu loops%s, store %zu "
                "scans %s (%llu evicted), %.1f s; ground truth: %s\n",
                ri, r.data.name.c_str(), r.scans, m.num_keyframes(),
                static_cast<unsigned long long>(m.stats().invalid_descriptors),
                static_cast<unsigned long long>(m.stats().loops_accepted), false_text.c_str(), ss.num_scans,
                FormatBytes(static_cast<std::int64_t>(ss.used_bytes)).c_str(),
                static_cast<unsigned long long>(ss.num_evicted), r.seconds,
                r.data.ground_truth.empty() ? "none" : r.data.ground_truth_source.c_str());
    job->trajectories.push_back(KeyframeTrajectories(r));
  }
  const MergeServerStats& sst = job->server->stats();
  std::printf("  streamed to the server: keyframes %s (%llu records in %llu batches), pose updates %s (%llu)\n",
              FormatBytes(static_cast<std::int64_t>(job->stream_ledger->KindTotal(MessageKind::kKeyframes).bytes)).c_str(),
              static_cast<unsigned long long>(sst.records), static_cast<unsigned long long>(sst.batches),
              FormatBytes(static_cast<std::int64_t>(job->stream_ledger->KindTotal(MessageKind::kPoseUpdates).bytes)).c_str(),
              static_cast<unsigned long long>(sst.pose_updates));
}

// ---- step 5: the cascade per pair, once for every mode

int RunCascades(RunJob* job) {
  const auto t0 = RunClock::now();
  if (Status st = job->server->RunCascades(); !st.ok()) return Fail(*job, kExitFailure, "server: " + st.message());
  job->cascade_s = SecondsSince(t0);
  std::printf("\nserver cascade (%.3f s):\n", job->cascade_s);
  for (int a = 0; a < job->num_robots(); ++a) {
    for (int b = a + 1; b < job->num_robots(); ++b) {
      const ExchangeCascadeResult* c = job->server->cascade(a, b);
      if (!c) continue;
      std::string padded;
      if (c->policy.alpha.padded_scans + c->policy.beta.padded_scans > 0) {
        padded = " (policy " + std::to_string(c->policy.alpha.keyframes.size()) + " + " +
                 std::to_string(c->policy.beta.keyframes.size()) + " scans with " +
                 std::to_string(c->policy.alpha.padded_scans) + " + " + std::to_string(c->policy.beta.padded_scans) +
                 " more of stage A's keyframes, --min-submap-scans, --min-submap-stored-points)";
      }
      if (c->stage_c.any_endpoint_fallback) padded += " (stage C over the loops with one endpoint selected: none had both)";
      if (c->verification) padded += " (to verify: stage A's " + c->verification_reason + ", --verify-area-fraction)";
      if (AmbiguousPlaceConfirmed(CascadeEvidence(*c), job->server->params().decision)) {
        padded += " (ambiguous place: " + c->ambiguity_reason + ", --max-ambiguous-fraction; confirmed by " +
                  FormatNumber(c->consensus_support_chosen, 4) + " keyframes of place consensus, may be widened, " +
                  "--widen-ambiguous-support)";
      } else if (c->ambiguous) {
        padded += " (ambiguous place, registered once: " + c->ambiguity_reason + ", --max-ambiguous-fraction)";
      }
      if (c->consensus_switched) padded += " (place consensus: " + c->consensus_reason + ", --consensus-max-cells)";
      std::printf("  pair %d-%d: %s; L_seq %zu loops (%zu x %zu keyframes; span %llu cells, next cluster %llu), stage B %zu + %zu scans (%s), |L_K| = %zu%s; "
                  "A %.3f s, B %.3f s, C %.3f s%s%s\n",
                  a, b, CascadeOutcomeName(c->outcome), c->stage_a.cells.size(), c->stage_b_vertices_alpha,
                  c->stage_b_vertices_beta, static_cast<unsigned long long>(c->stage_a.found ? c->stage_a.best.span_area() : 0),
                  static_cast<unsigned long long>(c->stage_a.second_span_area), c->stage_b.selected_left.size(), c->stage_b.selected_right.size(),
                  BalancedCoverStatusName(c->stage_b.status), c->stage_c.selected_loops.size(), padded.c_str(),
                  c->stage_a_s, c->stage_b_s, c->stage_c_s, c->no_candidate_reason.empty() ? "" : "; ",
                  c->no_candidate_reason.c_str());
      const StageSolverOutcome ob = StageBOutcome(*c);
      const StageSolverOutcome oc = StageCOutcome(*c);
      if (ob.ran || oc.ran || oc.loops_dropped > 0) {
        std::printf("    solvers: stage B %s; stage C %s\n", FormatStageSolverOutcome(ob).c_str(),
                    FormatStageSolverOutcome(oc).c_str());
      }
    }
  }
  return kExitOk;
}

// ---- step 6: one merge round per mode, its messages over the in-process wire

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

 private:
  ByteLedger* ledger_;
  std::vector<std::uint8_t> buffer_;
};

// Policies to the robots; their answers (the requested keyframes' current poses, then the scans) to the server.
// `to_server` false: only counted (the bytes send-all would cost, without the server holding every scan).
Status DeliverRequests(RunJob* job, ModeOutcome* out, Wire* wire, const std::vector<ScanRequest>& requests,
                       bool to_server = true) {
  MergeServer& server = *job->server;
  std::vector<ScanChunk> chunks;
  for (const ScanRequest& req : requests) {
    RobotRun& r = job->robots[static_cast<std::size_t>(req.robot_id)];
    ScanRequest delivered = req;
    if (out->mode != ExchangeMode::kSendAll) {  // send-all needs no policy: every robot sends everything
      auto rx = wire->Send(req, req.robot_id, MessageKind::kPolicies, Direction::kServerToRobot,
                           platform::EncodeScanRequest, platform::DecodeScanRequest);
      if (!rx.ok()) return Status(rx.status().code(), "policy: " + rx.status().message());
      delivered = std::move(*rx);
    }
    chunks.clear();
    PoseUpdate fresh_poses;
    auto answer = r.agent->AnswerRequest(delivered, 0, &chunks, &fresh_poses, /*remember_poses=*/false);
    if (!answer.ok()) return Status(answer.status().code(), "robot " + std::to_string(req.robot_id) + ": " + answer.status().message());
    if (!fresh_poses.keyframes.empty()) {  // current poses of the requested keyframes, before their scans
      auto rx = wire->Send(fresh_poses, req.robot_id, MessageKind::kPoseUpdates, Direction::kRobotToServer,
                           platform::EncodePoseUpdate, platform::DecodePoseUpdate);
      if (!rx.ok()) return Status(rx.status().code(), "pose update: " + rx.status().message());
      if (Status st = to_server ? server.OnPoseUpdate(*rx) : Status::Ok(); !st.ok()) {
        return Status(st.code(), "server refused a pose update: " + st.message());
      }
    }
    out->scans_missing += answer->missing.size();
    for (const ScanChunk& c : chunks) {
      auto rx = wire->Send(c, req.robot_id, MessageKind::kScans, Direction::kRobotToServer, platform::EncodeScanChunk,
                           platform::DecodeScanChunk);
      if (!rx.ok()) return Status(rx.status().code(), "scan chunk: " + rx.status().message());
      if (Status st = to_server ? server.OnScanChunk(*rx) : Status::Ok(); !st.ok()) {
        std::fprintf(stderr, "%s: server refused a scan chunk: %s\n", job->tag, st.message().c_str());
      }
    }
  }
  return Status::Ok();
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
  e.transform_error = ComputeTransformError(T_a_b, a.T_gt_map.inverse() * b.T_gt_map);
  return e;
}

// Every registered pair and every placed robot against ground truth.
void EvaluateMode(const RunJob& job, ModeOutcome* out) {
  const std::vector<Trajectories>& traj = job.trajectories;
  for (const PairMergeResult& p : out->round.pairs) {
    PairEval e;
    if (p.merged()) {
      e = Evaluate(traj[static_cast<std::size_t>(p.alpha)], traj[static_cast<std::size_t>(p.beta)],
                   p.registration.T_target_source);
    }
    out->pair_eval.push_back(e);
  }
  out->robot_eval.assign(static_cast<std::size_t>(job.num_robots()), PairEval{});
  for (int r = 1; r < job.num_robots(); ++r) {
    if (out->round.in_world(r)) {
      out->robot_eval[static_cast<std::size_t>(r)] = Evaluate(traj[0], traj[static_cast<std::size_t>(r)], out->round.T_world_map(r));
    }
  }
}

class ProgressObserver : public MergeRoundObserver {
 public:
  ProgressObserver(RunProgress* progress, ExchangeMode mode) : progress_(progress), mode_(mode) {}
  void OnPairRegistered(const PairMergeResult& r) override {
    progress_->Update("mode " + std::string(ExchangeModeName(mode_)) + ": merged pair " + std::to_string(r.alpha) +
                      "-" + std::to_string(r.beta));
  }

 private:
  RunProgress* progress_;
  ExchangeMode mode_;
};

// What send-all costs on the wire: the send-all plan's requests answered and counted, not delivered.
int CountSendAllBytes(RunJob* job) {
  ModeOutcome out;
  out.mode = ExchangeMode::kSendAll;
  out.ledger = std::make_unique<ByteLedger>(job->ledger_params);
  Wire wire(out.ledger.get());
  auto plan = job->server->Plan(ExchangeMode::kSendAll);
  Status st = plan.ok() ? DeliverRequests(job, &out, &wire, plan->requests, /*to_server=*/false) : plan.status();
  if (!st.ok()) return Fail(*job, kExitFailure, std::string("send-all bytes: ") + st.message());
  job->send_all_bytes = job->stream_bytes() + out.ledger->Total().bytes;
  return kExitOk;
}

// One merge round of `mode` on a server without scans; exchange_s is the time the messages took, merge_s the
// round's own work.
int RunMode(RunJob* job, ExchangeMode mode, RunProgress* progress) {
  ModeOutcome out;
  out.mode = mode;
  out.ledger = std::make_unique<ByteLedger>(job->ledger_params);
  Wire wire(out.ledger.get());
  job->server->ClearScans();
  MergeRound round(job->server.get(), MergeRoundParams{mode, /*run_cascades=*/false, PairExchangeParams{}});
  ProgressObserver observer(progress, mode);
  round.set_observer(&observer);
  const std::vector<std::int64_t> sessions(static_cast<std::size_t>(job->num_robots()), 1);
  std::vector<ScanRequest> requests;
  const auto t0 = RunClock::now();
  Status st = round.Begin(Span<const std::int64_t>(sessions), &requests);
  for (bool done = false; st.ok() && !done;) {
    const auto t_exchange = RunClock::now();
    st = DeliverRequests(job, &out, &wire, requests);
    out.exchange_s += SecondsSince(t_exchange);
    if (!st.ok()) break;
    auto finished = round.Continue(&requests);
    if (!finished.ok()) st = finished.status();
    done = finished.ok() && *finished;
  }
  progress->Done();
  if (!st.ok()) return Fail(*job, kExitFailure, std::string("mode ") + ExchangeModeName(mode) + ": " + st.message());
  out.merge_s = SecondsSince(t0) - out.exchange_s;
  out.round = round.result();
  EvaluateMode(*job, &out);
  job->outcomes.push_back(std::move(out));
  return kExitOk;
}

}  // namespace

void AddRunFlags(CLI::App* cmd, RunOptions* o) {
  cmd->add_option("--out", o->out_dir, "output directory (merged map, trajectories, transforms, report/)")
      ->capture_default_str();
  cmd->add_option("--modes", o->modes,
                  "exchange modes run side by side: send-all, A, A+B, A+C, A+B+C (the last gives the final result)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--lidar", o->sensor, "SOLiD sensor preset of the robots' LiDAR (hdl-64e, vlp-16, os1-64, os1-128, "
                                        "os2-128, os0-128, avia, aeva)")
      ->capture_default_str();
  AddDescriptorFlags(cmd, &o->descriptor);
  cmd->add_flag("--gt-from-poses", o->gt_from_poses,
                "without poses_gt.txt, use the poses file as ground truth (real sequences split into robots)");
  cmd->add_option("--odometry", o->odometry_file,
                  "the robots' odometry: this file of each dataset directory instead of poses.txt (e.g. odom_poses.txt, "
                  "a trajectory before loop closure); poses.txt stays the reference for --gt-from-poses");
  AddMergeFlags(cmd, &o->server, &o->profile);
  cmd->add_option("--keyframe-spacing-m", o->keyframe_spacing_m,
                  "robots take a keyframe every this many metres (paper 1.0; datasets written at exactly 1 m "
                  "keyframes need a little less, e.g. 0.9, or odometry noise skips every other one)")
      ->check(CLI::Range(0.05, 100.0))
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "robots processed in parallel")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_flag("!--no-report", o->report, "skip the PNG report pictures");
  cmd->add_flag("--dump-keyframes", o->dump_keyframes,
                "write report/keyframes_<r>.tsv: per keyframe its descriptor as the server holds it, its pose in the "
                "robot's map frame and its ground truth (for offline analysis of place recognition)");
  cmd->add_flag("!--no-progress", o->progress, "no progress line on stderr");
  AddMemoryFlags(cmd, &o->memory);
}

int RunMergeJob(const RunOptions& o, RunSummary* summary_out) {
  RunJob job(o);
  RunProgress progress(o.progress);
  if (int rc = ReadInputs(&job); rc != kExitOk) return rc;
  if (int rc = SetUpRun(&job); rc != kExitOk) return rc;
  if (int rc = CreateRobots(&job); rc != kExitOk) return rc;
  if (int rc = MapRobots(&job, &progress); rc != kExitOk) return rc;
  PrintRobots(&job);
  if (int rc = RunCascades(&job); rc != kExitOk) return rc;
  if (int rc = CountSendAllBytes(&job); rc != kExitOk) return rc;
  for (ExchangeMode mode : job.modes) {
    if (int rc = RunMode(&job, mode, &progress); rc != kExitOk) return rc;
  }
  SolveJoint(&job);
  const std::string summary = PrintResults(job);
  const std::string map_text = WriteRunOutputs(job, summary);
  const platform::RssFigures rss = platform::ReadRss();
  std::printf("\nwrote %s (merged_map.pcd/.ply %s, transforms.txt, trajectories/, report/)\n", o.out_dir.c_str(),
              map_text.c_str());
  std::printf("time %.1f s; peak RSS after the robots %s, at the end %s (robots and server in one process)\n",
              SecondsSince(job.start), FormatBytes(job.robots_peak_rss).c_str(), FormatBytes(rss.peak_bytes).c_str());
  const ModeOutcome& final_mode = job.outcomes.back();
  if (summary_out) {
    summary_out->pairs_merged = static_cast<int>(final_mode.pairs_merged());
    summary_out->final_rmse_m.clear();
    for (const PairEval& e : final_mode.robot_eval) summary_out->final_rmse_m.push_back(e.has_gt ? e.rmse_m : -1.0);
    summary_out->final_reduction_percent =
        100.0 * (1.0 - static_cast<double>(job.stream_bytes() + final_mode.ledger->Total().bytes) /
                           static_cast<double>(job.send_all_bytes));
  }
  if (final_mode.pairs_merged() == 0) return Fail(job, kExitFailure, "no robot pair could be merged (see above)");
  return kExitOk;
}

}  // namespace commerge::app
