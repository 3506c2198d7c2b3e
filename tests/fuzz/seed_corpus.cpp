// SPDX-License-Identifier: BSD-3-Clause
// cm_fuzz_seeds --write-seeds DIR: the seed corpora of the fuzz targets, written at build time into the build
// tree (never committed). Every seed is a valid message made by the project's own encoders, so the fuzzers start
// past the fingerprint check:
//   * a recorded mission: two robots (RobotAgent + RobotLink on ray-cast VLP-16 scans of a street, the second
//     starting 10 m behind the first on the other lane) talk to the fuzzed server (tests/fuzz/server_inbox.hpp)
//     until it merges them: their keyframe batches, pose updates and scan chunks, the server's transfer
//     statuses, exchange policies and merge result, and both daemons' health messages;
//   * the largest legal message of each type (every array at its MAX_..., every string at kMaxStatusTextBytes),
//     which each CTest test runs once before fuzzing: the proof that -malloc_limit_mb leaves room for every
//     legal message (and for the server's largest legal scan);
//   * the smallest (empty arrays, empty strings).
// DIR/<name>/ for every row of tests/fuzz/codec_table.hpp (a row whose type is not known here gets its default
// message, encoded) and DIR/server_inbox/ (the mission stream, its prefix up to the first exchange policy, one
// record per channel); the largest legal messages go to DIR/largest/<name>/ (so no codec may be named "largest").
// Deterministic: the same files on every run.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "core/agent/robot_agent.hpp"
#include "core/agent/robot_link.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/memory/budget.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/scan_store.hpp"
#include "tests/fuzz/codec_table.hpp"
#include "tests/fuzz/fuzz_support.hpp"
#include "tests/fuzz/server_inbox.hpp"
#include "tests/support/batch_keyframes.hpp"

namespace commerge::fuzz {
namespace {

constexpr int kMissionScans = 60;            // per robot, 1.1 m apart
constexpr std::int64_t kMissionLimitUs = 180 * 1000000ll;  // give up (and say so) after 3 simulated minutes
constexpr std::size_t kSeedsPerKind = 6;     // recorded messages kept per type, spread over the mission

// ---- the recorded mission ----

struct MissionRobot {
  int id = 0;
  float start_x_m = 0.0f, lane_y_m = 0.0f;
  std::int64_t session = 0;
  std::unique_ptr<SolidDescriptor> solid;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotAgent> agent;
  std::unique_ptr<RobotLink> link;
  int scans_fed = 0;
  bool finished = false;
  std::int64_t bytes_sent = 0;
};

// What the mission produced, as the plain structs the encoders take.
struct SampleBank {
  std::vector<KeyframeBatch> batches;
  std::vector<PoseUpdate> pose_updates;
  std::vector<ScanRequest> requests;
  std::vector<ScanChunk> chunks;
  std::vector<TransferStatus> statuses;
  std::vector<MergeResultMessage> results;
  std::vector<RoundStep> round_steps;
  std::vector<RobotStatus> robot_statuses;
  std::vector<ServerStatus> server_statuses;
  std::vector<std::uint8_t> stream;         // the whole server inbox
  std::size_t stream_before_chunks = 0;     // bytes of it up to the first exchange policy
  std::vector<std::uint8_t> first_record[kInboxChannels];
};

template <typename T>
T Check(Result<T> r, const char* what) {
  if (!r.ok()) Fail("seed mission: %s: %s", what, r.status().ToString().c_str());
  return std::move(r).value();
}
void Check(const Status& st, const char* what) {
  if (!st.ok()) Fail("seed mission: %s: %s", what, st.ToString().c_str());
}

MissionRobot MakeRobot(int id, float start_x_m, float lane_y_m) {
  MissionRobot r;
  r.id = id;
  r.start_x_m = start_x_m;
  r.lane_y_m = lane_y_m;
  r.session = kInboxStartUs - 600000000ll + id;  // started ten minutes before the server, as a robot might
  r.solid = std::make_unique<SolidDescriptor>(
      Check(SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneVlp16)), "SOLiD"));
  ScanStoreParams sp;
  sp.capacity_bytes = 8u << 20;
  sp.max_scans = 256;
  r.store = Check(ScanStore::Create(sp), "scan store");
  RobotMapperCapacity capacity;
  capacity.max_keyframes = 256;
  capacity.max_points_per_raw_scan = 16 * 900;
  capacity.max_points_per_stored_scan = 8192;
  r.agent = std::make_unique<RobotAgent>(id, RobotAgentParams{}, capacity, r.solid.get(), r.store.get());
  r.link = std::make_unique<RobotLink>(r.session, RobotLinkParams{}, r.agent.get());
  return r;
}

std::vector<ModuleMemory> Modules(AppKind app, std::int64_t used_fraction_permille) {
  std::vector<ModuleMemory> modules;
  const BudgetTable table = MakeBudgetTable(app, DefaultMemoryConfig(BoardProfile::kJetsonNano));
  for (const BudgetEntry& e : table.entries()) {
    if (modules.size() == kMaxStatusModules) break;
    ModuleMemory m;
    m.name = e.module;
    m.budget_bytes = e.bytes;
    m.used_bytes = e.bytes / 1000 * used_fraction_permille;
    m.high_water_bytes = m.used_bytes + e.bytes / 20;
    modules.push_back(std::move(m));
  }
  return modules;
}

