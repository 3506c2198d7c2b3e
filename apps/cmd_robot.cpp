// SPDX-License-Identifier: BSD-3-Clause
// `commerge robot`: one robot process on LCM. Its input is a KITTI-layout directory replayed at --rate-hz (scans +
// their odometry poses), or, with --live, lidar_scan_t / odometry_t from an odometry stack on the robot's own
// board (a separate LCM URL, so scans never reach the radio), time-synchronised by ScanOdometrySync; the input
// ends after --idle-finish-s without a scan or at the first SIGINT / SIGTERM. It maps the input (keyframes, SOLiD, scan store, loop closure), streams keyframe batches and pose
// updates, answers the server's exchange policies with scan chunks, and re-announces / retransmits from the
// server's transfer status (core/agent/robot_link). Publishes robot_status_t once per second. It ends (exit 0)
// when a merge result of the current server places --exit-when-merged robots, itself among them, in the world
// frame after a round that saw all of its keyframes, every keyframe is acknowledged and no scan request is open; or (exit 1: not merged) when --linger-s
// passed after the last scan. With --exit-when-merged 0 it runs until SIGINT / SIGTERM.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/app_auth.hpp"
#include "apps/app_common.hpp"
#include "apps/app_descriptor_flags.hpp"
#include "apps/app_memory.hpp"
#include "apps/commands.hpp"
#include "core/agent/delivery_digest.hpp"
#include "core/agent/robot_link.hpp"
#include "core/agent/scan_odometry_sync.hpp"
#include "core/common/bytes.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_reader.hpp"
#include "platform/lcm/input_codec.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "platform/memory/peak_rss.hpp"

namespace commerge::app {

namespace {

/// Keyframes per batch when --records-per-batch is not given: one keyframe_batch_t inside one 1500-byte datagram.
std::size_t DefaultRecordsPerBatch(KeyframeRecordKind kind) {
  switch (kind) {
    case KeyframeRecordKind::kScanContext: return 1;   // 1226 B
    case KeyframeRecordKind::kUnit40: return 12;       // 12 x 92 B
    case KeyframeRecordKind::kCompact40: return 24;    // 35-45 B a keyframe, its point count included
  }
  return 1;
}

struct RobotOptions {
  int id = 0;
  std::string data;
  bool live = false;
  std::string input_lcm_url = platform::kDefaultInputLcmUrl;
  std::string scan_channel = platform::kLidarScanChannel;
  std::string odometry_channel = platform::kOdometryChannel;
  double idle_finish_s = 5.0;
  std::string lidar = "hdl-64e";
  DescriptorFlags descriptor;
  double rate_hz = 10.0;
  double keyframe_spacing_m = 1.0;
  // One keyframe_batch_t / pose_update_t stays inside one UDP datagram at a 1500-byte MTU (WiFi): LCM drops a
  // whole message when one IP fragment is lost. 128 poses of a corrected stretch = about 0.7-1.1 kB (5-8 bytes a
  // pose, core/descriptor/compact_pose_codec.hpp).
  std::size_t records_per_batch = 0;  ///< 0: DefaultRecordsPerBatch of the record kind
  std::size_t poses_per_update = 128;
  std::string lcm_url;
  double bandwidth_kbps = 4000.0;
  double linger_s = 60.0;
  int exit_when_merged = 2;
  double resend_timeout_s = 2.0;
  double batch_delay_s = RobotLinkParams{}.batch_delay_s;
  /// robot_status_t every this many seconds, and at once when the state changes (it crosses the WiFi like the
  /// exchange: at 1 Hz, 380 bytes a second per robot were a tenth of a 10 000-keyframe mission's bytes).
  double status_interval_s = 10.0;
  double delay_ms = 0.0, jitter_ms = 0.0, duplicate_pct = 0.0;
  bool quiet = false;
  MemoryFlags memory;
  AuthFlags auth;
};

// Decoded traffic for this robot; everything else is ignored, malformed messages are counted.
struct Inbox {
  std::uint64_t rejected = 0;
  std::string last_rejection;
};

// The robot process: configuration, the transport-free robot (RobotAgent + RobotLink), its input (a replayed
// dataset or the live odometry stack) and the LCM bus; Run() is its loop.
class RobotProcess {
 public:
  explicit RobotProcess(const RobotOptions& o) : o_(o), bucket_(o.bandwidth_kbps * 1000.0 / 8.0, 16384.0) {}
  /// Flags, memory budget, input, descriptor, agent, authentication; kExitOk when Run may follow (also after
  /// --check: see checked()).
  int Configure();
  bool checked() const { return o_.auth.check; }
  int Run();

