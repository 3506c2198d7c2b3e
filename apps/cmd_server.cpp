// SPDX-License-Identifier: BSD-3-Clause
// `commerge server`: the merge server process on LCM. It receives keyframe batches, pose updates and scan
// chunks (decoded with the bounded decoders; malformed, foreign, stale and unknown-robot messages are counted),
// sends transfer statuses and exchange policies, runs merge rounds (core/agent/server_link), publishes
// merge_result_t and server_status_t, and writes transforms.txt and the merged map of the scans it holds
// (merged_map.pcd / .ply, robot id per point) after every round. With --exit-when-merged N it ends (exit 0) once
// N robots are in the world frame after a round that saw every delivered keyframe, and every placed robot's
// robot_status_t said "merged" (or --linger-s passed; the result is re-sent every second meanwhile); otherwise it
// runs until SIGINT / SIGTERM. At exit it prints, per robot, a
// digest of the descriptors it holds (compare with the robot's own line: equal = every descriptor arrived).
// --replay takes a mission recorded with lcm-logger and played back with lcm-logplayer: scan chunks are
// accepted without this server's own request (the recording server made the requests).
#include <CLI/CLI.hpp>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <utility>
#include <string>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/common/bytes.hpp"
#include "core/agent/delivery_digest.hpp"
#include "core/agent/server_link.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/exchange/exchange_policy.hpp"
#include "platform/io/pcd.hpp"
#include "platform/io/ply.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "platform/memory/peak_rss.hpp"

namespace commerge::app {

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

struct ServerOptions {
  std::string out_dir = "commerge-server-out";
  std::string mode = "A+B+C";
  std::string lcm_url;
  double round_interval_s = 10.0;
  double round_quiet_s = 3.0;
  double request_timeout_s = 60.0;
  std::int64_t round_min_new_keyframes = 200;
  double tau_inter = 0.0;
  std::int64_t tau_area = -1;
  std::size_t sequence_half_window = 0;
  std::int64_t min_submap_scans = -1;
  int max_widen_steps = MergeServerParams{}.max_widen_steps;
  int exit_when_merged = 0;
  double max_runtime_s = 0.0;
  double linger_s = 10.0;
  bool replay = false;
  double delay_ms = 0.0, jitter_ms = 0.0, duplicate_pct = 0.0;
  bool quiet = false;
  MemoryFlags memory;
  AuthFlags auth;
};

Status WriteTransforms(const std::string& path, const MergeResultMessage& m) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return IoError("cannot write " + path);
  std::fprintf(f, "# commerge server round %d: T_world_map per robot (world = robot 0's map), row-major 3x4\n",
               m.round);
  for (std::size_t i = 0; i < m.robot_ids.size(); ++i) {
    const Eigen::Matrix4d T = m.T_world_map[i].matrix();
    std::fprintf(f, "robot %d %s", m.robot_ids[i], m.in_world[i] ? "merged" : "unmerged");
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) std::fprintf(f, " %.9g", T(r, c));
    }
    std::fprintf(f, "\n");
  }
  for (const MergePairOutcome& p : m.pairs) {
    std::fprintf(f, "# pair %d-%d: %s, overlap %.3f, %u inliers, scans %u + %u%s\n", p.alpha, p.beta,
                 p.verdict.c_str(), static_cast<double>(p.overlap), p.inliers, p.alpha_scans, p.beta_scans,
                 p.success && !p.consistent ? " (rejected as inconsistent)" : "");
  }
  const bool ok = std::fclose(f) == 0;
  return ok ? Status::Ok() : IoError("cannot write " + path);
}