class Mission {
 public:
  Mission() {
    scene_ = MakeStreetScene(11, 160.0f);
    lidar_.beams = 16;
    lidar_.azimuth_steps = 900;
    lidar_.min_elevation_deg = -15.0f;
    lidar_.max_elevation_deg = 15.0f;
    lidar_.max_range_m = 80.0f;
    robots_.push_back(MakeRobot(0, -40.0f, -1.5f));
    robots_.push_back(MakeRobot(1, -30.0f, -1.2f));
  }

  SampleBank Run() {
    while (server_.link().rounds_merged() == 0 || server_.now_us() < merged_us_ + 3000000) {
      if (server_.now_us() - kInboxStartUs > kMissionLimitUs) {
        std::fprintf(stderr, "cm_fuzz_seeds: warning: the mission did not merge within %lld s (state: %s); seeds "
                     "are written anyway\n", static_cast<long long>(kMissionLimitUs / 1000000),
                     server_.link().state().c_str());
        break;
      }
      Step();
    }
    std::fprintf(stderr, "cm_fuzz_seeds: mission: %s after %.1f s; %llu messages accepted, %llu refused; %zu-byte "
                 "inbox stream\n", server_.link().state().c_str(),
                 static_cast<double>(server_.now_us() - kInboxStartUs) * 1e-6,
                 static_cast<unsigned long long>(server_.accepted()),
                 static_cast<unsigned long long>(server_.rejected()), bank_.stream.size());
    if (const ExchangeCascadeResult* c = server_.server().cascade(0, 1)) {
      std::fprintf(stderr, "cm_fuzz_seeds: cascade of robots 0 and 1: %s%s%s; %zu loops in stage A, %zu in L_K\n",
                   CascadeOutcomeName(c->outcome), c->no_candidate_reason.empty() ? "" : ": ",
                   c->no_candidate_reason.c_str(), c->stage_a.cells.size(), c->stage_c.selected_loops.size());
    }
    for (const MergeResultMessage& m : bank_.results) {
      for (const MergePairOutcome& p : m.pairs) {
        const Eigen::Vector3d t = p.T_alpha_beta.translation();
        std::fprintf(stderr, "cm_fuzz_seeds: merge round %d, robots %d-%d: %s, t = (%.2f, %.2f, %.2f) m, %u + %u "
                     "scans\n", m.round, p.alpha, p.beta, p.verdict.c_str(), t.x(), t.y(), t.z(), p.alpha_scans,
                     p.beta_scans);
      }
    }
    return std::move(bank_);
  }

 private:
  // One 10 ms step: scans every 100 ms, then everything the robots want to send, then a clock tick.
  void Step() {
    const std::int64_t t = server_.now_us() - kInboxStartUs;
    if (t % 100000 == 0) {
      for (MissionRobot& r : robots_) FeedScan(&r);
    }
    if (t == 7000000) {
      // A robot that lost a pose update sends the current poses again (RobotLink does this on a missing ack):
      // pose updates from the robots' own state.
      std::vector<std::uint32_t> keyframes;
      for (std::uint32_t k = 5; k < 25; ++k) keyframes.push_back(k);
      robots_[0].agent->RequeuePoses(Span<const std::uint32_t>(keyframes));
      robots_[1].agent->RequeuePoses(Span<const std::uint32_t>(keyframes.data(), 8));
    }
    for (MissionRobot& r : robots_) {
      RobotOutgoing m;
      while (Check(r.link->Next(server_.now_us(), &m), "RobotLink::Next")) Send(&r, m);
    }
    Record(InboxChannel::kTick, {});
    if (t % 1000000 == 0) TakeHealthSamples();
  }

  void FeedScan(MissionRobot* r) {
    if (r->scans_fed == kMissionScans) {
      if (!r->finished) Check(r->agent->Finish(), "RobotAgent::Finish");
      r->finished = true;
      return;
    }
    const int k = r->scans_fed++;
    const float x = r->start_x_m + 1.1f * static_cast<float>(k);
    CastScan(scene_, lidar_, x, r->lane_y_m, 1.73f, 0.0f, 1000u * static_cast<std::uint32_t>(r->id + 1) +
             static_cast<std::uint32_t>(k), &raw_);
    Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();  // odometry in the robot's own start frame
    T_odom_sensor.translation() = Eigen::Vector3d(1.1 * k, 0.0, 0.0);
    (void)Check(r->agent->AddScan(Span<const PointXYZI>(raw_), T_odom_sensor), "RobotAgent::AddScan");
  }

  void Send(MissionRobot* r, const RobotOutgoing& m) {
    std::vector<std::uint8_t> bytes;
    InboxChannel channel = InboxChannel::kKeyframes;
    switch (m.kind) {
      case RobotOutgoing::Kind::kKeyframeBatch:
        Check(platform::EncodeKeyframeBatch(m.batch, &bytes), "keyframe batch");
        bank_.batches.push_back(m.batch);
        break;
      case RobotOutgoing::Kind::kPoseUpdate:
        Check(platform::EncodePoseUpdate(m.poses, &bytes), "pose update");
        bank_.pose_updates.push_back(m.poses);
        channel = InboxChannel::kPoses;
        break;
      case RobotOutgoing::Kind::kScanChunk:
        Check(platform::EncodeScanChunk(m.chunk, &bytes), "scan chunk");
        bank_.chunks.push_back(m.chunk);
        channel = InboxChannel::kScans;
        break;
    }
    r->bytes_sent += static_cast<std::int64_t>(bytes.size());
    Record(channel, bytes);
  }