 private:
  int OpenBuses();
  void SayStart() const;
  bool MapScan(Span<const PointXYZI> points, const Eigen::Isometry3d& T_odom_sensor, const char* what);
  bool FinishInput(std::int64_t now);
  /// Replay: the next scan of the dataset when it is due. False on a fatal error.
  bool ReplayInput(std::int64_t now);
  /// Live: decodes the odometry stack's messages and maps the scans synchronised so far. False on a fatal error.
  bool LiveInput(std::int64_t now);
  /// The server's messages: policies, transfer statuses, merge results.
  void HandleServerMessages(std::int64_t wall);
  /// Publishes what the link has to send while the bandwidth allows. False on a fatal error.
  bool SendOutgoing(std::int64_t now, std::int64_t wall);
  void PublishStatus(std::int64_t wall, bool done);
  /// robot_status_t's state: "mapping", "sending scans", "waiting", "merged" (done).
  std::string State(bool done) const;
  int Finish(bool merged);
  void PrintLiveInputSummary() const;

  static constexpr const char* kTag = "commerge robot";
  const RobotOptions& o_;
  MemorySetup setup_;
  std::string descriptor_text_;
  platform::RobotDataset data_;
  std::unique_ptr<PlaceDescriptor> descriptor_;
  std::unique_ptr<ScanStore> store_;
  std::unique_ptr<RobotAgent> agent_;
  std::unique_ptr<RobotLink> link_;
  std::int64_t session_ = 0;
  platform::LcmBusParams bus_params_;
  std::unique_ptr<platform::LcmBus> bus_;
  // Live input: its own bus (the odometry stack's URL on this board), decoder and time synchronisation.
  std::unique_ptr<ScanOdometrySync> sync_;
  std::unique_ptr<platform::LcmBus> input_;
  platform::LidarScanDecoder scan_decoder_;
  LidarScan scan_in_;
  std::uint64_t input_rejected_ = 0, nonfinite_points_ = 0, scans_after_end_ = 0;
  std::string last_input_rejection_;
  Inbox inbox_;
  TokenBucket bucket_;  ///< --bandwidth-kbps
  std::int64_t bytes_sent_ = 0, bytes_resent_ = 0, publish_failures_ = 0;
  std::int64_t last_scan_us_ = -1, next_scan_us_ = 0, data_end_us_ = -1;
  std::string last_state_;  ///< of the last robot_status_t
  std::size_t scan_ = 0;
  // The server session whose merge result placed this robot (0: none yet). Kept once set: a duplicated or late
  // copy of an earlier result must not undo it; a new server session (a restarted server) starts over.
  std::int64_t merged_session_ = 0;
  std::vector<std::uint8_t> buffer_;
  platform::BusMessage message_;
};

int RobotProcess::Configure() {
  MemoryFlags memory = o_.memory;
  memory.descriptor_floats = DescriptorFloatsFor(o_.descriptor.name);
  if (int rc = SetUpMemory(AppKind::kRobot, memory, &setup_, false); rc != kExitOk) return rc;
  if (o_.live == !o_.data.empty()) {
    std::fprintf(stderr, "%s: give exactly one input: --data DIR (replay) or --live (odometry stack on LCM)\n", kTag);
    return kExitUsage;
  }
  auto descriptor = MakeRobotDescriptor(o_.descriptor, o_.lidar);
  if (!descriptor.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, descriptor.status().message().c_str());
    return kExitUsage;
  }
  descriptor_ = std::move(descriptor->descriptor);
  descriptor_text_ = descriptor->text;
  if (!o_.live) {
    auto spec = platform::ParseRobotDatasetSpec(o_.data);
    if (!spec.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, spec.status().message().c_str());
      return kExitUsage;
    }
    auto opened = platform::OpenRobotDataset(*spec, /*gt_from_poses=*/true);
    if (!opened.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, opened.status().message().c_str());
      return kExitFailure;
    }
    data_ = std::move(*opened);
  }
  auto store_params = ScanStoreParamsFromBudget(setup_.config, ScanStorePolicy::kEvictOldest);
  if (!store_params.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, store_params.status().message().c_str());
    return kExitFailure;
  }
  auto store = ScanStore::Create(*store_params);
  if (!store.ok()) {
    std::fprintf(stderr, "%s: scan store: %s\n", kTag, store.status().message().c_str());
    return kExitFailure;
  }
  store_ = std::move(*store);
  RobotMapperCapacity capacity;
  capacity.max_keyframes = static_cast<std::size_t>(setup_.config.max_keyframes_per_robot);
  capacity.max_points_per_raw_scan = static_cast<std::size_t>(setup_.config.max_points_per_raw_scan);
  capacity.max_points_per_stored_scan = static_cast<std::size_t>(setup_.config.max_points_per_stored_scan);
  RobotAgentParams agent_params;
  agent_params.mapper.keyframer.keyframe_spacing_m = o_.keyframe_spacing_m;
  agent_params.mapper.descriptor_input = descriptor->input;
  agent_params.mapper.loop.max_descriptor_distance = descriptor->tau_intra;
  agent_params.mapper.loop.window_keyframes = o_.descriptor.tau_window_keyframes;
  agent_params.mapper.loop.max_icp_mean_squared_residual_m2 = o_.descriptor.tau_icp_m2;
  agent_params.mapper.odometry_sigma_roll_pitch_rad = o_.descriptor.odometry_roll_pitch_sigma_deg * kPi / 180.0;
  agent_params.mapper.voxel = StoredScanVoxel(o_.descriptor);
  agent_params.record_descriptor_bits = o_.descriptor.record_descriptor_bits;
  agent_params.max_records_per_batch = o_.records_per_batch > 0 ? o_.records_per_batch
                                                                : DefaultRecordsPerBatch(RobotRecordKind(
                                                                      descriptor_->kind(),
                                                                      o_.descriptor.record_descriptor_bits));
  agent_params.max_poses_per_update = o_.poses_per_update;
  RobotLinkParams link_params;
  link_params.resend_timeout_s = o_.resend_timeout_s;
  link_params.batch_delay_s = o_.batch_delay_s;
  for (const Status& st : {ValidateRobotAgentParams(agent_params), ValidateRobotLinkParams(link_params)}) {
    if (!st.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
      return kExitUsage;
    }
  }
  agent_ = std::make_unique<RobotAgent>(o_.id, agent_params, capacity, descriptor_.get(), store_.get());
  session_ = platform::WallTimeUs();
  link_ = std::make_unique<RobotLink>(session_, link_params, agent_.get());
  bus_params_.url = o_.lcm_url;
  bus_params_.delay_ms = o_.delay_ms;
  bus_params_.jitter_ms = o_.jitter_ms;
  bus_params_.duplicate_pct = o_.duplicate_pct;
  bus_params_.fault_seed = static_cast<std::uint32_t>(session_) ^ static_cast<std::uint32_t>(o_.id);
  bus_params_.receive_thread = true;  // mapping a scan can take longer than LCM's 30-message queue lasts
  if (int rc = SetUpAuth(kTag, o_.auth, static_cast<std::uint16_t>(o_.id), session_, setup_.config.max_robots,
                         &bus_params_);
      rc != kExitOk) {
    return rc;
  }
  if (o_.auth.check) {
    const std::string input = o_.live ? "live on " + o_.input_lcm_url
                                      : std::to_string(data_.scan_files.size()) + " scans from " + o_.data;
    std::printf("%s %d: configuration OK (--check): board %s, memory budget %s of %s; input %s; LCM %s; %s\n", kTag,
                o_.id, o_.memory.board.c_str(), FormatBytes(setup_.table.total_bytes()).c_str(),
                FormatBytes(setup_.limit_bytes).c_str(), input.c_str(),
                o_.lcm_url.empty() ? "LCM_DEFAULT_URL" : o_.lcm_url.c_str(), AuthDescription(o_.auth, bus_params_).c_str());
  }
  return kExitOk;
}

