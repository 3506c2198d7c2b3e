// SPDX-License-Identifier: BSD-3-Clause
// cm_lcm_sampler: a test publisher for lcm-spy. It fills one realistic sample of every commerge message (keyframe
// batch, pose update, scan request / exchange policy, scan chunk, transfer status, merge result, robot status,
// server status), encodes it with the project's own Encode* functions (platform/lcm) and publishes it on its real
// channel, --count rounds at --rate-hz (the LCM URL from LCM_DEFAULT_URL, as the daemons). Before publishing it
// prints one manifest line per channel,
//   sample <channel> <package.type> <fingerprint, 16 hex digits> <bytes>
// where the fingerprint is the first 8 bytes of the encoded message (big-endian), checked against the generated
// type's getHash(); tests/apps/lcm_spy_test.sh compares these with what lcm-spy discovered and decoded.
// Exit codes: 0 published, 1 an encoder or LCM failed, 2 usage.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include <commerge/exchange_policy_t.hpp>
#include <commerge/keyframe_batch_t.hpp>
#include <commerge/lidar_scan_t.hpp>
#include <commerge/merge_result_t.hpp>
#include <commerge/merge_round_t.hpp>
#include <commerge/odometry_t.hpp>
#include <commerge/pose_update_t.hpp>
#include <commerge/robot_status_t.hpp>
#include <commerge/scan_chunk_t.hpp>
#include <commerge/server_status_t.hpp>
#include <commerge/transfer_status_t.hpp>

#include "core/agent/messages.hpp"
#include "core/cloud/point.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/geometry/angles.hpp"
#include "platform/lcm/input_codec.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_auth.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/round_codec.hpp"
#include "platform/lcm/status_codec.hpp"