  // Appends one record to the stream, feeds it to the server, and hands what it publishes to the robots.
  void Record(InboxChannel channel, const std::vector<std::uint8_t>& payload) {
    const std::size_t at = bank_.stream.size();
    AppendInboxRecord(channel, Span<const std::uint8_t>(payload), &bank_.stream);
    Span<const std::uint8_t> rest(bank_.stream.data() + at, bank_.stream.size() - at);
    InboxRecord record;
    if (!TakeInboxRecord(&rest, &record)) Fail("seed mission: a record does not parse back");
    std::vector<std::uint8_t>& first = bank_.first_record[static_cast<int>(channel)];
    if (first.empty()) first.assign(bank_.stream.begin() + static_cast<std::ptrdiff_t>(at), bank_.stream.end());
    server_.Feed(record);
    for (const ServerOutgoing& o : server_.published()) {
      switch (o.kind) {
        case ServerOutgoing::Kind::kTransferStatus:
          bank_.statuses.push_back(o.status);
          if (MissionRobot* r = Robot(o.status.robot_id)) (void)r->link->OnTransferStatus(o.status, server_.now_us());
          break;
        case ServerOutgoing::Kind::kScanRequest:
          bank_.requests.push_back(o.request);
          if (bank_.stream_before_chunks == 0) bank_.stream_before_chunks = bank_.stream.size();
          if (MissionRobot* r = Robot(o.request.robot_id)) (void)r->link->OnScanRequest(o.request, server_.now_us());
          break;
        case ServerOutgoing::Kind::kMergeResult:
          bank_.results.push_back(o.result);
          merged_us_ = server_.now_us();
          break;
        case ServerOutgoing::Kind::kRoundStep: bank_.round_steps.push_back(o.step); break;
      }
    }
  }

  MissionRobot* Robot(int id) {
    for (MissionRobot& r : robots_) {
      if (r.id == id) return &r;
    }
    return nullptr;
  }

  // The robots' and the server's health messages, as the daemons fill them (plus their budget modules).
  void TakeHealthSamples() {
    const std::int64_t t = server_.now_us() - kInboxStartUs;
    for (const MissionRobot& r : robots_) {
      RobotStatus s;
      s.utime_us = server_.now_us();
      s.robot_id = r.id;
      s.session = r.session;
      s.peak_rss_bytes = (180ll << 20) + t;
      s.modules = Modules(AppKind::kRobot, 200 + t / 100000);
      for (const ModuleMemory& m : s.modules) s.budget_total_bytes += m.budget_bytes;
      s.budget_limit_bytes = 384ll << 20;
      s.keyframes = static_cast<std::uint32_t>(r.agent->mapper().num_keyframes());
      s.keyframes_acked = r.link->stats().keyframes_acked;
      s.queued_keyframes = static_cast<std::uint32_t>(r.agent->unsent_keyframes() + r.agent->queued_resends());
      s.queued_poses = static_cast<std::uint32_t>(r.agent->queued_poses());
      s.queued_chunks = static_cast<std::uint32_t>(r.link->queued_chunks());
      s.bytes_sent = r.bytes_sent;
      s.request_id = r.link->active_request();
      s.state = server_.link().rounds_merged() > 0 ? "merged" : !r.finished ? "mapping"
                : r.link->queued_chunks() > 0 ? "sending scans" : "waiting";
      bank_.robot_statuses.push_back(std::move(s));
    }
    ServerStatus s = server_.MakeServerStatus();
    s.peak_rss_bytes = (240ll << 20) + t;
    s.modules = Modules(AppKind::kServer, 100 + t / 200000);
    for (const ModuleMemory& m : s.modules) s.budget_total_bytes += m.budget_bytes;
    s.budget_limit_bytes = 512ll << 20;
    bank_.server_statuses.push_back(std::move(s));
  }

  InboxServer server_;
  std::vector<MissionRobot> robots_;
  BoxScene scene_;
  SpinningLidar lidar_;
  std::vector<PointXYZI> raw_;
  std::int64_t merged_us_ = 0;
  SampleBank bank_;
};

// ---- the largest and smallest legal messages ----

Eigen::Isometry3d SomePose(std::size_t i) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.001 * static_cast<double>(i % 6283), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.9 * static_cast<double>(i), 0.1 * static_cast<double>(i % 50), 0.02);
  return T;
}

std::string Text(const char* stem, std::size_t bytes) {
  std::string s;
  while (s.size() < bytes) s += stem;
  s.resize(bytes);
  return s;
}

// The keyframes of one batch of either record kind the robots send for SOLiD (a compact batch, 92-byte records).
std::vector<CompactKeyframe> BatchKeyframes(const KeyframeBatch& b) {
  auto keyframes = test::BatchKeyframes(b);
  if (!keyframes.ok()) Fail("seed: a mission batch does not decode: %s", keyframes.status().ToString().c_str());
  return *keyframes;
}

// Appends `k` to `m` as a 92-byte record and its point count.
void AppendUnit40Record(const CompactKeyframe& k, KeyframeBatch* m) {
  KeyframeRecord record;
  record.keyframe_index = k.pose.keyframe_index;
  record.T_map_sensor = k.pose.T_map_sensor;
  record.descriptor = k.descriptor;
  record.descriptor_valid = true;
  const std::size_t at = m->records.size();
  m->records.resize(at + kKeyframeRecordBytes);
  Check(EncodeKeyframeRecord(record, Span<std::uint8_t>(m->records.data() + at, kKeyframeRecordBytes)), "record");
  m->stored_points.push_back(k.stored_points);
}