int RobotProcess::OpenBuses() {
  auto bus = platform::OpenLcmBus(bus_params_, {platform::kPolicyChannel, platform::kStatusChannel,
                                                platform::kMergeResultChannel});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, bus.status().message().c_str());
    return kExitFailure;
  }
  bus_ = std::move(*bus);
  if (!o_.live) return kExitOk;
  ScanOdometrySyncParams sync_params;
  sync_params.max_points_per_scan = static_cast<std::size_t>(setup_.config.max_points_per_raw_scan);
  if (Status st = ValidateScanOdometrySyncParams(sync_params); !st.ok()) {
    std::fprintf(stderr, "%s: live input: %s\n", kTag, st.message().c_str());
    return kExitUsage;
  }
  sync_ = std::make_unique<ScanOdometrySync>(sync_params);
  platform::LcmBusParams input_params;
  input_params.url = o_.input_lcm_url;
  input_params.max_queued_bytes = 64u << 20;  // a few 4 MiB scans plus odometry
  input_params.receive_thread = true;
  auto opened = platform::OpenLcmBus(input_params, {o_.scan_channel.c_str(), o_.odometry_channel.c_str()});
  if (!opened.ok()) {
    std::fprintf(stderr, "%s: live input: %s\n", kTag, opened.status().message().c_str());
    return kExitFailure;
  }
  input_ = std::move(*opened);
  return kExitOk;
}