namespace commerge {
namespace {

using Bytes = std::vector<std::uint8_t>;
constexpr const char* kTag = "cm_lcm_sampler";
constexpr int kRobotId = 1;
constexpr std::int32_t kRequestId = 7;

Eigen::Isometry3d MakePose(double yaw_rad, double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

// One channel: how to encode round `round`'s sample, and the generated type it must match.
struct Sample {
  const char* channel;
  std::string type;           // package.type
  std::uint64_t fingerprint;  // the generated type's getHash()
  std::function<Status(int round, Bytes*)> encode;
};

template <typename LcmType>
Sample MakeSample(const char* channel, std::function<Status(int, Bytes*)> encode) {
  return {channel, std::string("commerge.") + LcmType::getTypeName(), static_cast<std::uint64_t>(LcmType::getHash()),
          std::move(encode)};
}

// The scan whose chunks the sampler sends: a 500-point ring (3 012 encoded bytes: 3 chunks of <= 1 200 B).
Result<Bytes> EncodedRingScan() {
  std::vector<PointXYZI> points(500);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double a = 2.0 * kPi * static_cast<double>(i) / static_cast<double>(points.size());
    const double r = 8.0 + 2.0 * std::sin(5.0 * a);
    points[i].x = static_cast<float>(r * std::cos(a));
    points[i].y = static_cast<float>(r * std::sin(a));
    points[i].z = static_cast<float>(-1.2 + 0.1 * std::cos(3.0 * a));
  }
  Bytes encoded(EncodedScanBytes(points.size()));
  auto info = EncodeScan(Span<const PointXYZI>(points), Span<std::uint8_t>(encoded));
  if (!info.ok()) return info.status();
  encoded.resize(info->bytes_written);
  return encoded;
}

std::vector<Sample> MakeSamples(std::int64_t robot_session, std::int64_t server_session, const Bytes& scan) {
  const std::uint64_t chunks = ScanChunkCount(scan.size(), kMaxScanChunkPayloadBytes);
  std::vector<Sample> s;
  s.push_back(MakeSample<commerge::keyframe_batch_t>(platform::kKeyframesChannel, [=](int round, Bytes* out) {
    KeyframeBatch m;
    m.utime_us = platform::WallTimeUs();
    m.robot_id = kRobotId;
    m.session = robot_session;
    m.sequence = round;
    constexpr std::size_t kRecords = 4;
    m.records.resize(kRecords * kKeyframeRecordBytes);
    for (std::size_t k = 0; k < kRecords; ++k) {
      KeyframeRecord r;
      r.keyframe_index = static_cast<std::uint32_t>(4 * round + static_cast<int>(k));
      r.T_map_sensor = MakePose(0.05 * static_cast<double>(r.keyframe_index), 1.0 * r.keyframe_index, 0.3, 0.0);
      double norm2 = 0.0;
      std::array<double, kKeyframeDescriptorDim> d{};
      for (std::size_t i = 0; i < d.size(); ++i) {
        d[i] = 0.5 + static_cast<double>((i * 3 + k) % 7);
        norm2 += d[i] * d[i];
      }
      for (std::size_t i = 0; i < d.size(); ++i) r.descriptor[i] = static_cast<float>(d[i] / std::sqrt(norm2));
      r.descriptor_valid = true;
      Status st = EncodeKeyframeRecord(r, Span<std::uint8_t>(m.records.data() + k * kKeyframeRecordBytes,
                                                             kKeyframeRecordBytes));
      if (!st.ok()) return st;
      m.stored_points.push_back(k == 2 ? 0u : 4000u + 37u * static_cast<std::uint32_t>(k));
    }
    return platform::EncodeKeyframeBatch(m, out);
  }));
  s.push_back(MakeSample<commerge::pose_update_t>(platform::kPosesChannel, [=](int round, Bytes* out) {
    PoseUpdate m;
    m.utime_us = platform::WallTimeUs();
    m.robot_id = kRobotId;
    m.session = robot_session;
    m.sequence = round;
    m.keyframes = {2, 3, 5};
    for (std::uint32_t k : m.keyframes) m.T_map_sensor.push_back(MakePose(0.1 * k, 1.02 * k, 0.28, 0.01));
    m.no_descriptor = {0, 0, 1};
    return platform::EncodePoseUpdate(m, out);
  }));
  s.push_back(MakeSample<commerge::exchange_policy_t>(platform::kPolicyChannel, [=](int, Bytes* out) {
    ScanRequest m;
    m.utime_us = platform::WallTimeUs();
    m.robot_id = kRobotId;
    m.server_session = server_session;
    m.request_id = kRequestId;
    m.keyframes = {0, 1, 3};
    return platform::EncodeScanRequest(m, out);
  }));
  s.push_back(MakeSample<commerge::scan_chunk_t>(platform::kScansChannel, [=, &scan](int round, Bytes* out) {
    ScanChunk m;
    m.utime_us = platform::WallTimeUs();
    m.robot_id = kRobotId;
    m.request_id = kRequestId;
    m.keyframe = 1;
    m.total_bytes = static_cast<std::uint32_t>(scan.size());
    m.num_chunks = static_cast<std::uint16_t>(chunks);
    m.chunk_index = static_cast<std::uint16_t>(static_cast<std::uint64_t>(round) % chunks);
    const ChunkRange range = ScanChunkRange(scan.size(), chunks, m.chunk_index);
    m.payload.assign(scan.begin() + static_cast<std::ptrdiff_t>(range.offset),
                     scan.begin() + static_cast<std::ptrdiff_t>(range.offset + range.size));
    return platform::EncodeScanChunk(m, out);
  }));
  s.push_back(MakeSample<commerge::transfer_status_t>(platform::kStatusChannel, [=](int round, Bytes* out) {
    TransferStatus m;
    m.utime_us = platform::WallTimeUs();
    m.robot_id = kRobotId;
    m.server_session = server_session;
    m.robot_session = robot_session;
    m.keyframes_contiguous = 2;
    m.keyframes_seen = 4;
    m.gaps = {{2, 3}};
    m.pose_sequences = {round};
    m.request_id = kRequestId;
    m.request_complete = false;
    m.missing = {{1, 2, 1}, {3, 0, 0}};
    return platform::EncodeTransferStatus(m, out);
  }));
  s.push_back(MakeSample<commerge::merge_result_t>(platform::kMergeResultChannel, [=](int round, Bytes* out) {
    MergeResultMessage m;
    m.utime_us = platform::WallTimeUs();
    m.server_session = server_session;
    m.round = round + 1;
    m.robot_ids = {0, 1};
    m.in_world = {1, 1};
    m.keyframes = {200, 200};
    m.T_world_map = {Eigen::Isometry3d::Identity(), MakePose(0.52, 12.5, -3.25, 0.4)};
    MergePairOutcome p;
    p.alpha = 0;
    p.beta = 1;
    p.success = true;
    p.verdict = "success";
    p.T_alpha_beta = m.T_world_map[1];
    p.loops_stage_a = 12;
    p.loops_stage_c = 5;
    p.alpha_scans = 3;
    p.beta_scans = 3;
    p.overlap = 0.62f;
    p.inliers = 850;
    p.consistent = true;
    m.pairs = {p};
    return platform::EncodeMergeResult(m, out);
  }));
  s.push_back(MakeSample<commerge::merge_round_t>(platform::kRoundChannel, [=](int round, Bytes* out) {
    RoundStep m;
    m.utime_us = platform::WallTimeUs();
    m.server_session = server_session;
    m.round = round + 1;
    m.step = 0;
    for (int r : {0, 1}) {
      RoundRobotInput in;
      in.robot_id = r;
      in.session = robot_session + r;
      in.keyframe_batches = 17;
      in.pose_updates = 2;
      in.scan_chunks = 40u * static_cast<std::uint32_t>(round);
      in.digest = 0x811c9dc5u + static_cast<std::uint32_t>(r);
      m.robots.push_back(in);
    }
    ScanRequest q;
    q.robot_id = kRobotId;
    q.request_id = kRequestId;
    q.keyframes = {3, 4, 5};
    m.requests = {q};
    return platform::EncodeRoundStep(m, out);
  }));
  // The odometry stack's input (board-local in a deployment; here on the same URL, for lcm-spy).
  s.push_back(MakeSample<commerge::lidar_scan_t>(platform::kLidarScanChannel, [=](int round, Bytes* out) {
    LidarScan m;
    m.utime_us = robot_session + 100000 * round;
    m.frame = "velodyne";
    for (int i = 0; i < 360; ++i) {
      const float a = static_cast<float>(i) * kPiF / 180.0f;
      m.points.push_back({12.0f * std::cos(a), 12.0f * std::sin(a), -1.5f + 0.01f * static_cast<float>(round), 0.25f});
    }
    return platform::EncodeLidarScan(m, out);
  }));
  s.push_back(MakeSample<commerge::odometry_t>(platform::kOdometryChannel, [=](int round, Bytes* out) {
    OdometrySample m;
    m.utime_us = robot_session + 100000 * round;
    m.odom_frame = "odom";
    m.sensor_frame = "velodyne";
    m.T_odom_sensor = Eigen::Isometry3d::Identity();
    m.T_odom_sensor.translation() = Eigen::Vector3d(1.0 * round, 0.5, 0.0);
    m.T_odom_sensor.linear() = Eigen::AngleAxisd(0.1 * round, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return platform::EncodeOdometry(m, out);
  }));
  s.push_back(MakeSample<commerge::robot_status_t>(platform::kRobotStatusChannel, [=](int round, Bytes* out) {
    RobotStatus m;
    m.utime_us = platform::WallTimeUs();
    m.robot_id = kRobotId;
    m.session = robot_session;
    constexpr std::int64_t kMiB = 1 << 20;
    m.peak_rss_bytes = 310 * kMiB + round * kMiB;
    m.budget_total_bytes = 900 * kMiB;
    m.budget_limit_bytes = 2530 * kMiB;
    m.modules = {{"descriptor_db", 4 * kMiB, 1 * kMiB, 1 * kMiB},
                 {"pose_graph", 2 * kMiB, kMiB / 2, kMiB / 2},
                 {"scan_store", 512 * kMiB, 96 * kMiB + round * kMiB, 120 * kMiB},
                 {"scan_workspace", 64 * kMiB, 18 * kMiB, 40 * kMiB},
                 {"loop_closure", 32 * kMiB, 0, 12 * kMiB},
                 {"outbox", 16 * kMiB, 3 * kMiB, 5 * kMiB},
                 {"runtime", 96 * kMiB, 70 * kMiB, 72 * kMiB}};
    m.keyframes = 4;
    m.keyframes_acked = 2;
    m.queued_keyframes = 1;
    m.queued_poses = 3;
    m.queued_chunks = 2;
    m.bytes_sent = 41250 + 1500 * round;
    m.bytes_resent = 1220;
    m.request_id = kRequestId;
    m.state = "sending scans";
    return platform::EncodeRobotStatus(m, out);
  }));
  s.push_back(MakeSample<commerge::server_status_t>(platform::kServerStatusChannel, [=](int round, Bytes* out) {
    ServerStatus m;
    m.utime_us = platform::WallTimeUs();
    m.session = server_session;
    constexpr std::int64_t kMiB = 1 << 20;
    m.peak_rss_bytes = 640 * kMiB;
    m.budget_total_bytes = 1400 * kMiB;
    m.budget_limit_bytes = 2530 * kMiB;
    m.modules = {{"descriptor_db", 8 * kMiB, 1 * kMiB, 1 * kMiB},
                 {"affinity", 2 * kMiB, kMiB / 4, kMiB / 4},
                 {"solvers", 64 * kMiB, 0, 9 * kMiB},
                 {"scan_reassembly", 48 * kMiB, 2 * kMiB, 6 * kMiB},
                 {"submaps", 256 * kMiB, 0, 80 * kMiB},
                 {"registration", 256 * kMiB, 0, 95 * kMiB},
                 {"merged_map", 512 * kMiB, 0, 0},
                 {"inbox", 16 * kMiB, kMiB, 2 * kMiB},
                 {"runtime", 96 * kMiB, 74 * kMiB, 75 * kMiB}};
    m.round = round;
    m.state = "waiting for scans";
    m.bytes_received = 52000 + 1500 * round;
    m.messages_rejected = 1;
    m.last_rejection = "pose_update_t from robot 3: no session at the server";
    m.robot_ids = {0, 1};
    m.keyframes = {6, 2};
    m.scans = {3, 0};
    m.chunks_missing = {0, 4};
    m.descriptor_ids = {0x761BEAA5u, 0x761BEAA5u};  // the HDL-64E preset's id
    return platform::EncodeServerStatus(m, out);
  }));
  return s;
}

std::uint64_t FirstEightBytesBigEndian(const Bytes& b) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8 && i < b.size(); ++i) v = (v << 8) | b[i];
  return v;
}

// --hostile: for every channel a daemon listens on, messages it must refuse and count: the sample truncated to
// half, its fingerprint changed, random bytes, 100 kB of random bytes, and another channel's sample; on the
// server's keyframe and pose channels also the sample from robot 40 (outside any --robots). Returns how many of
// one round go to the server and how many to each robot.
struct HostileRound {
  std::vector<std::pair<const char*, Bytes>> messages;
  std::size_t to_server = 0, to_each_robot = 0;
};

HostileRound MakeHostile(const std::vector<Sample>& samples, int round, std::uint32_t seed) {
  std::mt19937 rng(seed + static_cast<std::uint32_t>(round));
  auto random_bytes = [&rng](std::size_t n) {
    Bytes b(n);
    for (auto& x : b) x = static_cast<std::uint8_t>(rng());
    return b;
  };
  const char* const server_channels[] = {platform::kKeyframesChannel, platform::kPosesChannel, platform::kScansChannel};
  const char* const robot_channels[] = {platform::kPolicyChannel, platform::kStatusChannel,
                                        platform::kMergeResultChannel};
  HostileRound h;
  Bytes own, foreign;
  for (const Sample& s : samples) {
    const std::string channel = s.channel;
    bool to_server = false, to_robot = false;
    for (const char* c : server_channels) to_server = to_server || channel == c;
    for (const char* c : robot_channels) to_robot = to_robot || channel == c;
    if (!to_server && !to_robot) continue;
    if (!s.encode(round, &own).ok()) continue;
    // Another channel's sample: a foreign fingerprint here.
    const Sample& other = samples[(static_cast<std::size_t>(&s - samples.data()) + 1) % samples.size()];
    if (!other.encode(round, &foreign).ok()) continue;
    Bytes fingerprint = own;
    fingerprint[3] ^= 0x5a;
    const std::vector<Bytes> bad = {Bytes(own.begin(), own.begin() + static_cast<std::ptrdiff_t>(own.size() / 2)),
                                    fingerprint, random_bytes(200), random_bytes(100000), foreign};
    for (const Bytes& b : bad) h.messages.push_back({s.channel, b});
    (to_server ? h.to_server : h.to_each_robot) += bad.size();
    if (channel == platform::kKeyframesChannel || channel == platform::kPosesChannel) {
      Bytes unknown = own;  // int16 robot_id right after the fingerprint and utime: robot 40
      unknown[16] = 0;
      unknown[17] = 40;
      h.messages.push_back({s.channel, unknown});
      ++h.to_server;
    }
  }
  return h;
}

// --attack TEAM_KEY_FILE: during a mission with authentication on, captures the daemons' signed messages and
// publishes, for some of them (at most --attack-per-s per second to the server and as many to the robots), what an attacker or a broken team member would:
// the message again (replayed), with one payload byte flipped (tampered), re-signed with another team's key
// (foreign team), and re-signed with the team key as robot 40 (an unknown robot id). Every one must be refused.
// It stops after --attack-s, or once a merge result places every robot it names (the mission is over: robots
// leave soon after, and messages to a robot that has left would not be counted).
struct AttackCounts {
  std::size_t to_server = 0, to_each_robot = 0, replayed = 0, tampered = 0, foreign = 0, unknown_robot = 0;
};

int Attack(const std::string& team_key_file, double seconds, double per_s) {
  auto team = platform::LoadTeamKeyring(team_key_file);
  if (!team.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, team.status().message().c_str());
    return 2;
  }
  auto foreign_key = platform::GenerateTeamKey(team->keys.front().id);  // same id, another team's secret
  if (!foreign_key.ok()) return 1;
  platform::MessageAuthParams fp;
  fp.keyring.keys = {*foreign_key};
  fp.sender = 0;
  fp.session = platform::WallTimeUs();
  platform::MessageAuthParams ip;
  ip.keyring = *team;
  ip.sender = 40;
  ip.session = fp.session;
  ip.max_robots = platform::kAuthMaxRobots;
  auto foreign = platform::MessageAuthenticator::Create(fp);
  auto insider = platform::MessageAuthenticator::Create(ip);
  auto bus = platform::OpenLcmBus(platform::LcmBusParams{}, {"COMMERGE_.*"});
  if (!foreign.ok() || !insider.ok() || !bus.ok()) {
    std::fprintf(stderr, "%s: attack set-up failed\n", kTag);
    return 1;
  }
  const char* const server_channels[] = {platform::kKeyframesChannel, platform::kPosesChannel, platform::kScansChannel};
  const char* const robot_channels[] = {platform::kPolicyChannel, platform::kStatusChannel,
                                        platform::kMergeResultChannel};
  AttackCounts n;
  const std::int64_t end = platform::MonotonicUs() + static_cast<std::int64_t>(seconds * 1e6);
  std::int64_t next_us[2] = {platform::MonotonicUs(), platform::MonotonicUs()};  // to the server, to the robots
  platform::BusMessage m;
  std::vector<std::pair<std::string, Bytes>> out;
  bool over = false;
  while (!over && platform::MonotonicUs() < end) {
    if (!(*bus)->Poll(10).ok()) return 1;
    out.clear();
    while ((*bus)->Take(&m)) {
      if (m.channel == platform::kMergeResultChannel && m.bytes.size() > platform::kAuthTrailerBytes) {
        auto result = platform::DecodeMergeResult(
            Span<const std::uint8_t>(m.bytes.data(), m.bytes.size() - platform::kAuthTrailerBytes));
        if (result.ok() && result->in_world.size() >= 2) {
          over = true;
          for (std::uint8_t w : result->in_world) over = over && w != 0;
          if (over) break;
        }
      }
      bool to_server = false, to_robot = false;
      for (const char* c : server_channels) to_server = to_server || m.channel == c;
      for (const char* c : robot_channels) to_robot = to_robot || m.channel == c;
      if ((!to_server && !to_robot) || m.bytes.size() <= platform::kAuthTrailerBytes + 8) continue;
      const std::int64_t now = platform::MonotonicUs();
      std::int64_t& next = next_us[to_server ? 0 : 1];
      if (now < next) continue;
      next = now + static_cast<std::int64_t>(1e6 / per_s);
      Bytes tampered = m.bytes;
      tampered[8] ^= 0x01;  // the first byte after the fingerprint
      Bytes payload(m.bytes.begin(), m.bytes.end() - static_cast<std::ptrdiff_t>(platform::kAuthTrailerBytes));
      Bytes other_team = payload, unknown = payload;
      (*foreign)->Sign(m.channel, &other_team);
      (*insider)->Sign(m.channel, &unknown);
      out.push_back({m.channel, m.bytes});
      out.push_back({m.channel, tampered});
      out.push_back({m.channel, other_team});
      out.push_back({m.channel, unknown});
      ++n.replayed, ++n.tampered, ++n.foreign, ++n.unknown_robot;
      (to_server ? n.to_server : n.to_each_robot) += 4;
    }
    for (const auto& [channel, bytes] : out) {
      if (!(*bus)->PublishRaw(channel, bytes).ok()) return 1;
    }
  }
  std::printf("%s: attack: %zu messages the server must refuse, %zu each robot must refuse (replayed %zu, tampered "
              "%zu, foreign team %zu, unknown robot %zu)\n",
              kTag, n.to_server, n.to_each_robot, n.replayed, n.tampered, n.foreign, n.unknown_robot);
  return 0;
}