// The mission's keyframes, every batch's.
std::vector<CompactKeyframe> MissionKeyframes(const SampleBank& bank) {
  std::vector<CompactKeyframe> out;
  for (const KeyframeBatch& b : bank.batches) {
    const std::vector<CompactKeyframe> keyframes = BatchKeyframes(b);
    out.insert(out.end(), keyframes.begin(), keyframes.end());
  }
  return out;
}

// kMaxRecordsPerBatch 92-byte records of the mission's keyframes, renumbered 0, 1, ...
KeyframeBatch LargestBatch(const SampleBank& bank) {
  KeyframeBatch m = bank.batches.empty() ? KeyframeBatch{} : bank.batches.front();
  m.record_kind = KeyframeRecordKind::kUnit40;
  m.records.clear();
  m.stored_points.clear();
  const std::vector<CompactKeyframe> keyframes = MissionKeyframes(bank);
  if (keyframes.empty()) return m;
  for (std::size_t k = 0; k < kMaxRecordsPerBatch; ++k) {
    CompactKeyframe from = keyframes[k % keyframes.size()];
    from.pose.keyframe_index = static_cast<std::uint32_t>(k);
    from.stored_points = 400 + static_cast<std::uint32_t>(k % 300);
    AppendUnit40Record(from, &m);
  }
  return m;
}

// The longest compact batch: kMaxRecordsPerBatch keyframes at 14 bits, every other index skipped, poses far apart,
// descriptors unrelated and point counts jumping between 0 and 2^31 - 1, so that no prediction helps.
KeyframeBatch LargestCompactBatch(const SampleBank& bank) {
  KeyframeBatch m = bank.batches.empty() ? KeyframeBatch{} : bank.batches.front();
  m.record_kind = KeyframeRecordKind::kCompact40;
  m.stored_points.clear();
  m.num_compact_records = kMaxRecordsPerBatch;
  std::vector<CompactKeyframe> keyframes(kMaxRecordsPerBatch);
  std::uint32_t x = 12345;
  const auto next = [&x] { return (x = x * 1664525u + 1013904223u) >> 8; };
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    keyframes[k].pose.keyframe_index = static_cast<std::uint32_t>(2 * k);
    Eigen::Isometry3d T = SomePose(k);
    T.translation() = Eigen::Vector3d(static_cast<double>(next() % 2000000) - 1e6,
                                      static_cast<double>(next() % 2000000) - 1e6, static_cast<double>(next() % 2000));
    keyframes[k].pose.T_map_sensor = T;
    double norm2 = 0.0;
    for (float& v : keyframes[k].descriptor) {
      v = static_cast<float>(next() % 1000) + 1.0f;
      norm2 += static_cast<double>(v) * static_cast<double>(v);
    }
    for (float& v : keyframes[k].descriptor) v = static_cast<float>(static_cast<double>(v) / std::sqrt(norm2));
    keyframes[k].stored_points = k % 2 == 0 ? 0u : kCompactMaxStoredPoints;
  }
  Check(EncodeCompactBatch(Span<const CompactKeyframe>(keyframes), kCompactMaxDescriptorBits, &m.records),
        "compact batch");
  if (m.records.size() > kMaxCompactBatchBytes) Fail("seed: the longest compact batch exceeds kMaxCompactBatchBytes");
  return m;
}

// kMaxRecordsPerBatch Scan Context records (1226 B each, 627 KB: the largest legal keyframe_batch_t): grids of
// heights in a third of the cells, a different pattern per keyframe.
KeyframeBatch LargestScanContextBatch(const SampleBank& bank) {
  KeyframeBatch m = bank.batches.empty() ? KeyframeBatch{} : bank.batches.front();
  m.records.clear();
  m.stored_points.clear();
  m.record_kind = KeyframeRecordKind::kScanContext;
  const std::size_t bytes = KeyframeRecordBytesOf(m.record_kind);
  std::vector<float> grid(KeyframeRecordDimOf(m.record_kind));
  for (std::size_t k = 0; k < kMaxRecordsPerBatch; ++k) {
    for (std::size_t c = 0; c < grid.size(); ++c) {
      grid[c] = (c * 7 + k) % 3 == 0 ? 0.5f + static_cast<float>((c * 13 + k * 5) % 40) * 0.1f : 0.0f;
    }
    const std::size_t at = m.records.size();
    m.records.resize(at + bytes);
    Check(EncodeRecordOfKind(m.record_kind, KeyframePose{static_cast<std::uint32_t>(k), SomePose(k)},
                             Span<const float>(grid), Span<std::uint8_t>(m.records.data() + at, bytes)),
          "Scan Context record");
    m.stored_points.push_back(400 + static_cast<std::uint32_t>(k % 300));
  }
  return m;
}

PoseUpdate LargestPoseUpdate() {
  PoseUpdate m;
  m.utime_us = kInboxStartUs;
  m.robot_id = 1;
  m.session = kInboxStartUs - 1;
  m.sequence = 77;
  for (std::size_t i = 0; i < kMaxPosesPerUpdate; ++i) {
    m.keyframes.push_back(static_cast<std::uint32_t>(i));
    m.T_map_sensor.push_back(SomePose(i));
    m.no_descriptor.push_back(i % 97 == 0 ? 1 : 0);  // keyframes whose descriptor was invalid
  }
  return m;
}