void RobotProcess::SayStart() const {
  if (!o_.quiet) {
    if (o_.live) {
      std::fprintf(stderr, "%s %d: session %lld, live input %s / %s on %s\n", kTag, o_.id,
                   static_cast<long long>(session_), o_.scan_channel.c_str(), o_.odometry_channel.c_str(),
                   o_.input_lcm_url.c_str());
    } else {
      std::fprintf(stderr, "%s %d: session %lld, %zu scans from %s at %.1f Hz\n", kTag, o_.id,
                   static_cast<long long>(session_), data_.scan_files.size(), o_.data.c_str(), o_.rate_hz);
    }
    // The id is not in the messages: the operator compares it across the team's robots.
    std::fprintf(stderr, "%s %d: descriptor %s, parameter id 0x%08X (every robot must show the same)\n", kTag,
                 o_.id, descriptor_text_.c_str(), static_cast<unsigned>(agent_->mapper().descriptor_parameter_id()));
  }
  if (!o_.quiet || !bus_params_.authenticate) {
    std::fprintf(stderr, "%s %d: %s\n", kTag, o_.id, AuthDescription(o_.auth, bus_params_).c_str());
  }
}

bool RobotProcess::MapScan(Span<const PointXYZI> points, const Eigen::Isometry3d& T_odom_sensor, const char* what) {
  // The odometry pose as it comes: the mapper's map frame is its first keyframe's sensor frame, and the
  // odometry frame's z (gravity, in an IMU-aided odometry) levels the descriptor's input.
  auto step = agent_->AddScan(points, T_odom_sensor);
  if (!step.ok()) std::fprintf(stderr, "%s: scan %s: %s\n", kTag, what, step.status().message().c_str());
  return step.ok();
}

bool RobotProcess::FinishInput(std::int64_t now) {
  if (Status st = agent_->Finish(); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
    return false;
  }
  data_end_us_ = now;
  link_->set_flush(true);  // nothing more will come to fill a batch
  return true;
}

bool RobotProcess::ReplayInput(std::int64_t now) {
  if (scan_ >= data_.scan_files.size() || now < next_scan_us_) return true;
  next_scan_us_ += static_cast<std::int64_t>(1e6 / o_.rate_hz);
  auto cloud = platform::ReadKittiBin(data_.scan_files[scan_]);
  if (!cloud.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, cloud.status().message().c_str());
    return false;
  }
  if (!MapScan(Span<const PointXYZI>(cloud->points), data_.poses[scan_], data_.scan_files[scan_].c_str())) return false;
  return ++scan_ < data_.scan_files.size() || FinishInput(now);
}