// The scans the server holds of the robots in the world frame, placed with T_world_map * T_map_sensor: the
// merged map the server can build (the robots keep the rest). Returns the number of points written; raises
// *high_water_bytes to the bytes the map's buffers took (the merged_map budget module).
Result<std::size_t> WriteServerMap(const std::string& dir, const MergeServer& server, const MergeResultMessage& m,
                                   std::int64_t* high_water_bytes) {
  std::vector<PointXYZI> map, scan;
  std::vector<std::uint16_t> ids;
  for (std::size_t i = 0; i < m.robot_ids.size(); ++i) {
    if (!m.in_world[i]) continue;
    const int r = m.robot_ids[i];
    const RobotKeyframeDb& db = server.robot(r);
    for (std::size_t k = 0; k < db.size(); ++k) {
      const std::vector<std::uint8_t>* bytes = server.scan_bytes(r, static_cast<std::uint32_t>(k));
      if (bytes == nullptr || !db.pose_known[k]) continue;
      if (!DecodeScan(Span<const std::uint8_t>(bytes->data(), bytes->size()), &scan).ok()) continue;
      const Eigen::Isometry3f T = (m.T_world_map[i] * db.T_map_sensor[k]).cast<float>();
      for (const PointXYZI& p : scan) {
        const Eigen::Vector3f q = T * Eigen::Vector3f(p.x, p.y, p.z);
        map.push_back({q.x(), q.y(), q.z(), p.intensity});
      }
      ids.insert(ids.end(), scan.size(), static_cast<std::uint16_t>(r));
    }
  }
  *high_water_bytes = std::max(*high_water_bytes, static_cast<std::int64_t>((map.capacity() + scan.capacity()) * sizeof(PointXYZI) +
                                                                            ids.capacity() * sizeof(std::uint16_t)));
  if (Status st = platform::WritePcd(dir + "/merged_map.pcd", Span<const PointXYZI>(map), platform::PcdEncoding::kBinary,
                                     Span<const std::uint16_t>(ids));
      !st.ok()) {
    return st;
  }
  if (Status st = platform::WritePly(dir + "/merged_map.ply", Span<const PointXYZI>(map), Span<const std::uint16_t>(ids));
      !st.ok()) {
    return st;
  }
  return map.size();
}