ScanRequest LargestRequest() {
  ScanRequest m;
  m.utime_us = kInboxStartUs;
  m.robot_id = kMaxRobotId;
  m.server_session = kInboxServerSession;
  m.request_id = 12;
  for (std::size_t k = 0; k < kMaxKeyframesPerRequest; ++k) m.keyframes.push_back(static_cast<std::uint32_t>(2 * k));
  return m;
}

ScanChunk LargestChunk(const SampleBank& bank) {
  ScanChunk m = bank.chunks.empty() ? ScanChunk{} : bank.chunks.front();
  m.num_chunks = static_cast<std::uint16_t>(kMaxChunksPerScan);  // the largest scan: 39.3 MB in 32767 chunks
  m.chunk_index = m.num_chunks - 1;
  m.total_bytes = static_cast<std::uint32_t>(kMaxChunksPerScan * kMaxScanChunkPayloadBytes);
  m.payload.assign(kMaxScanChunkPayloadBytes, 0);
  for (std::size_t i = 0; i < m.payload.size(); ++i) m.payload[i] = static_cast<std::uint8_t>(i * 37 + 11);
  return m;
}

TransferStatus LargestStatus() {
  TransferStatus m;
  m.utime_us = kInboxStartUs;
  m.robot_id = 2;
  m.server_session = kInboxServerSession;
  m.robot_session = kInboxStartUs - 2;
  m.keyframes_contiguous = 100;
  for (std::uint32_t i = 0; i < kMaxStatusGaps; ++i) m.gaps.push_back(KeyframeGap{100 + 10 * i, 105 + 10 * i});
  m.keyframes_seen = 100 + 10 * static_cast<std::uint32_t>(kMaxStatusGaps);
  m.gaps_truncated = true;
  for (std::size_t i = 0; i < kMaxStatusPoseAcks; ++i) m.pose_sequences.push_back(static_cast<std::int32_t>(500 + i));
  m.request_id = 3;
  for (std::uint32_t i = 0; i < kMaxStatusMissingRanges; ++i) {
    m.missing.push_back(MissingChunkRange{i / 2, static_cast<std::uint16_t>(i % 2 ? 40 : 0), 20});
  }
  return m;
}

MergeResultMessage LargestResult() {
  MergeResultMessage m;
  m.utime_us = kInboxStartUs;
  m.server_session = kInboxServerSession;
  m.round = 9;
  for (int r = 0; r < static_cast<int>(kMaxMergeRobots); ++r) {
    m.robot_ids.push_back(r);
    m.in_world.push_back(r % 3 ? 1 : 0);
    m.T_world_map.push_back(SomePose(static_cast<std::size_t>(r) * 31));
    m.keyframes.push_back(20000 - static_cast<std::uint32_t>(r));
  }
  for (int a = 0; a < static_cast<int>(kMaxMergeRobots); ++a) {
    for (int b = a + 1; b < static_cast<int>(kMaxMergeRobots); ++b) {
      MergePairOutcome p;
      p.alpha = a;
      p.beta = b;
      p.success = (a + b) % 2 == 0;
      p.verdict = Text(p.success ? "success " : "fine-stage overlap below the gate ", kMaxStatusTextBytes);
      p.T_alpha_beta = SomePose(static_cast<std::size_t>(a * 64 + b));
      p.loops_stage_a = 40;
      p.loops_stage_c = 12;
      p.alpha_scans = 9;
      p.beta_scans = 8;
      p.overlap = 0.42f;
      p.inliers = 1234;
      p.consistent = p.success;
      p.stage_b = {static_cast<std::uint8_t>((a + b) % 4), 0.125f, 2147483647u, 2147483647u};
      p.stage_c = {2, 1.0f, 2147483647u, 77};
      p.stage_c_loops_dropped = 2147483647u;
      m.pairs.push_back(std::move(p));
    }
  }
  return m;
}

template <typename Status_>
void FillLargestHealth(Status_* s) {
  s->utime_us = kInboxStartUs;
  s->session = kInboxStartUs - 5;
  s->peak_rss_bytes = 400ll << 20;
  s->budget_total_bytes = 380ll << 20;
  s->budget_limit_bytes = 384ll << 20;
  for (std::size_t i = 0; i < kMaxStatusModules; ++i) {
    ModuleMemory mm;
    mm.name = Text(("module_" + std::to_string(i) + "_").c_str(), kMaxStatusTextBytes);
    mm.budget_bytes = 1ll << 30;
    mm.used_bytes = 1ll << 29;
    mm.high_water_bytes = 3ll << 28;
    s->modules.push_back(std::move(mm));
  }
  s->state = Text("sending scans ", kMaxStatusTextBytes);
}

RobotStatus LargestRobotStatus() {
  RobotStatus s;
  FillLargestHealth(&s);
  s.robot_id = kMaxRobotId;
  s.keyframes = 2147483647u;
  s.keyframes_acked = 2147483000u;
  s.queued_chunks = 32767;
  s.bytes_sent = 1ll << 40;
  s.request_id = 2147483647;
  return s;
}