bool RobotProcess::LiveInput(std::int64_t now) {
  if (Status st = input_->Poll(0); !st.ok()) {
    std::fprintf(stderr, "%s: live input: %s\n", kTag, st.message().c_str());
    return false;
  }
  while (input_->Take(&message_)) {
    const Span<const std::uint8_t> bytes(message_.bytes.data(), message_.bytes.size());
    Status st;
    if (message_.channel == o_.scan_channel) {
      st = scan_decoder_.Decode(bytes, &scan_in_);
      if (st.ok() && data_end_us_ >= 0) {
        ++scans_after_end_;  // the mapper is closed
      } else if (st.ok()) {
        nonfinite_points_ += scan_in_.dropped_nonfinite;
        sync_->PushScan(scan_in_);
        last_scan_us_ = now;
      }
    } else if (message_.channel == o_.odometry_channel) {
      auto odometry = platform::DecodeOdometry(bytes);
      if (odometry.ok()) {
        sync_->PushOdometry(*odometry);
      } else {
        st = odometry.status();
      }
    }
    if (!st.ok()) {
      ++input_rejected_;
      last_input_rejection_ = message_.channel + ": " + st.message();
    }
  }
  SyncedScan ready;
  while (data_end_us_ < 0 && sync_->PopReady(&ready)) {
    if (!MapScan(ready.points, ready.T_odom_sensor, "from the odometry stack")) return false;
  }
  // The input is over after --idle-finish-s without a scan, or at the first signal.
  const bool idle = last_scan_us_ >= 0 && static_cast<double>(now - last_scan_us_) > o_.idle_finish_s * 1e6;
  if (data_end_us_ >= 0 || !(idle || StopSignalCount() == 1)) return true;
  sync_->DropWaiting();
  while (sync_->PopReady(&ready)) {
    if (!MapScan(ready.points, ready.T_odom_sensor, "from the odometry stack")) return false;
  }
  if (!FinishInput(now)) return false;
  if (!o_.quiet) {
    const ScanOdometrySyncStats& s = sync_->stats();
    std::fprintf(stderr, "%s %d: live input ended (%s): %llu scans mapped, %llu dropped, %llu odometry samples "
                 "rejected, %llu non-finite points, %llu messages rejected\n", kTag, o_.id,
                 idle ? "no scan for --idle-finish-s" : "signal", static_cast<unsigned long long>(s.scans_taken),
                 static_cast<unsigned long long>(s.scans_dropped()), static_cast<unsigned long long>(s.odometry_rejected()),
                 static_cast<unsigned long long>(nonfinite_points_), static_cast<unsigned long long>(input_rejected_));
  }
  return true;
}

void RobotProcess::HandleServerMessages(std::int64_t wall) {
  while (bus_->Take(&message_)) {
    const Span<const std::uint8_t> bytes(message_.bytes.data(), message_.bytes.size());
    // Every channel this robot reads is the server's: a robot's signature there is a team member misbehaving.
    Status st = CheckSigner(message_, platform::kAuthServerSender);
    if (st.ok() && message_.channel == platform::kPolicyChannel) {
      auto request = platform::DecodeScanRequest(bytes);
      st = !request.ok() ? request.status() : (request->robot_id == o_.id ? link_->OnScanRequest(*request, wall) : Status::Ok());
    } else if (st.ok() && message_.channel == platform::kStatusChannel) {
      auto status = platform::DecodeTransferStatus(bytes);
      st = !status.ok() ? status.status() : (status->robot_id == o_.id ? link_->OnTransferStatus(*status, wall) : Status::Ok());
    } else if (st.ok() && message_.channel == platform::kMergeResultChannel) {
      auto result = platform::DecodeMergeResult(bytes);
      if (!result.ok()) {
        st = result.status();
      } else if (result->server_session == link_->server_session() && data_end_us_ >= 0) {
        // Robot 0 is always "in the world" (its map is the world frame): count the robots placed with it.
        // The round must have seen every keyframe of this robot, not an early part of its data.
        int placed = 0;
        bool self = false;
        for (std::size_t i = 0; i < result->robot_ids.size(); ++i) {
          if (!result->in_world[i]) continue;
          ++placed;
          self = self || (result->robot_ids[i] == o_.id && result->keyframes[i] == agent_->mapper().num_keyframes());
        }
        if (self && o_.exit_when_merged > 0 && placed >= o_.exit_when_merged) merged_session_ = result->server_session;
      }
    }
    if (!st.ok()) {
      ++inbox_.rejected;
      inbox_.last_rejection = message_.channel + ": " + st.message();
    }
  }
}