int Usage(const char* message) {
  if (message != nullptr) std::fprintf(stderr, "%s: %s\n", kTag, message);
  std::fprintf(stderr,
               "usage: %s [--count N] [--rate-hz R] [--hostile] | --attack TEAM_KEY_FILE [--attack-s S] [--attack-per-s R]\n"
               "  publishes one sample of every commerge message on its channel, N rounds (default 5) at R rounds\n"
               "  per second (default 10); the LCM URL is $LCM_DEFAULT_URL (udpm: only inside a private network\n"
               "  namespace, PLATFORM.md 4.1). --hostile publishes instead, on the daemons' channels, messages they\n"
               "  must refuse and count (truncated, foreign fingerprint, random, 100 kB random, another type, robot\n"
               "  40), and prints how many go to the server and to each robot. --attack listens S seconds (default 20)\n"
               "  to a mission with authentication on and, for at most R (default 5) captured messages per second,\n"
               "  publishes the message replayed, tampered, re-signed by another team and signed as robot 40\n",
               kTag);
  return message != nullptr ? 2 : 0;
}

bool ParseNumber(const char* text, double* out) {
  char* end = nullptr;
  *out = std::strtod(text, &end);
  return end != text && *end == '\0' && std::isfinite(*out);
}

int Run(int argc, char** argv) {
  double count = 5.0;
  double rate_hz = 10.0;
  bool hostile = false;
  std::string attack_key;
  double attack_s = 20.0, attack_per_s = 5.0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") return Usage(nullptr);
    if (arg == "--attack" && i + 1 < argc) {
      attack_key = argv[++i];
      continue;
    }
    if ((arg == "--attack-s" || arg == "--attack-per-s") && i + 1 < argc) {
      double v = 0.0;
      if (!ParseNumber(argv[++i], &v) || v <= 0.0 || v > 3600.0) return Usage((arg + ": in (0, 3600]").c_str());
      (arg == "--attack-s" ? attack_s : attack_per_s) = v;
      continue;
    }
    if (arg == "--hostile") {
      hostile = true;
      continue;
    }
    if ((arg == "--count" || arg == "--rate-hz") && i + 1 < argc) {
      double v = 0.0;
      if (!ParseNumber(argv[++i], &v)) return Usage((arg + ": not a number: " + argv[i]).c_str());
      (arg == "--count" ? count : rate_hz) = v;
      continue;
    }
    return Usage(("unknown or incomplete argument '" + arg + "'").c_str());
  }
  if (count < 1.0 || count > 100000.0 || std::floor(count) != count) return Usage("--count: an integer 1..100000");
  if (rate_hz <= 0.0 || rate_hz > 1000.0) return Usage("--rate-hz: in (0, 1000]");
  if (!attack_key.empty()) return Attack(attack_key, attack_s, attack_per_s);

  auto scan = EncodedRingScan();
  if (!scan.ok()) {
    std::fprintf(stderr, "%s: scan: %s\n", kTag, scan.status().message().c_str());
    return 1;
  }
  const std::int64_t robot_session = platform::WallTimeUs();
  const std::int64_t server_session = robot_session - 5000000;
  const std::vector<Sample> samples = MakeSamples(robot_session, server_session, *scan);

  // The manifest, from round 0's encoding: fails before any traffic if an encoder disagrees with its type.
  Bytes buffer;
  for (const Sample& s : samples) {
    Status st = s.encode(0, &buffer);
    if (!st.ok()) {
      std::fprintf(stderr, "%s: %s: %s\n", kTag, s.channel, st.message().c_str());
      return 1;
    }
    const std::uint64_t fp = FirstEightBytesBigEndian(buffer);
    if (buffer.size() < 8 || fp != s.fingerprint) {
      std::fprintf(stderr, "%s: %s: the encoded fingerprint %016llx is not %s's %016llx\n", kTag, s.channel,
                   static_cast<unsigned long long>(fp), s.type.c_str(),
                   static_cast<unsigned long long>(s.fingerprint));
      return 1;
    }
    std::printf("sample %s %s %016llx %zu\n", s.channel, s.type.c_str(), static_cast<unsigned long long>(fp),
                buffer.size());
  }
  std::fflush(stdout);

  auto bus = platform::LcmBus::Create(platform::LcmBusParams{});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, bus.status().message().c_str());
    return 1;
  }
  const int rounds = static_cast<int>(count);
  const auto period = std::chrono::duration<double>(1.0 / rate_hz);
  auto next = std::chrono::steady_clock::now();
  std::size_t hostile_to_server = 0, hostile_to_robot = 0;
  for (int round = 0; round < rounds && hostile; ++round) {
    const HostileRound h = MakeHostile(samples, round, static_cast<std::uint32_t>(robot_session));
    for (const auto& [channel, bytes] : h.messages) {
      if (Status st = (*bus)->Publish(channel, bytes); !st.ok()) {
        std::fprintf(stderr, "%s: round %d, %s: %s\n", kTag, round, channel, st.message().c_str());
        return 1;
      }
      // Paced, so the receivers' kernel buffers (about 200 KiB by default) never overflow: the test counts
      // refusals, and UDP would silently drop a burst of 100 kB messages.
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    hostile_to_server += h.to_server;
    hostile_to_robot += h.to_each_robot;
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    if (round + 1 < rounds) std::this_thread::sleep_until(next);
  }
  if (hostile) {
    std::printf("%s: hostile: %zu messages the server must refuse, %zu each robot must refuse\n", kTag,
                hostile_to_server, hostile_to_robot);
    return (*bus)->stats().publish_errors == 0 ? 0 : 1;
  }
  for (int round = 0; round < rounds; ++round) {
    for (const Sample& s : samples) {
      Status st = s.encode(round, &buffer);
      if (st.ok()) st = (*bus)->Publish(s.channel, buffer);
      if (!st.ok()) {
        std::fprintf(stderr, "%s: round %d, %s: %s\n", kTag, round, s.channel, st.message().c_str());
        return 1;
      }
    }
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    if (round + 1 < rounds) std::this_thread::sleep_until(next);
  }
  const auto& stats = (*bus)->stats();
  std::printf("%s: published %llu messages (%llu bytes) on %zu channels, %d rounds at %g Hz\n", kTag,
              static_cast<unsigned long long>(stats.published), static_cast<unsigned long long>(stats.published_bytes),
              samples.size(), rounds, rate_hz);
  return stats.publish_errors == 0 ? 0 : 1;
}

}  // namespace
}  // namespace commerge

int main(int argc, char** argv) { return commerge::Run(argc, argv); }