ServerStatus LargestServerStatus() {
  ServerStatus s;
  FillLargestHealth(&s);
  s.round = 2147483647;
  s.bytes_received = 1ll << 40;
  s.messages_rejected = 1ll << 33;
  s.last_rejection = Text("COMMERGE_SCANS: scan_chunk_t: truncated ", kMaxStatusTextBytes);
  for (int r = 0; r < static_cast<int>(kMaxMergeRobots); ++r) {
    s.robot_ids.push_back(r);
    s.keyframes.push_back(20000);
    s.scans.push_back(static_cast<std::uint32_t>(r));
    s.chunks_missing.push_back(static_cast<std::uint32_t>(r * 3));
    s.descriptor_ids.push_back(0xFFFFFFFFu - static_cast<std::uint32_t>(r));
  }
  for (int a = 0; a < static_cast<int>(kMaxMergeRobots); ++a) {
    for (int b = a + 1; b < static_cast<int>(kMaxMergeRobots); ++b) {
      s.pairs.push_back({a, b, Text("B limit, gap 12.50 %, 20000 nodes, 31 LPs; C optimal ", kMaxStatusTextBytes)});
    }
  }
  return s;
}

// ---- samples per codec (the table rows) ----

template <typename T>
std::vector<T> Spread(const std::vector<T>& all, std::size_t n) {
  if (all.size() <= n) return all;
  std::vector<T> out;
  for (std::size_t i = 0; i < n; ++i) out.push_back(all[i * (all.size() - 1) / (n - 1)]);
  return out;
}
template <typename T>
std::vector<T> Plus(std::vector<T> v, std::initializer_list<T> more) {
  v.insert(v.end(), more);
  return v;
}

template <typename T>
struct Tag {};

// Per codec: the corpus seeds (recorded messages spread over the mission, and the smallest message), and the
// largest legal message, which the CTest test runs once on its own (a corpus of ~0.5 MB inputs would make
// every mutation slow).
template <typename T>
struct Samples {
  bool known = true;
  std::vector<T> seeds;
  std::vector<T> largest;
};

// A row this file does not know yet: its default message (valid for the encoders that accept defaults).
template <typename T>
Samples<T> SamplesOf(const SampleBank&, Tag<T>) {
  return {false, {T{}}, {}};
}
// A robot that sees a new server session announces every keyframe again, kMaxRecordsPerBatch at a time: one
// batch of all of robot 1's recorded keyframes, of the record kind of its first batch.
KeyframeBatch Reannouncement(const SampleBank& bank) {
  KeyframeBatch m;
  std::vector<CompactKeyframe> keyframes;
  bool first = true;
  for (const KeyframeBatch& b : bank.batches) {
    if (b.robot_id != 1 || (!first && b.record_kind != m.record_kind) ||
        keyframes.size() + b.num_records() > kMaxRecordsPerBatch) {
      continue;
    }
    if (first) m = b;
    first = false;
    m.sequence = b.sequence + 1;
    m.utime_us = b.utime_us;
    for (const CompactKeyframe& k : BatchKeyframes(b)) {  // once each, ascending (a resent batch repeats them)
      if (keyframes.empty() || k.pose.keyframe_index > keyframes.back().pose.keyframe_index) keyframes.push_back(k);
    }
  }
  if (keyframes.empty()) return m;
  const int bits = m.record_kind == KeyframeRecordKind::kCompact40 ? m.records.front() : 0;
  m.records.clear();
  m.stored_points.clear();
  if (m.record_kind == KeyframeRecordKind::kCompact40) {
    Check(EncodeCompactBatch(Span<const CompactKeyframe>(keyframes), bits, &m.records), "re-announcement");
    m.num_compact_records = keyframes.size();
    return m;
  }
  for (const CompactKeyframe& k : keyframes) AppendUnit40Record(k, &m);
  return m;
}

// The statuses with the most missing chunk ranges, gaps and pose acknowledgements, beside the spread.
std::vector<TransferStatus> InterestingStatuses(const SampleBank& bank) {
  std::vector<TransferStatus> out = Spread(bank.statuses, kSeedsPerKind);
  const TransferStatus* most[3] = {nullptr, nullptr, nullptr};
  for (const TransferStatus& s : bank.statuses) {
    if (!most[0] || s.missing.size() > most[0]->missing.size()) most[0] = &s;
    if (!most[1] || s.gaps.size() > most[1]->gaps.size()) most[1] = &s;
    if (!most[2] || s.pose_sequences.size() > most[2]->pose_sequences.size()) most[2] = &s;
  }
  for (const TransferStatus* s : most) {
    if (s != nullptr) out.push_back(*s);
  }
  return out;
}