bool RobotProcess::SendOutgoing(std::int64_t now, std::int64_t wall) {
  RobotOutgoing out;
  while (bucket_.CanSend(now)) {
    auto more = link_->Next(wall, &out);
    if (!more.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, more.status().message().c_str());
      return false;
    }
    if (!*more) break;
    const char* channel = platform::kScansChannel;
    Status st;
    switch (out.kind) {
      case RobotOutgoing::Kind::kKeyframeBatch:
        st = platform::EncodeKeyframeBatch(out.batch, &buffer_);
        channel = platform::kKeyframesChannel;
        break;
      case RobotOutgoing::Kind::kPoseUpdate:
        st = platform::EncodePoseUpdate(out.poses, &buffer_);
        channel = platform::kPosesChannel;
        break;
      case RobotOutgoing::Kind::kScanChunk: st = platform::EncodeScanChunk(out.chunk, &buffer_); break;
    }
    if (!st.ok()) {  // an encoder refusing the agent's own message is a bug, not a network fault
      std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
      return false;
    }
    // A failed publish is a lost message: counted, and the transfer status brings it back.
    if (Status pub = bus_->Publish(channel, buffer_); !pub.ok()) {
      if (publish_failures_++ == 0 && !o_.quiet) std::fprintf(stderr, "%s %d: %s\n", kTag, o_.id, pub.message().c_str());
    }
    bucket_.Take(buffer_.size());
    bytes_sent_ += static_cast<std::int64_t>(buffer_.size());
    if (out.resend) bytes_resent_ += static_cast<std::int64_t>(buffer_.size());
  }
  return true;
}

std::string RobotProcess::State(bool done) const {
  return done ? "merged" : data_end_us_ < 0 ? "mapping" : link_->queued_chunks() > 0 ? "sending scans" : "waiting";
}

void RobotProcess::PublishStatus(std::int64_t wall, bool done) {
  RobotStatus status;
  status.utime_us = wall;
  status.robot_id = o_.id;
  status.session = session_;
  status.peak_rss_bytes = platform::ReadRss().peak_bytes;
  status.budget_total_bytes = static_cast<std::int64_t>(setup_.table.total_bytes());
  status.budget_limit_bytes = setup_.limit_bytes;
  status.modules = StatusModules(setup_.table, agent_->MemoryUse());
  status.keyframes = static_cast<std::uint32_t>(agent_->mapper().num_keyframes());
  status.keyframes_acked = link_->stats().keyframes_acked;
  status.queued_keyframes = static_cast<std::uint32_t>(agent_->unsent_keyframes() + agent_->queued_resends());
  status.queued_poses = static_cast<std::uint32_t>(agent_->queued_poses());
  status.queued_chunks = static_cast<std::uint32_t>(link_->queued_chunks());
  status.bytes_sent = bytes_sent_;
  status.bytes_resent = bytes_resent_;
  status.request_id = link_->active_request();
  status.state = State(done);
  // The server lingers until every placed robot said "merged": the last status goes out three times, so one
  // lost datagram does not keep the server waiting for --linger-s.
  if (platform::EncodeRobotStatus(status, &buffer_).ok()) {
    for (int copy = 0; copy < (done ? 3 : 1); ++copy) (void)bus_->Publish(platform::kRobotStatusChannel, buffer_);
  }
  if (!o_.quiet) {
    std::fprintf(stderr, "%s %d: %s, %u/%u keyframes acknowledged, %lld bytes sent (%lld resent), %llu rejected\n",
                 kTag, o_.id, status.state.c_str(), status.keyframes_acked, status.keyframes,
                 static_cast<long long>(bytes_sent_), static_cast<long long>(bytes_resent_),
                 static_cast<unsigned long long>(inbox_.rejected + AuthRejected(*bus_)));
  }
}

int RobotProcess::Run() {
  if (int rc = OpenBuses(); rc != kExitOk) return rc;
  InstallStopSignalHandlers();
  SayStart();
  next_scan_us_ = platform::MonotonicUs();
  std::int64_t next_status_us = next_scan_us_;
  bool merged = false;
  while (StopSignalCount() == 0 ||
         (o_.live && StopSignalCount() == 1)) {  // live: the first signal ends the input, the second the robot
    const std::int64_t now = platform::MonotonicUs();
    const std::int64_t wall = platform::WallTimeUs();
    if (!(o_.live ? LiveInput(now) : ReplayInput(now))) return kExitFailure;
    if (Status st = bus_->Poll(5); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
      return kExitFailure;
    }
    HandleServerMessages(wall);
    if (!SendOutgoing(now, wall)) return kExitFailure;
    const bool all_acked = data_end_us_ >= 0 && link_->stats().keyframes_acked >= agent_->mapper().num_keyframes() &&
                           agent_->queued_resends() == 0 && agent_->queued_poses() == 0 && link_->queued_chunks() == 0;
    merged = merged_session_ != 0 && merged_session_ == link_->server_session();
    const bool done = merged && all_acked;
    if (now >= next_status_us || done || State(done) != last_state_) {
      next_status_us = now + static_cast<std::int64_t>(o_.status_interval_s * 1e6);
      last_state_ = State(done);
      PublishStatus(wall, done);
    }
    if (done) break;
    if (data_end_us_ >= 0 && o_.exit_when_merged > 0 && static_cast<double>(now - data_end_us_) > o_.linger_s * 1e6) break;
  }
  return Finish(merged);
}

