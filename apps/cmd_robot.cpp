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

#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/common/bytes.hpp"
#include "core/agent/delivery_digest.hpp"
#include "core/agent/robot_link.hpp"
#include "core/agent/scan_odometry_sync.hpp"
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

volatile std::sig_atomic_t g_stop = 0;  // counts signals: live input ends at the first, the process at the second
void OnSignal(int) { g_stop = g_stop + 1; }

struct RobotOptions {
  int id = 0;
  std::string data;
  bool live = false;
  std::string input_lcm_url = platform::kDefaultInputLcmUrl;
  std::string scan_channel = platform::kLidarScanChannel;
  std::string odometry_channel = platform::kOdometryChannel;
  double idle_finish_s = 5.0;
  std::string lidar = "hdl-64e";
  double solid_min_z_m = SolidParams{}.min_z_m;
  double rate_hz = 10.0;
  double keyframe_spacing_m = 1.0;
  // One keyframe_batch_t / pose_update_t stays inside one UDP datagram at a 1500-byte MTU (WiFi): LCM drops a
  // whole message when one IP fragment is lost. 12 records = about 1.2 kB encoded, 32 poses = about 1.1 kB.
  std::size_t records_per_batch = 12;
  std::size_t poses_per_update = 32;
  std::string lcm_url;
  double bandwidth_kbps = 4000.0;
  double linger_s = 60.0;
  int exit_when_merged = 2;
  double resend_timeout_s = 2.0;
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

int RunRobot(const RobotOptions& o) {
  const char* tag = "commerge robot";
  MemorySetup setup;
  if (int rc = SetUpMemory(AppKind::kRobot, o.memory, &setup, false); rc != kExitOk) return rc;
  if (o.live == !o.data.empty()) {
    std::fprintf(stderr, "%s: give exactly one input: --data DIR (replay) or --live (odometry stack on LCM)\n", tag);
    return kExitUsage;
  }
  auto solid_params = SolidParamsFromFlags(o.lidar, o.solid_min_z_m);
  if (!solid_params.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, solid_params.status().message().c_str());
    return kExitUsage;
  }
  platform::RobotDataset data;
  if (!o.live) {
    auto spec = platform::ParseRobotDatasetSpec(o.data);
    if (!spec.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, spec.status().message().c_str());
      return kExitUsage;
    }
    auto opened = platform::OpenRobotDataset(*spec, /*gt_from_poses=*/true);
    if (!opened.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, opened.status().message().c_str());
      return kExitFailure;
    }
    data = std::move(*opened);
  }
  auto solid = SolidDescriptor::Create(*solid_params);
  auto store_params = ScanStoreParamsFromBudget(setup.config, ScanStorePolicy::kEvictOldest);
  if (!solid.ok() || !store_params.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, (!solid.ok() ? solid.status() : store_params.status()).message().c_str());
    return kExitFailure;
  }
  auto store = ScanStore::Create(*store_params);
  if (!store.ok()) {
    std::fprintf(stderr, "%s: scan store: %s\n", tag, store.status().message().c_str());
    return kExitFailure;
  }
  RobotMapperCapacity capacity;
  capacity.max_keyframes = static_cast<std::size_t>(setup.config.max_keyframes_per_robot);
  capacity.max_points_per_raw_scan = static_cast<std::size_t>(setup.config.max_points_per_raw_scan);
  capacity.max_points_per_stored_scan = static_cast<std::size_t>(setup.config.max_points_per_stored_scan);
  RobotAgentParams agent_params;
  agent_params.mapper.keyframer.keyframe_spacing_m = o.keyframe_spacing_m;
  agent_params.max_records_per_batch = o.records_per_batch;
  agent_params.max_poses_per_update = o.poses_per_update;
  if (Status st = ValidateRobotAgentParams(agent_params); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  RobotAgent agent(o.id, agent_params, capacity, &*solid, store->get());
  RobotLinkParams link_params;
  link_params.resend_timeout_s = o.resend_timeout_s;
  if (Status st = ValidateRobotLinkParams(link_params); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  const std::int64_t session = platform::WallTimeUs();
  RobotLink link(session, link_params, &agent);

  platform::LcmBusParams bus_params;
  bus_params.url = o.lcm_url;
  bus_params.delay_ms = o.delay_ms;
  bus_params.jitter_ms = o.jitter_ms;
  bus_params.duplicate_pct = o.duplicate_pct;
  bus_params.fault_seed = static_cast<std::uint32_t>(session) ^ static_cast<std::uint32_t>(o.id);
  bus_params.receive_thread = true;  // mapping a scan can take longer than LCM's 30-message queue lasts
  if (int rc = SetUpAuth(tag, o.auth, static_cast<std::uint16_t>(o.id), session, setup.config.max_robots, &bus_params);
      rc != kExitOk) {
    return rc;
  }
  if (o.auth.check) {
    const std::string input = o.live ? "live on " + o.input_lcm_url
                                     : std::to_string(data.scan_files.size()) + " scans from " + o.data;
    std::printf("%s %d: configuration OK (--check): board %s, memory budget %s of %s; input %s; LCM %s; %s\n", tag,
                o.id, o.memory.board.c_str(), FormatBytes(setup.table.total_bytes()).c_str(),
                FormatBytes(setup.limit_bytes).c_str(), input.c_str(),
                o.lcm_url.empty() ? "LCM_DEFAULT_URL" : o.lcm_url.c_str(), AuthDescription(o.auth, bus_params).c_str());
    return kExitOk;
  }
  auto bus = platform::OpenLcmBus(bus_params, {platform::kPolicyChannel, platform::kStatusChannel, platform::kMergeResultChannel});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, bus.status().message().c_str());
    return kExitFailure;
  }
  // Live input: its own bus (the odometry stack's URL on this board), decoder and time synchronisation.
  ScanOdometrySyncParams sync_params;
  sync_params.max_points_per_scan = capacity.max_points_per_raw_scan;
  if (Status st = ValidateScanOdometrySyncParams(sync_params); o.live && !st.ok()) {
    std::fprintf(stderr, "%s: live input: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  std::unique_ptr<ScanOdometrySync> sync;
  std::unique_ptr<platform::LcmBus> input;
  platform::LidarScanDecoder scan_decoder;
  LidarScan scan_in;
  std::uint64_t input_rejected = 0, nonfinite_points = 0, scans_after_end = 0;
  std::string last_input_rejection;
  if (o.live) {
    sync = std::make_unique<ScanOdometrySync>(sync_params);
    platform::LcmBusParams input_params;
    input_params.url = o.input_lcm_url;
    input_params.max_queued_bytes = 64u << 20;  // a few 4 MiB scans plus odometry
    input_params.receive_thread = true;
    auto opened = platform::OpenLcmBus(input_params, {o.scan_channel.c_str(), o.odometry_channel.c_str()});
    if (!opened.ok()) {
      std::fprintf(stderr, "%s: live input: %s\n", tag, opened.status().message().c_str());
      return kExitFailure;
    }
    input = std::move(*opened);
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  if (!o.quiet) {
    if (o.live) {
      std::fprintf(stderr, "%s %d: session %lld, live input %s / %s on %s\n", tag, o.id, static_cast<long long>(session),
                   o.scan_channel.c_str(), o.odometry_channel.c_str(), o.input_lcm_url.c_str());
    } else {
      std::fprintf(stderr, "%s %d: session %lld, %zu scans from %s at %.1f Hz\n", tag, o.id,
                   static_cast<long long>(session), data.scan_files.size(), o.data.c_str(), o.rate_hz);
    }
    // The id is not in the messages: the operator compares it across the team's robots.
    std::fprintf(stderr, "%s %d: descriptor SOLiD %s, %s, parameter id 0x%08X (every robot must show the same)\n",
                 tag, o.id, o.lidar.c_str(), SolidMinZText(*solid_params).c_str(),
                 static_cast<unsigned>(SolidParameterId(*solid_params)));
  }
  if (!o.quiet || !bus_params.authenticate) {
    std::fprintf(stderr, "%s %d: %s\n", tag, o.id, AuthDescription(o.auth, bus_params).c_str());
  }

  TokenBucket bucket(o.bandwidth_kbps * 1000.0 / 8.0, 16384.0);
  Inbox inbox;
  std::int64_t bytes_sent = 0, bytes_resent = 0, publish_failures = 0;
  std::string last_publish_error;
  Eigen::Isometry3d T_first_inv = o.live ? Eigen::Isometry3d::Identity() : data.poses.front().inverse();
  bool have_first = !o.live;
  std::int64_t last_scan_us = -1;
  const std::int64_t period_us = static_cast<std::int64_t>(1e6 / o.rate_hz);
  std::int64_t next_scan_us = platform::MonotonicUs(), next_status_us = next_scan_us, data_end_us = -1;
  std::size_t scan = 0;
  // The server session whose merge result placed this robot (0: none yet). Kept once set: a duplicated or late
  // copy of an earlier result must not undo it; a new server session (a restarted server) starts over.
  std::int64_t merged_session = 0;
  bool merged = false;
  std::vector<std::uint8_t> buffer;
  RobotOutgoing out;
  platform::BusMessage message;
  // The map frame is the first scan's sensor frame: poses are relative to the first odometry pose.
  auto map_scan = [&](Span<const PointXYZI> points, const Eigen::Isometry3d& T_odom_sensor, const char* what) {
    if (!have_first) {
      T_first_inv = T_odom_sensor.inverse();
      have_first = true;
    }
    auto step = agent.AddScan(points, T_first_inv * T_odom_sensor);
    if (!step.ok()) std::fprintf(stderr, "%s: scan %s: %s\n", tag, what, step.status().message().c_str());
    return step.ok();
  };
  auto finish_input = [&](std::int64_t now) {
    if (Status st = agent.Finish(); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      return false;
    }
    data_end_us = now;
    return true;
  };
  while (g_stop == 0 || (o.live && g_stop == 1)) {  // live: the first signal ends the input, the second the robot
    const std::int64_t now = platform::MonotonicUs();
    const std::int64_t wall = platform::WallTimeUs();
    if (!o.live && scan < data.scan_files.size() && now >= next_scan_us) {
      next_scan_us += period_us;
      auto cloud = platform::ReadKittiBin(data.scan_files[scan]);
      if (!cloud.ok()) {
        std::fprintf(stderr, "%s: %s\n", tag, cloud.status().message().c_str());
        return kExitFailure;
      }
      if (!map_scan(Span<const PointXYZI>(cloud->points), data.poses[scan], data.scan_files[scan].c_str())) {
        return kExitFailure;
      }
      if (++scan == data.scan_files.size() && !finish_input(now)) return kExitFailure;
    }
    if (o.live) {
      if (Status st = input->Poll(0); !st.ok()) {
        std::fprintf(stderr, "%s: live input: %s\n", tag, st.message().c_str());
        return kExitFailure;
      }
      while (input->Take(&message)) {
        const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
        Status st;
        if (message.channel == o.scan_channel) {
          st = scan_decoder.Decode(bytes, &scan_in);
          if (st.ok() && data_end_us >= 0) {
            ++scans_after_end;  // the mapper is closed
          } else if (st.ok()) {
            nonfinite_points += scan_in.dropped_nonfinite;
            sync->PushScan(scan_in);
            last_scan_us = now;
          }
        } else if (message.channel == o.odometry_channel) {
          auto odometry = platform::DecodeOdometry(bytes);
          if (odometry.ok()) {
            sync->PushOdometry(*odometry);
          } else {
            st = odometry.status();
          }
        }
        if (!st.ok()) {
          ++input_rejected;
          last_input_rejection = message.channel + ": " + st.message();
        }
      }
      SyncedScan ready;
      while (data_end_us < 0 && sync->PopReady(&ready)) {
        if (!map_scan(ready.points, ready.T_odom_sensor, "from the odometry stack")) return kExitFailure;
      }
      // The input is over after --idle-finish-s without a scan, or at the first signal.
      const bool idle = last_scan_us >= 0 && static_cast<double>(now - last_scan_us) > o.idle_finish_s * 1e6;
      if (data_end_us < 0 && (idle || g_stop == 1)) {
        sync->DropWaiting();
        while (sync->PopReady(&ready)) {
          if (!map_scan(ready.points, ready.T_odom_sensor, "from the odometry stack")) return kExitFailure;
        }
        if (!finish_input(now)) return kExitFailure;
        if (!o.quiet) {
          const ScanOdometrySyncStats& s = sync->stats();
          std::fprintf(stderr, "%s %d: live input ended (%s): %llu scans mapped, %llu dropped, %llu odometry samples "
                       "rejected, %llu non-finite points, %llu messages rejected\n", tag, o.id,
                       idle ? "no scan for --idle-finish-s" : "signal", static_cast<unsigned long long>(s.scans_taken),
                       static_cast<unsigned long long>(s.scans_dropped()),
                       static_cast<unsigned long long>(s.odometry_rejected()),
                       static_cast<unsigned long long>(nonfinite_points), static_cast<unsigned long long>(input_rejected));
        }
      }
    }
    if (Status st = (*bus)->Poll(5); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      return kExitFailure;
    }
    while ((*bus)->Take(&message)) {
      const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
      // Every channel this robot reads is the server's: a robot's signature there is a team member misbehaving.
      Status st = CheckSigner(message, platform::kAuthServerSender);
      if (st.ok() && message.channel == platform::kPolicyChannel) {
        auto request = platform::DecodeScanRequest(bytes);
        st = !request.ok() ? request.status()
                           : (request->robot_id == o.id ? link.OnScanRequest(*request, wall) : Status::Ok());
      } else if (st.ok() && message.channel == platform::kStatusChannel) {
        auto status = platform::DecodeTransferStatus(bytes);
        st = !status.ok() ? status.status()
                          : (status->robot_id == o.id ? link.OnTransferStatus(*status, wall) : Status::Ok());
      } else if (st.ok() && message.channel == platform::kMergeResultChannel) {
        auto result = platform::DecodeMergeResult(bytes);
        if (!result.ok()) {
          st = result.status();
        } else if (result->server_session == link.server_session() && data_end_us >= 0) {
          // Robot 0 is always "in the world" (its map is the world frame): count the robots placed with it.
          // The round must have seen every keyframe of this robot, not an early part of its data.
          int placed = 0;
          bool self = false;
          for (std::size_t i = 0; i < result->robot_ids.size(); ++i) {
            if (!result->in_world[i]) continue;
            ++placed;
            self = self || (result->robot_ids[i] == o.id && result->keyframes[i] == agent.mapper().num_keyframes());
          }
          if (self && o.exit_when_merged > 0 && placed >= o.exit_when_merged) merged_session = result->server_session;
        }
      }
      if (!st.ok()) {
        ++inbox.rejected;
        inbox.last_rejection = message.channel + ": " + st.message();
      }
    }
    while (bucket.CanSend(now)) {
      auto more = link.Next(wall, &out);
      if (!more.ok()) {
        std::fprintf(stderr, "%s: %s\n", tag, more.status().message().c_str());
        return kExitFailure;
      }
      if (!*more) break;
      const char* channel = platform::kScansChannel;
      Status st;
      switch (out.kind) {
        case RobotOutgoing::Kind::kKeyframeBatch:
          st = platform::EncodeKeyframeBatch(out.batch, &buffer);
          channel = platform::kKeyframesChannel;
          break;
        case RobotOutgoing::Kind::kPoseUpdate:
          st = platform::EncodePoseUpdate(out.poses, &buffer);
          channel = platform::kPosesChannel;
          break;
        case RobotOutgoing::Kind::kScanChunk: st = platform::EncodeScanChunk(out.chunk, &buffer); break;
      }
      if (!st.ok()) {  // an encoder refusing the agent's own message is a bug, not a network fault
        std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
        return kExitFailure;
      }
      // A failed publish is a lost message: counted, and the transfer status brings it back.
      if (Status pub = (*bus)->Publish(channel, buffer); !pub.ok()) {
        if (publish_failures++ == 0 && !o.quiet) std::fprintf(stderr, "%s %d: %s\n", tag, o.id, pub.message().c_str());
        last_publish_error = pub.message();
      }
      bucket.Take(buffer.size());
      bytes_sent += static_cast<std::int64_t>(buffer.size());
      if (out.resend) bytes_resent += static_cast<std::int64_t>(buffer.size());
    }
    const bool all_acked = data_end_us >= 0 && link.stats().keyframes_acked >= agent.mapper().num_keyframes() &&
                           agent.queued_resends() == 0 && agent.queued_poses() == 0 && link.queued_chunks() == 0;
    merged = merged_session != 0 && merged_session == link.server_session();
    const bool done = merged && all_acked;
    if (now >= next_status_us || done) {
      next_status_us = now + 1000000;
      RobotStatus status;
      status.utime_us = wall;
      status.robot_id = o.id;
      status.session = session;
      status.peak_rss_bytes = platform::ReadRss().peak_bytes;
      status.budget_total_bytes = static_cast<std::int64_t>(setup.table.total_bytes());
      status.budget_limit_bytes = setup.limit_bytes;
      status.modules = StatusModules(setup.table, agent.MemoryUse());
      status.keyframes = static_cast<std::uint32_t>(agent.mapper().num_keyframes());
      status.keyframes_acked = link.stats().keyframes_acked;
      status.queued_keyframes = static_cast<std::uint32_t>(agent.unsent_keyframes() + agent.queued_resends());
      status.queued_poses = static_cast<std::uint32_t>(agent.queued_poses());
      status.queued_chunks = static_cast<std::uint32_t>(link.queued_chunks());
      status.bytes_sent = bytes_sent;
      status.bytes_resent = bytes_resent;
      status.request_id = link.active_request();
      status.state = done ? "merged" : data_end_us < 0 ? "mapping" : link.queued_chunks() > 0 ? "sending scans" : "waiting";
      // The server lingers until every placed robot said "merged": the last status goes out three times, so one
      // lost datagram does not keep the server waiting for --linger-s.
      if (platform::EncodeRobotStatus(status, &buffer).ok()) {
        for (int copy = 0; copy < (done ? 3 : 1); ++copy) (void)(*bus)->Publish(platform::kRobotStatusChannel, buffer);
      }
      if (!o.quiet) {
        std::fprintf(stderr, "%s %d: %s, %u/%u keyframes acknowledged, %lld bytes sent (%lld resent), %llu rejected\n",
                     tag, o.id, status.state.c_str(), status.keyframes_acked, status.keyframes,
                     static_cast<long long>(bytes_sent), static_cast<long long>(bytes_resent),
                     static_cast<unsigned long long>(inbox.rejected + AuthRejected(**bus)));
      }
    }
    if (done) break;
    if (data_end_us >= 0 && o.exit_when_merged > 0 && static_cast<double>(now - data_end_us) > o.linger_s * 1e6) break;
  }
  // Let delayed messages out before leaving (Poll returns at once while messages are queued: drop them).
  for (int i = 0; i < 400 && (*bus)->delayed() > 0; ++i) {
    (void)(*bus)->Poll(10);
    while ((*bus)->Take(&message)) {
    }
  }
  const bool ok = o.exit_when_merged == 0 || merged;  // 0: ended by a signal, as asked
  std::printf("robot %d: %s; keyframes %zu, acknowledged %u; bytes sent %lld, resent %lld; publish failures %lld; "
              "rejected messages %llu%s%s\n",
              o.id, ok ? "merged" : "NOT merged", agent.mapper().num_keyframes(), link.stats().keyframes_acked,
              static_cast<long long>(bytes_sent), static_cast<long long>(bytes_resent),
              static_cast<long long>(publish_failures),
              static_cast<unsigned long long>(inbox.rejected + AuthRejected(**bus)),
              inbox.last_rejection.empty() ? "" : "; last: ", inbox.last_rejection.c_str());
  std::printf("robot %d %s\n", o.id, AuthSummary(**bus).c_str());
  if (o.live) {
    const ScanOdometrySyncStats& s = sync->stats();
    std::printf("robot %d live input: %llu scans received, %llu mapped, %llu dropped (no odometry yet %llu, odometry "
                "gap %llu, queue full %llu, at the end %llu, too many points %llu, out of order %llu), %llu after the "
                "end; odometry %llu received, %llu rejected; %llu non-finite points dropped; %llu input messages "
                "rejected%s%s\n",
                o.id, static_cast<unsigned long long>(s.scans_received), static_cast<unsigned long long>(s.scans_taken),
                static_cast<unsigned long long>(s.scans_dropped()),
                static_cast<unsigned long long>(s.scans_dropped_before_odometry),
                static_cast<unsigned long long>(s.scans_dropped_odometry_gap),
                static_cast<unsigned long long>(s.scans_dropped_queue_full),
                static_cast<unsigned long long>(s.scans_dropped_at_end),
                static_cast<unsigned long long>(s.scans_dropped_too_many_points),
                static_cast<unsigned long long>(s.scans_dropped_time_not_increasing),
                static_cast<unsigned long long>(scans_after_end), static_cast<unsigned long long>(s.odometry_received),
                static_cast<unsigned long long>(s.odometry_rejected()), static_cast<unsigned long long>(nonfinite_points),
                static_cast<unsigned long long>(input_rejected), last_input_rejection.empty() ? "" : "; last: ",
                last_input_rejection.c_str());
  }
  auto digest = RobotDeliveryDigest(agent.mapper());
  std::printf("robot %d session %lld: %s\n", o.id, static_cast<long long>(session),
              digest.ok() ? digest->ToText().c_str() : digest.status().message().c_str());
  std::printf("%s\n", PeakRssLine().c_str());
  std::fprintf(stderr, "%s", MemorySummary(setup.table, agent.MemoryUse(), platform::ReadRss().peak_bytes).c_str());
  return ok ? kExitOk : kExitFailure;
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
  cmd->add_option("--lidar", o->lidar, "SOLiD sensor preset (hdl-64e, vlp-16, os1-64, os1-128, os2-128, avia, aeva)")->capture_default_str();
  AddSolidMinZFlag(cmd, &o->solid_min_z_m);
  cmd->add_option("--rate-hz", o->rate_hz, "scans replayed per second")->check(CLI::Range(0.1, 1000.0))->capture_default_str();
  cmd->add_option("--keyframe-spacing-m", o->keyframe_spacing_m, "distance between keyframes [m]")->capture_default_str();
  cmd->add_option("--lcm-url", o->lcm_url, "LCM provider URL (default: LCM_DEFAULT_URL)");
  cmd->add_option("--records-per-batch", o->records_per_batch, "keyframe records per keyframe batch (the default "
                  "keeps one message inside one 1500-byte datagram)")->check(CLI::Range(1, 512))->capture_default_str();
  cmd->add_option("--poses-per-update", o->poses_per_update, "poses per pose update (the default keeps one message "
                  "inside one 1500-byte datagram)")->check(CLI::Range(1, 4096))->capture_default_str();
  cmd->add_option("--bandwidth-kbps", o->bandwidth_kbps, "cap on what this robot sends [kbit/s] (0 = none; the "
                                                         "default paces bursts so receivers keep up)")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
  cmd->add_option("--resend-timeout-s", o->resend_timeout_s, "unacknowledged data is sent again after this [s]")->capture_default_str();
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