Samples<KeyframeBatch> SamplesOf(const SampleBank& b, Tag<KeyframeBatch>) {
  KeyframeBatch smallest;
  smallest.robot_id = 1;
  smallest.session = kInboxStartUs - 1;
  return {true, Plus(Spread(b.batches, kSeedsPerKind), {Reannouncement(b), smallest}),
          {LargestBatch(b), LargestScanContextBatch(b), LargestCompactBatch(b)}};
}
Samples<PoseUpdate> SamplesOf(const SampleBank& b, Tag<PoseUpdate>) {
  return {true, Plus(Spread(b.pose_updates, kSeedsPerKind), {PoseUpdate{}}), {LargestPoseUpdate()}};
}
Samples<ScanRequest> SamplesOf(const SampleBank& b, Tag<ScanRequest>) {
  return {true, Plus(Spread(b.requests, kSeedsPerKind), {ScanRequest{}}), {LargestRequest()}};
}
Samples<ScanChunk> SamplesOf(const SampleBank& b, Tag<ScanChunk>) {
  return {true, Plus(Spread(b.chunks, kSeedsPerKind), {ScanChunk{}}), {LargestChunk(b)}};
}
Samples<TransferStatus> SamplesOf(const SampleBank& b, Tag<TransferStatus>) {
  return {true, Plus(InterestingStatuses(b), {TransferStatus{}}), {LargestStatus()}};
}
Samples<MergeResultMessage> SamplesOf(const SampleBank& b, Tag<MergeResultMessage>) {
  return {true, Plus(Spread(b.results, kSeedsPerKind), {MergeResultMessage{}}), {LargestResult()}};
}
// The largest legal round step: 64 robots, 64 requests of 16 384 keyframes (2^20 in all).
RoundStep LargestRoundStep() {
  RoundStep m;
  m.round = 2147483647;
  m.step = 32767;
  for (int r = 0; r <= kMaxRobotId; ++r) {
    RoundRobotInput in;
    in.robot_id = r;
    in.session = kInboxStartUs + r;
    in.keyframe_batches = in.pose_updates = in.scan_chunks = 2147483647u;
    in.digest = 0xffffffffu;
    m.robots.push_back(in);
  }
  for (std::size_t q = 0; q < kMaxRoundRequests; ++q) {
    ScanRequest req;
    req.robot_id = static_cast<int>(q);
    req.request_id = static_cast<std::int32_t>(q);
    for (std::uint32_t k = 0; k < kMaxRoundKeyframes / kMaxRoundRequests; ++k) req.keyframes.push_back(3 * k);
    m.requests.push_back(std::move(req));
  }
  return m;
}
Samples<RoundStep> SamplesOf(const SampleBank& b, Tag<RoundStep>) {
  return {true, Plus(Spread(b.round_steps, kSeedsPerKind), {RoundStep{}}), {LargestRoundStep()}};
}
Samples<RobotStatus> SamplesOf(const SampleBank& b, Tag<RobotStatus>) {
  return {true, Plus(Spread(b.robot_statuses, kSeedsPerKind), {RobotStatus{}}), {LargestRobotStatus()}};
}
Samples<ServerStatus> SamplesOf(const SampleBank& b, Tag<ServerStatus>) {
  return {true, Plus(Spread(b.server_statuses, kSeedsPerKind), {ServerStatus{}}), {LargestServerStatus()}};
}
// The live input (odometry stack -> robot): a ring scan, the largest legal scan
// (MAX_POINTS points, 4.2 MB), and odometry on a circle.
Samples<LidarScan> SamplesOf(const SampleBank&, Tag<LidarScan>) {
  LidarScan ring;
  ring.utime_us = kInboxStartUs;
  ring.frame = "velodyne";
  for (int i = 0; i < 720; ++i) {
    const float a = static_cast<float>(i) * 0.00872665f;
    const float r = 8.0f + static_cast<float>(i % 7);
    ring.points.push_back({r * std::cos(a), r * std::sin(a), -1.2f + 0.001f * static_cast<float>(i), 0.3f});
  }
  LidarScan largest;
  largest.frame = std::string(kMaxStatusTextBytes, 'f');
  largest.points.assign(kMaxLidarScanPoints, PointXYZI{1.0f, -2.0f, 0.5f, 7.0f});
  return {true, {ring, LidarScan{}}, {largest}};
}
Samples<OdometrySample> SamplesOf(const SampleBank&, Tag<OdometrySample>) {
  std::vector<OdometrySample> seeds;
  for (int i = 0; i < 4; ++i) {
    OdometrySample m;
    m.utime_us = kInboxStartUs + 50000 * i;
    m.odom_frame = "odom";
    m.sensor_frame = "velodyne";
    const double yaw = 0.2 * i;
    m.T_odom_sensor.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    m.T_odom_sensor.translation() = Eigen::Vector3d(10.0 * std::sin(yaw), 10.0 * (1.0 - std::cos(yaw)), 0.1);
    seeds.push_back(m);
  }
  OdometrySample largest = seeds.front();
  largest.odom_frame = std::string(kMaxStatusTextBytes, 'o');
  largest.sensor_frame = std::string(kMaxStatusTextBytes, 's');
  return {true, seeds, {largest}};
}

// ---- writing ----

void WriteFile(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() || std::fclose(f) != 0) {
    Fail("cannot write %s", path.c_str());
  }
}

std::filesystem::path FreshDir(const std::filesystem::path& root, const char* name) {
  const std::filesystem::path dir = root / name;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir, ec);
  if (ec) Fail("cannot create %s: %s", dir.c_str(), ec.message().c_str());
  return dir;
}

// Encodes `messages` into dir/seed-NNN (each must encode and decode again); returns the largest size.
template <typename Message, typename Encoder, typename Decoder>
std::size_t WriteMessages(const std::filesystem::path& dir, const char* name, const std::vector<Message>& messages,
                          bool known, Encoder encode, Decoder decode, std::size_t* written) {
  std::size_t largest = 0;
  for (const Message& m : messages) {
    std::vector<std::uint8_t> bytes;
    if (Status st = encode(m, &bytes); !st.ok()) {
      if (known) Fail("seed %s #%zu: the encoder refuses it: %s", name, *written, st.ToString().c_str());
      std::fprintf(stderr, "cm_fuzz_seeds: %s: no seed (its default message does not encode: %s)\n", name,
                   st.message().c_str());
      continue;
    }
    if (auto back = decode(Span<const std::uint8_t>(bytes)); !back.ok()) {
      Fail("seed %s #%zu: the decoder refuses its encoding: %s", name, *written, back.status().ToString().c_str());
    }
    char file[32];
    std::snprintf(file, sizeof(file), "seed-%03zu", (*written)++);
    WriteFile(dir / file, bytes);
    largest = std::max(largest, bytes.size());
  }
  return largest;
}