// Lets delayed messages out, then the exit summary: delivery, authentication, live input, digest, memory.
int RobotProcess::Finish(bool merged) {
  for (int i = 0; i < 400 && bus_->delayed() > 0; ++i) {  // Poll returns at once while messages are queued
    (void)bus_->Poll(10);
    while (bus_->Take(&message_)) {
    }
  }
  const bool ok = o_.exit_when_merged == 0 || merged;  // 0: ended by a signal, as asked
  std::printf("robot %d: %s; keyframes %zu, acknowledged %u; bytes sent %lld, resent %lld; publish failures %lld; "
              "rejected messages %llu%s%s\n",
              o_.id, ok ? "merged" : "NOT merged", agent_->mapper().num_keyframes(), link_->stats().keyframes_acked,
              static_cast<long long>(bytes_sent_), static_cast<long long>(bytes_resent_),
              static_cast<long long>(publish_failures_), static_cast<unsigned long long>(inbox_.rejected + AuthRejected(*bus_)),
              inbox_.last_rejection.empty() ? "" : "; last: ", inbox_.last_rejection.c_str());
  std::printf("robot %d %s\n", o_.id, AuthSummary(*bus_).c_str());
  if (o_.live) PrintLiveInputSummary();
  auto digest = RobotDeliveryDigest(agent_->mapper(), agent_->params().record_descriptor_bits);
  std::printf("robot %d session %lld: %s\n", o_.id, static_cast<long long>(session_),
              digest.ok() ? digest->ToText().c_str() : digest.status().message().c_str());
  std::printf("%s\n", PeakRssLine().c_str());
  std::fprintf(stderr, "%s", MemorySummary(setup_.table, agent_->MemoryUse(), platform::ReadRss().peak_bytes).c_str());
  return ok ? kExitOk : kExitFailure;
}

void RobotProcess::PrintLiveInputSummary() const {
  const ScanOdometrySyncStats& s = sync_->stats();
  std::printf("robot %d live input: %llu scans received, %llu mapped, %llu dropped (no odometry yet %llu, odometry "
              "gap %llu, queue full %llu, at the end %llu, too many points %llu, out of order %llu), %llu after the "
              "end; odometry %llu received, %llu rejected; %llu non-finite points dropped; %llu input messages "
              "rejected%s%s\n",
              o_.id, static_cast<unsigned long long>(s.scans_received), static_cast<unsigned long long>(s.scans_taken),
              static_cast<unsigned long long>(s.scans_dropped()),
              static_cast<unsigned long long>(s.scans_dropped_before_odometry),
              static_cast<unsigned long long>(s.scans_dropped_odometry_gap),
              static_cast<unsigned long long>(s.scans_dropped_queue_full),
              static_cast<unsigned long long>(s.scans_dropped_at_end),
              static_cast<unsigned long long>(s.scans_dropped_too_many_points),
              static_cast<unsigned long long>(s.scans_dropped_time_not_increasing),
              static_cast<unsigned long long>(scans_after_end_), static_cast<unsigned long long>(s.odometry_received),
              static_cast<unsigned long long>(s.odometry_rejected()), static_cast<unsigned long long>(nonfinite_points_),
              static_cast<unsigned long long>(input_rejected_), last_input_rejection_.empty() ? "" : "; last: ",
              last_input_rejection_.c_str());
}

int RunRobot(const RobotOptions& o) {
  RobotProcess process(o);
  if (int rc = process.Configure(); rc != kExitOk || process.checked()) return rc;
  return process.Run();
}

}  // namespace

