// SPDX-License-Identifier: BSD-3-Clause
// `commerge robot`: one robot process on LCM. It replays a KITTI-layout directory at --rate-hz (scans + its own
// odometry poses), maps it (keyframes, SOLiD, scan store, loop closure), streams keyframe batches and pose
// updates, answers the server's exchange policies with scan chunks, and re-announces / retransmits from the
// server's transfer status (core/agent/robot_link). Publishes robot_status_t once per second. It ends when
// the server's merge result has placed it in the world frame and every keyframe is acknowledged, or when
// --linger-s passed after the last scan (exit 1: not merged).
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/agent/robot_link.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/slam/scan_store.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_reader.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "platform/memory/peak_rss.hpp"

namespace commerge::app {

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

struct RobotOptions {
  int id = 0;
  std::string data;
  std::string lidar = "hdl-64e";
  double rate_hz = 10.0;
  double keyframe_spacing_m = 1.0;
  std::string lcm_url;
  double bandwidth_kbps = 0.0;
  double linger_s = 60.0;
  double resend_timeout_s = 2.0;
  double delay_ms = 0.0;
  bool quiet = false;
  MemoryFlags memory;
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
  auto spec = platform::ParseRobotDatasetSpec(o.data);
  if (!spec.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, spec.status().message().c_str());
    return kExitUsage;
  }
  auto data = platform::OpenRobotDataset(*spec, /*gt_from_poses=*/true);
  if (!data.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, data.status().message().c_str());
    return kExitFailure;
  }
  auto solid_params = SolidPresetFor(o.lidar);
  if (!solid_params.ok()) {
    std::fprintf(stderr, "%s: --lidar: %s\n", tag, solid_params.status().message().c_str());
    return kExitUsage;
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
  auto bus = platform::OpenLcmBus(bus_params, {platform::kPolicyChannel, platform::kStatusChannel, platform::kMergeResultChannel});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, bus.status().message().c_str());
    return kExitFailure;
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  if (!o.quiet) {
    std::fprintf(stderr, "%s %d: session %lld, %zu scans from %s at %.1f Hz\n", tag, o.id,
                 static_cast<long long>(session), data->scan_files.size(), o.data.c_str(), o.rate_hz);
  }

  TokenBucket bucket(o.bandwidth_kbps * 1000.0 / 8.0, 16384.0);
  Inbox inbox;
  std::int64_t bytes_sent = 0, bytes_resent = 0;
  const Eigen::Isometry3d T_first_inv = data->poses.front().inverse();
  const std::int64_t period_us = static_cast<std::int64_t>(1e6 / o.rate_hz);
  std::int64_t next_scan_us = platform::MonotonicUs(), next_status_us = next_scan_us, data_end_us = -1;
  std::size_t scan = 0;
  bool merged = false;
  std::vector<std::uint8_t> buffer;
  RobotOutgoing out;
  platform::BusMessage message;
  while (!g_stop) {
    const std::int64_t now = platform::MonotonicUs();
    const std::int64_t wall = platform::WallTimeUs();
    if (scan < data->scan_files.size() && now >= next_scan_us) {
      next_scan_us += period_us;
      auto cloud = platform::ReadKittiBin(data->scan_files[scan]);
      if (!cloud.ok()) {
        std::fprintf(stderr, "%s: %s\n", tag, cloud.status().message().c_str());
        return kExitFailure;
      }
      auto step = agent.AddScan(Span<const PointXYZI>(cloud->points), T_first_inv * data->poses[scan]);
      if (!step.ok()) {
        std::fprintf(stderr, "%s: scan %s: %s\n", tag, data->scan_files[scan].c_str(), step.status().message().c_str());
        return kExitFailure;
      }
      if (++scan == data->scan_files.size()) {
        if (Status st = agent.Finish(); !st.ok()) {
          std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
          return kExitFailure;
        }
        data_end_us = now;
      }
    }
    if (Status st = (*bus)->Poll(5); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      return kExitFailure;
    }
    while ((*bus)->Take(&message)) {
      const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
      Status st;
      if (message.channel == platform::kPolicyChannel) {
        auto request = platform::DecodeScanRequest(bytes);
        st = !request.ok() ? request.status()
                           : (request->robot_id == o.id ? link.OnScanRequest(*request, wall) : Status::Ok());
      } else if (message.channel == platform::kStatusChannel) {
        auto status = platform::DecodeTransferStatus(bytes);
        st = !status.ok() ? status.status()
                          : (status->robot_id == o.id ? link.OnTransferStatus(*status, wall) : Status::Ok());
      } else if (message.channel == platform::kMergeResultChannel) {
        auto result = platform::DecodeMergeResult(bytes);
        if (!result.ok()) {
          st = result.status();
        } else if (result->server_session == link.server_session()) {
          for (std::size_t i = 0; i < result->robot_ids.size(); ++i) {
            if (result->robot_ids[i] == o.id && result->in_world[i] && data_end_us >= 0) merged = true;
          }
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
      if (st.ok()) st = (*bus)->Publish(channel, buffer);
      if (!st.ok()) {
        std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
        return kExitFailure;
      }
      bucket.Take(buffer.size());
      bytes_sent += static_cast<std::int64_t>(buffer.size());
      if (out.resend) bytes_resent += static_cast<std::int64_t>(buffer.size());
    }
    const bool all_acked = data_end_us >= 0 && link.stats().keyframes_acked >= agent.mapper().num_keyframes() &&
                           agent.queued_resends() == 0 && agent.queued_poses() == 0;
    const bool done = merged && all_acked;
    if (now >= next_status_us || done) {
      next_status_us = now + 1000000;
      RobotStatus status;
      status.utime_us = wall;
      status.robot_id = o.id;
      status.session = session;
      status.peak_rss_bytes = platform::ReadRss().peak_bytes;
      status.budget_total_bytes = static_cast<std::int64_t>(setup.table.total_bytes());
      status.keyframes = static_cast<std::uint32_t>(agent.mapper().num_keyframes());
      status.keyframes_acked = link.stats().keyframes_acked;
      status.queued_keyframes = static_cast<std::uint32_t>(agent.unsent_keyframes() + agent.queued_resends());
      status.queued_poses = static_cast<std::uint32_t>(agent.queued_poses());
      status.queued_chunks = static_cast<std::uint32_t>(link.queued_chunks());
      status.bytes_sent = bytes_sent;
      status.bytes_resent = bytes_resent;
      status.request_id = link.active_request();
      status.state = done ? "merged" : data_end_us < 0 ? "mapping" : link.queued_chunks() > 0 ? "sending scans" : "waiting";
      if (platform::EncodeRobotStatus(status, &buffer).ok()) (void)(*bus)->Publish(platform::kRobotStatusChannel, buffer);
      if (!o.quiet) {
        std::fprintf(stderr, "%s %d: %s, %u/%u keyframes acknowledged, %lld bytes sent (%lld resent), %llu rejected\n",
                     tag, o.id, status.state.c_str(), status.keyframes_acked, status.keyframes,
                     static_cast<long long>(bytes_sent), static_cast<long long>(bytes_resent),
                     static_cast<unsigned long long>(inbox.rejected));
      }
    }
    if (done) break;
    if (data_end_us >= 0 && static_cast<double>(now - data_end_us) > o.linger_s * 1e6) break;
  }
  // Let delayed messages out before leaving.
  for (int i = 0; i < 400 && (*bus)->delayed() > 0; ++i) (void)(*bus)->Poll(10);
  const bool ok = merged;
  std::printf("robot %d: %s; keyframes %zu, acknowledged %u; bytes sent %lld, resent %lld; rejected messages %llu%s%s\n",
              o.id, ok ? "merged" : "NOT merged", agent.mapper().num_keyframes(), link.stats().keyframes_acked,
              static_cast<long long>(bytes_sent), static_cast<long long>(bytes_resent),
              static_cast<unsigned long long>(inbox.rejected), inbox.last_rejection.empty() ? "" : "; last: ",
              inbox.last_rejection.c_str());
  std::printf("%s\n", PeakRssLine().c_str());
  return ok ? kExitOk : kExitFailure;
}

}  // namespace