template <typename Message, typename Encoder, typename Decoder>
void WriteCodecSeeds(const std::filesystem::path& root, const char* name, const SampleBank& bank, Encoder encode,
                     Decoder decode) {
  const Samples<Message> samples = SamplesOf(bank, Tag<Message>{});
  std::size_t seeds = 0, largest = 0;
  const std::size_t seed_bytes =
      WriteMessages(FreshDir(root, name), name, samples.seeds, samples.known, encode, decode, &seeds);
  const std::size_t largest_bytes = WriteMessages(FreshDir(root / "largest", name), name, samples.largest,
                                                  samples.known, encode, decode, &largest);
  std::fprintf(stderr, "cm_fuzz_seeds: %-16s %zu seeds (at most %zu bytes); largest legal message %zu bytes%s\n",
               name, seeds, seed_bytes, largest_bytes,
               samples.known ? "" : " (default message only: add its samples to tests/fuzz/seed_corpus.cpp)");
}

void WriteInboxSeeds(const std::filesystem::path& root, const SampleBank& bank) {
  const std::filesystem::path dir = FreshDir(root, "server_inbox");
  WriteFile(dir / "mission", bank.stream);
  if (bank.stream_before_chunks > 0) {
    WriteFile(dir / "mission-until-policy",
              std::vector<std::uint8_t>(bank.stream.begin(),
                                        bank.stream.begin() + static_cast<std::ptrdiff_t>(bank.stream_before_chunks)));
  }
  const char* names[kInboxChannels] = {"keyframes", "poses", "scans", "tick"};
  for (int c = 0; c < kInboxChannels; ++c) {
    if (!bank.first_record[c].empty()) WriteFile(dir / (std::string("one-") + names[c]), bank.first_record[c]);
  }
  // The largest legal allocation of the server: up to the first exchange policy, then the first chunk of the
  // largest legal scan (kMaxChunksPerScan chunks of 1200 bytes: 39.3 MB, allocated whole) for three of the
  // requested keyframes. Two fit the fuzzed server's 96 MB scan budget, the third is refused and counted.
  std::vector<std::uint8_t> largest(bank.stream.begin(),
                                    bank.stream.begin() + static_cast<std::ptrdiff_t>(bank.stream_before_chunks));
  const ScanRequest& request = bank.requests.front();
  for (std::size_t i = 0; i < 3 && i < request.keyframes.size(); ++i) {
    ScanChunk chunk;
    chunk.utime_us = kInboxStartUs;
    chunk.robot_id = request.robot_id;
    chunk.request_id = request.request_id;
    chunk.keyframe = request.keyframes[i];
    chunk.num_chunks = static_cast<std::uint16_t>(kMaxChunksPerScan);
    chunk.total_bytes = static_cast<std::uint32_t>(kMaxChunksPerScan * kMaxScanChunkPayloadBytes);
    chunk.payload.assign(kMaxScanChunkPayloadBytes, static_cast<std::uint8_t>(0x43 + i));
    std::vector<std::uint8_t> bytes;
    Check(platform::EncodeScanChunk(chunk, &bytes), "largest scan chunk");
    AppendInboxRecord(InboxChannel::kScans, Span<const std::uint8_t>(bytes), &largest);
    AppendInboxRecord(InboxChannel::kTick, {}, &largest);
  }
  WriteFile(FreshDir(root / "largest", "server_inbox") / "largest-scans", largest);
  std::fprintf(stderr, "cm_fuzz_seeds: %-16s mission stream %zu bytes (%zu up to the first exchange policy); "
               "largest legal scans %zu bytes\n", "server_inbox", bank.stream.size(), bank.stream_before_chunks,
               largest.size());
}

int Main(int argc, char** argv) {
  if (argc != 3 || std::strcmp(argv[1], "--write-seeds") != 0) {
    std::fprintf(stderr, "usage: %s --write-seeds DIR\n(the seed corpora of the commerge fuzz targets, see "
                         "tests/fuzz/seed_corpus.cpp)\n", argc > 0 ? argv[0] : "cm_fuzz_seeds");
    return 2;
  }
  const std::filesystem::path root = argv[2];
  const SampleBank bank = Mission().Run();
  if (bank.results.empty() || bank.chunks.empty() || bank.pose_updates.empty() || bank.requests.empty()) {
    Fail("the seed mission produced %zu merge results, %zu exchange policies, %zu scan chunks, %zu pose updates "
         "(all needed)", bank.results.size(), bank.requests.size(), bank.chunks.size(), bank.pose_updates.size());
  }
#define CM_FUZZ_WRITE_CODEC(name, MessageType, DecodeFn, EncodeFn, malloc_limit_mb) \
  WriteCodecSeeds<MessageType>(root, #name, bank, platform::EncodeFn, platform::DecodeFn);
  CM_FUZZ_CODECS(CM_FUZZ_WRITE_CODEC)
#undef CM_FUZZ_WRITE_CODEC
  WriteInboxSeeds(root, bank);
  return 0;
}

}  // namespace
}  // namespace commerge::fuzz

int main(int argc, char** argv) { return commerge::fuzz::Main(argc, argv); }