int RunServer(const ServerOptions& o) {
  const char* tag = "commerge server";
  MemorySetup setup;
  if (int rc = SetUpMemory(AppKind::kServer, o.memory, &setup, false); rc != kExitOk) return rc;
  // Robot ids 0..--robots-1 are accepted (the memory flag that also sizes the budget).
  const int robots = setup.config.max_robots;
  if (robots < 2 || robots > 8) {
    std::fprintf(stderr, "%s: --robots = %d is outside 2..8 (the frame solver's limit)\n", tag, robots);
    return kExitUsage;
  }
  auto mode = ExchangeModeFromName(o.mode);
  if (!mode.ok()) {
    std::fprintf(stderr, "%s: --mode: %s\n", tag, mode.status().message().c_str());
    return kExitUsage;
  }
  MergeServerParams server_params;
  if (o.tau_inter > 0.0) server_params.cascade.stage_a.tau_inter = o.tau_inter;
  if (o.tau_area >= 0) server_params.cascade.stage_a.tau_area = static_cast<std::uint64_t>(o.tau_area);
  server_params.cascade.stage_a.sequence_half_window = o.sequence_half_window;
  if (o.min_submap_scans >= 0) {
    server_params.cascade.policy.min_scans_per_robot = static_cast<std::uint32_t>(o.min_submap_scans);
  }
  server_params.max_submap_points = static_cast<std::size_t>(setup.config.max_submap_points);
  server_params.max_widen_steps = o.max_widen_steps;
  if (Status st = ValidateMergeServerParams(server_params); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  ServerLinkParams link_params;
  link_params.mode = *mode;
  link_params.round_interval_s = o.round_interval_s;
  link_params.round_quiet_s = o.round_quiet_s;
  link_params.request_timeout_s = o.request_timeout_s;
  link_params.round_min_new_keyframes = static_cast<std::size_t>(std::max<std::int64_t>(1, o.round_min_new_keyframes));
  link_params.accept_unrequested_scans = o.replay;
  link_params.automatic_rounds = !o.replay;  // a replay runs its rounds where the recording has merge results
  if (Status st = ValidateServerLinkParams(link_params); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  const std::int64_t session = platform::WallTimeUs();
  platform::LcmBusParams bus_params;
  bus_params.url = o.lcm_url;
  bus_params.delay_ms = o.delay_ms;
  bus_params.jitter_ms = o.jitter_ms;
  bus_params.duplicate_pct = o.duplicate_pct;
  bus_params.fault_seed = static_cast<std::uint32_t>(session);
  bus_params.receive_thread = true;  // a round registers for seconds: robots' messages queue meanwhile
  // A replay has nobody to re-send a chunk LCM dropped: lcm-logplayer publishes faster than a live team, so
  // besides the receive thread let LCM hold as many messages per channel as this bus's own queue.
  if (o.replay) bus_params.lcm_queue_capacity = static_cast<int>(bus_params.max_queued_messages);
  if (int rc = SetUpAuth(tag, o.auth, platform::kAuthServerSender, session, robots, &bus_params); rc != kExitOk) {
    return rc;
  }
  if (o.auth.check) {
    std::printf("%s: configuration OK (--check): board %s, memory budget %s of %s; robots 0..%d, mode %s, output %s; "
                "LCM %s; %s\n",
                tag, o.memory.board.c_str(), FormatBytes(setup.table.total_bytes()).c_str(),
                FormatBytes(setup.limit_bytes).c_str(), robots - 1, ExchangeModeName(*mode), o.out_dir.c_str(),
                o.lcm_url.empty() ? "LCM_DEFAULT_URL" : o.lcm_url.c_str(), AuthDescription(o.auth, bus_params).c_str());
    return kExitOk;
  }
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "%s: cannot create --out %s: %s\n", tag, o.out_dir.c_str(), ec.message().c_str());
    return kExitFailure;
  }
  MergeServer server(robots, static_cast<std::size_t>(setup.config.max_keyframes_per_robot), server_params);
  ServerLink link(session, link_params, &server);

  auto bus = o.replay ? platform::OpenLcmBus(bus_params, {platform::kKeyframesChannel, platform::kPosesChannel,
                                                           platform::kScansChannel, platform::kMergeResultChannel})
                      : platform::OpenLcmBus(bus_params, {platform::kKeyframesChannel, platform::kPosesChannel,
                                                           platform::kScansChannel, platform::kRobotStatusChannel});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, bus.status().message().c_str());
    return kExitFailure;
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  if (!o.quiet) {
    std::fprintf(stderr, "%s: session %lld, robots 0..%d, mode %s, writing to %s%s\n", tag,
                 static_cast<long long>(session), robots - 1, ExchangeModeName(*mode), o.out_dir.c_str(),
                 o.replay ? " (replay: recorded scan chunks accepted without a request)" : "");
  }
  if (!o.quiet || !bus_params.authenticate) {
    std::fprintf(stderr, "%s: %s\n", tag, AuthDescription(o.auth, bus_params).c_str());
  }
  std::int64_t bytes_received = 0, rejected = 0;
  // Memory of the budget modules: the merge server's pools and the merged map WriteServerMap builds.
  std::int64_t merged_map_high_water = 0;
  std::vector<std::pair<int, int>> reported_incomparable;  // the last incomparable pairs said on stderr
  auto memory_use = [&server, &merged_map_high_water] {
    std::vector<ModuleMemory> modules = server.MemoryUse();
    modules.push_back(ModuleMemory{"merged_map", 0, 0, merged_map_high_water});
    return modules;
  };
  // Replay: the recording server's (session, round) pairs already followed, and when the recording last spoke.
  std::set<std::pair<std::int64_t, std::int32_t>> recorded_rounds;
  std::int64_t last_recorded_us = platform::MonotonicUs();
  std::string last_rejection;
  const std::int64_t start_us = platform::MonotonicUs();
  std::int64_t next_status_us = start_us;
  // After --exit-when-merged is met the server lingers: it keeps answering and re-sends the result every second
  // until every placed robot's status said "merged" (its current session), at most --linger-s.
  std::int64_t lingering_since_us = -1, next_result_us = 0;
  std::vector<std::int64_t> confirmed_session(static_cast<std::size_t>(robots), 0);
  auto placed_robots_confirmed = [&] {
    const MergeResultMessage& r = link.last_result();
    for (std::size_t i = 0; i < r.robot_ids.size(); ++i) {
      const int id = r.robot_ids[i];
      if (!r.in_world[i] || id < 0 || id >= robots) continue;
      if (confirmed_session[static_cast<std::size_t>(id)] != link.robot_session(id)) return false;
    }
    return true;
  };
  int exit_code = kExitOk;
  std::vector<ServerOutgoing> out;
  std::vector<std::uint8_t> buffer;
  platform::BusMessage message;
  while (!g_stop) {
    if (Status st = (*bus)->Poll(10); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      return kExitFailure;
    }
    const std::int64_t wall = platform::WallTimeUs();
    while ((*bus)->Take(&message)) {
      const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
      Status st;
      if (message.channel == platform::kKeyframesChannel) {
        auto m = platform::DecodeKeyframeBatch(bytes);
        st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
        if (st.ok()) st = link.OnKeyframeBatch(*m, wall);
      } else if (message.channel == platform::kPosesChannel) {
        auto m = platform::DecodePoseUpdate(bytes);
        st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
        if (st.ok()) st = link.OnPoseUpdate(*m, wall);
      } else if (message.channel == platform::kScansChannel) {
        auto m = platform::DecodeScanChunk(bytes);
        st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
        if (st.ok()) st = link.OnScanChunk(*m, wall);
      } else if (message.channel == platform::kMergeResultChannel) {
        auto m = platform::DecodeMergeResult(bytes);
        if (!m.ok()) {
          st = m.status();
        } else if (st = CheckSigner(message, platform::kAuthServerSender); st.ok() && m->server_session != session && recorded_rounds.size() < 100000 &&
                   recorded_rounds.insert({m->server_session, m->round}).second) {
          link.RequestRound();  // the recording merged here: merge on the same data
        }
      } else if (message.channel == platform::kRobotStatusChannel) {
        auto m = platform::DecodeRobotStatus(bytes);
        st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
        if (st.ok() && (m->robot_id < 0 || m->robot_id >= robots)) {
          st = InvalidArgument("robot status of robot " + std::to_string(m->robot_id) + ", not one of --robots " +
                               std::to_string(robots));
        }
        if (st.ok() && m->state == "merged" && m->session != 0 && m->session == link.robot_session(m->robot_id)) {
          confirmed_session[static_cast<std::size_t>(m->robot_id)] = m->session;
          link.OnRobotLeft(m->robot_id, m->session);  // "merged" is a robot's last status: it exits
        }
      }
      last_recorded_us = platform::MonotonicUs();
      if (st.ok()) {
        bytes_received += static_cast<std::int64_t>(message.bytes.size());
      } else {
        ++rejected;
        last_rejection = message.channel + ": " + st.message();
        if (last_rejection.size() > kMaxStatusTextBytes) last_rejection.resize(kMaxStatusTextBytes);
      }
    }
    out.clear();
    if (Status st = link.Poll(wall, &out); !st.ok()) {
      std::fprintf(stderr, "%s: merge round failed: %s\n", tag, st.message().c_str());
    }
    if (server.incomparable_pairs() != reported_incomparable) {
      // Said once per change: a robot started with another --lidar / --solid-min-z-m than the others.
      reported_incomparable = server.incomparable_pairs();
      for (const auto& [a, b] : reported_incomparable) {
        std::fprintf(stderr,
                     "%s: robots %d and %d are not compared: their descriptor parameter ids differ (0x%08X, 0x%08X); "
                     "start every robot with the same --lidar and --solid-min-z-m\n",
                     tag, a, b, static_cast<unsigned>(server.robot(a).descriptor_id),
                     static_cast<unsigned>(server.robot(b).descriptor_id));
      }
    }
    for (const ServerOutgoing& o_msg : out) {
      Status st;
      const char* channel = platform::kStatusChannel;
      switch (o_msg.kind) {
        case ServerOutgoing::Kind::kTransferStatus: st = platform::EncodeTransferStatus(o_msg.status, &buffer); break;
        case ServerOutgoing::Kind::kScanRequest:
          st = platform::EncodeScanRequest(o_msg.request, &buffer);
          channel = platform::kPolicyChannel;
          break;
        case ServerOutgoing::Kind::kMergeResult:
          st = platform::EncodeMergeResult(o_msg.result, &buffer);
          channel = platform::kMergeResultChannel;
          break;
      }
      if (st.ok()) st = (*bus)->Publish(channel, buffer);
      if (!st.ok()) std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      if (o_msg.kind == ServerOutgoing::Kind::kMergeResult) {
        if (Status w = WriteTransforms(o.out_dir + "/transforms.txt", o_msg.result); !w.ok()) {
          std::fprintf(stderr, "%s: %s\n", tag, w.message().c_str());
        }
        auto points = WriteServerMap(o.out_dir, server, o_msg.result, &merged_map_high_water);
        if (!points.ok()) std::fprintf(stderr, "%s: %s\n", tag, points.status().message().c_str());
        if (!o.quiet) {
          std::fprintf(stderr, "%s: %s; merged_map.pcd/.ply %zu points\n", tag, link.state().c_str(),
                       points.ok() ? *points : std::size_t{0});
        }
      }
    }
    const std::int64_t now = platform::MonotonicUs();
    int in_world = 0;
    for (std::uint8_t w : link.last_result().in_world) in_world += w;
    // Done when enough robots are placed and the round behind it saw every keyframe delivered (the robots went
    // quiet): an early round on part of the data does not end the mission.
    const bool done = o.exit_when_merged > 0 && in_world >= o.exit_when_merged && link.Settled(wall) &&
                      (!o.replay || static_cast<double>(now - last_recorded_us) > o.round_quiet_s * 1e6);
    const bool entering_linger = done && lingering_since_us < 0;
    if (entering_linger) lingering_since_us = now;
    if (lingering_since_us >= 0 && now >= next_result_us && link.rounds_merged() > 0) {
      next_result_us = now + 1000000;
      if (platform::EncodeMergeResult(link.last_result(), &buffer).ok()) {
        (void)(*bus)->Publish(platform::kMergeResultChannel, buffer);
      }
    }
    if (now >= next_status_us || entering_linger) {
      next_status_us = now + 1000000;
      ServerStatus status;
      status.utime_us = wall;
      status.session = session;
      status.peak_rss_bytes = platform::ReadRss().peak_bytes;
      status.budget_total_bytes = setup.table.total_bytes();
      status.budget_limit_bytes = setup.limit_bytes;
      status.modules = StatusModules(setup.table, memory_use());
      status.round = link.rounds_merged();
      status.state = link.state();
      status.bytes_received = bytes_received;
      status.messages_rejected = rejected + static_cast<std::int64_t>(AuthRejected(**bus)) +
                                 static_cast<std::int64_t>(server.stats().rejected_batches +
                                                                      server.stats().rejected_pose_updates +
                                                                      server.stats().rejected_chunks);
      status.last_rejection = last_rejection;
      link.AppendRobotStatus(&status);
      if (platform::EncodeServerStatus(status, &buffer).ok()) (void)(*bus)->Publish(platform::kServerStatusChannel, buffer);
      if (!o.quiet) {
        std::fprintf(stderr, "%s: %s; %lld bytes received, %lld messages rejected\n", tag, status.state.c_str(),
                     static_cast<long long>(bytes_received), static_cast<long long>(status.messages_rejected));
      }
    }
    if (lingering_since_us >= 0 &&
        (placed_robots_confirmed() || static_cast<double>(now - lingering_since_us) >= o.linger_s * 1e6)) {
      break;
    }
    if (lingering_since_us < 0 && o.max_runtime_s > 0.0 && static_cast<double>(now - start_us) > o.max_runtime_s * 1e6) {
      exit_code = kExitFailure;
      break;
    }
  }
  int in_world = 0;
  for (std::uint8_t w : link.last_result().in_world) in_world += w;
  int confirmed = 0;
  for (int r = 0; r < robots; ++r) {
    confirmed += confirmed_session[static_cast<std::size_t>(r)] != 0 &&
                 confirmed_session[static_cast<std::size_t>(r)] == link.robot_session(r);
  }
  std::printf("server: %d merge rounds, %d of %zu robots in the world frame, %d confirmed it; %lld bytes received; "
              "%lld messages rejected%s%s\n",
              link.rounds_merged(), in_world, link.last_result().robot_ids.size(), confirmed,
              static_cast<long long>(bytes_received),
              static_cast<long long>(rejected + static_cast<std::int64_t>(AuthRejected(**bus))),
              last_rejection.empty() ? "" : "; last: ", last_rejection.c_str());
  for (int r = 0; r < robots; ++r) {
    if (link.robot_session(r) == 0) continue;
    std::printf("server: robot %d session %lld: %s\n", r, static_cast<long long>(link.robot_session(r)),
                ServerDeliveryDigest(server.robot(r)).ToText().c_str());
  }
  std::printf("server %s\n", AuthSummary(**bus).c_str());
  std::printf("%s\n", PeakRssLine().c_str());
  std::fprintf(stderr, "%s", MemorySummary(setup.table, memory_use(), platform::ReadRss().peak_bytes).c_str());
  if (o.exit_when_merged > 0 && in_world < o.exit_when_merged) exit_code = kExitFailure;
  return exit_code;
}

}  // namespace