Command AddRobotCommand(CLI::App& root) {
  auto o = std::make_shared<RobotOptions>();
  CLI::App* cmd = root.add_subcommand("robot", "one robot process on LCM: replay a KITTI-layout directory, stream "
                                               "descriptors and poses, answer the server's scan requests");
  cmd->add_option("--id", o->id, "robot id (0..63; robot 0's map is the world frame)")->required()->check(CLI::Range(0, 63));
  auto* data = cmd->add_option("--data", o->data, "input: a KITTI-layout directory replayed at --rate-hz (velodyne/*.bin, "
                                                  "poses.txt), or DIR:FIRST-LAST");
  auto* live = cmd->add_flag("--live", o->live, "input: lidar_scan_t + odometry_t from an odometry stack on this board "
                                                "(see --input-lcm-url, --scan-channel, --odometry-channel)");
  data->excludes(live);
  live->excludes(data);
  cmd->add_option("--input-lcm-url", o->input_lcm_url, "LCM URL of the odometry stack's messages (on-board only: "
                  "scans must not reach the radio)")->capture_default_str();
  cmd->add_option("--scan-channel", o->scan_channel, "channel of lidar_scan_t (sensor-frame points)")->capture_default_str();
  cmd->add_option("--odometry-channel", o->odometry_channel, "channel of odometry_t (T_odom_sensor)")->capture_default_str();
  cmd->add_option("--idle-finish-s", o->idle_finish_s, "live input ends after this long without a scan (or at the "
                  "first SIGINT/SIGTERM; a second one ends the robot) [s]")
      ->check(CLI::Range(0.1, 86400.0))
      ->capture_default_str();
  cmd->add_option("--lidar", o->lidar, "SOLiD sensor preset (hdl-64e, vlp-16, os1-64, os1-128, os2-128, os0-128, avia, aeva)")->capture_default_str();
  AddDescriptorFlags(cmd, &o->descriptor);
  cmd->add_option("--rate-hz", o->rate_hz, "scans replayed per second")->check(CLI::Range(0.1, 1000.0))->capture_default_str();
  cmd->add_option("--keyframe-spacing-m", o->keyframe_spacing_m, "distance between keyframes [m]")->capture_default_str();
  cmd->add_option("--lcm-url", o->lcm_url, "LCM provider URL (default: LCM_DEFAULT_URL)");
  cmd->add_option("--records-per-batch", o->records_per_batch, "keyframe records per keyframe batch (default: as many "
                  "as keep one message inside one 1500-byte datagram: 24 keyframes of a compact batch at 35-45 bytes "
                  "each, 12 records of 92 bytes with --record-descriptor-bits 0, 1 Scan Context record of 1226 "
                  "bytes)")->check(CLI::Range(1, 512));
  cmd->add_option("--poses-per-update", o->poses_per_update, "poses per pose update (the default keeps the update "
                  "of a corrected stretch, 5-8 bytes a pose, inside one 1500-byte datagram)")->check(CLI::Range(1, 4096))->capture_default_str();
  cmd->add_option("--bandwidth-kbps", o->bandwidth_kbps, "cap on what this robot sends [kbit/s] (0 = none; the "
                                                         "default paces bursts so receivers keep up)")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
  cmd->add_option("--resend-timeout-s", o->resend_timeout_s, "unacknowledged data is sent again after this [s]")->capture_default_str();
  cmd->add_option("--batch-delay-s", o->batch_delay_s,
                  "new keyframes wait up to this long to share a keyframe batch (a full batch goes at once) [s]")
      ->check(CLI::Range(0.0, 60.0))
      ->capture_default_str();
  cmd->add_option("--status-interval-s", o->status_interval_s,
                  "publish robot_status_t this often, and when the state changes [s]")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  cmd->add_option("--linger-s", o->linger_s, "after the last scan, wait this long for the merge [s]")->capture_default_str();
  cmd->add_option("--exit-when-merged", o->exit_when_merged, "end once this many robots, this one among them, are in "
                  "the world frame (0 = run until SIGINT)")->check(CLI::Range(0, 64))->capture_default_str();
  AddAuthFlags(cmd, &o->auth);
  AddFaultFlags(cmd, &o->delay_ms, &o->jitter_ms, &o->duplicate_pct);
  cmd->add_flag("--quiet", o->quiet, "no progress lines on stderr");
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o]() { return RunRobot(*o); }};
}

}  // namespace commerge::app