Command AddRobotCommand(CLI::App& root) {
  auto o = std::make_shared<RobotOptions>();
  CLI::App* cmd = root.add_subcommand("robot", "one robot process on LCM: replay a KITTI-layout directory, stream "
                                               "descriptors and poses, answer the server's scan requests");
  cmd->add_option("--id", o->id, "robot id (0..63; robot 0's map is the world frame)")->required()->check(CLI::Range(0, 63));
  cmd->add_option("--data", o->data, "KITTI-layout directory (velodyne/*.bin, poses.txt), or DIR:FIRST-LAST")->required();
  cmd->add_option("--lidar", o->lidar, "SOLiD sensor preset (hdl-64e, vlp-16, os1-64, os1-128, os2-128, avia, aeva)")->capture_default_str();
  cmd->add_option("--rate-hz", o->rate_hz, "scans replayed per second")->check(CLI::Range(0.1, 1000.0))->capture_default_str();
  cmd->add_option("--keyframe-spacing-m", o->keyframe_spacing_m, "distance between keyframes [m]")->capture_default_str();
  cmd->add_option("--lcm-url", o->lcm_url, "LCM provider URL (default: LCM_DEFAULT_URL)");
  cmd->add_option("--bandwidth-kbps", o->bandwidth_kbps, "cap on what this robot sends [kbit/s] (0 = none)")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
  cmd->add_option("--resend-timeout-s", o->resend_timeout_s, "unacknowledged data is sent again after this [s]")->capture_default_str();
  cmd->add_option("--linger-s", o->linger_s, "after the last scan, wait this long for the merge [s]")->capture_default_str();
  cmd->add_option("--delay-ms", o->delay_ms, "hold every outgoing message this long (fault tests) [ms]")->capture_default_str();
  cmd->add_flag("--quiet", o->quiet, "no progress lines on stderr");
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o]() { return RunRobot(*o); }};
}

}  // namespace commerge::app