Command AddServerCommand(CLI::App& root) {
  auto o = std::make_shared<ServerOptions>();
  CLI::App* cmd = root.add_subcommand("server", "the merge server process on LCM: collect descriptors, request the "
                                                "few scans the cascade selects, register, publish the merge");
  cmd->add_option("--out", o->out_dir, "output directory (transforms.txt after every round)")->capture_default_str();
  cmd->add_option("--mode", o->mode, "exchange mode: send-all, A, A+B, A+C, A+B+C")->capture_default_str();
  cmd->add_option("--lcm-url", o->lcm_url, "LCM provider URL (default: LCM_DEFAULT_URL)");
  cmd->add_option("--round-interval-s", o->round_interval_s, "merge rounds start at most this often [s]")
      ->capture_default_str();
  cmd->add_option("--round-quiet-s", o->round_quiet_s, "start a round when new keyframes arrived and the robots "
                                                       "were quiet this long [s]")->capture_default_str();
  cmd->add_option("--round-min-new-keyframes", o->round_min_new_keyframes,
                  "start a round when this many keyframes arrived since the last")->capture_default_str();
  cmd->add_option("--request-timeout-s", o->request_timeout_s, "merge with what arrived after this [s]")
      ->capture_default_str();
  cmd->add_option("--tau-inter", o->tau_inter, "stage A descriptor distance threshold (0 = the paper's)");
  cmd->add_option("--tau-area", o->tau_area, "stage A minimal cluster span area [cells] (-1 = the paper's 10000)");
  AddSequenceHalfWindowFlag(cmd, &o->sequence_half_window);
  cmd->add_option("--min-submap-scans", o->min_submap_scans,
                  "fewest scans asked of each robot per pair: L_K's keyframes plus the nearest other keyframes of "
                  "stage A's loops (-1 = the default, " +
                      std::to_string(ExchangePolicyParams{}.min_scans_per_robot) + "; 0 = exactly L_K's, the paper's)")
      ->check(CLI::Range(std::int64_t{-1}, std::int64_t{kMaxMinScansPerRobot}));
  cmd->add_option("--max-widen-steps", o->max_widen_steps,
                  "when registration refuses a pair, ask again for up to twice its scans (more of stage A's "
                  "keyframes) and register again, at most this many times per round (0 = the paper's single "
                  "exchange)")
      ->check(CLI::Range(0, 8))
      ->capture_default_str();
  cmd->add_option("--exit-when-merged", o->exit_when_merged, "exit 0 once this many robots are in the world frame "
                  "and the last round saw every keyframe delivered (the robots went quiet for --round-quiet-s)");
  cmd->add_option("--max-runtime-s", o->max_runtime_s, "give up (exit 1) after this long [s] (0 = never)");
  cmd->add_option("--linger-s", o->linger_s, "after --exit-when-merged is met, keep answering and re-send the "
                                           "result every second until every placed robot reported \"merged\", at "
                                           "most this long [s]")->check(CLI::Range(0.0, 3600.0))->capture_default_str();
  cmd->add_flag("--replay", o->replay, "serve a recorded mission played back with lcm-logplayer: accept recorded scan "
                                       "chunks that answer the recording server's requests");
  cmd->add_flag("--quiet", o->quiet, "no progress lines on stderr");
  AddAuthFlags(cmd, &o->auth);
  AddFaultFlags(cmd, &o->delay_ms, &o->jitter_ms, &o->duplicate_pct);
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o]() { return RunServer(*o); }};
}

}  // namespace commerge::app
