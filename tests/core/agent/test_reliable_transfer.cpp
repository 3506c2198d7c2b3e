// SPDX-License-Identifier: BSD-3-Clause
// Reliable delivery between RobotLink and ServerLink over a simulated link that drops, duplicates, delays and
// reorders messages (seeded). The reference is the robots' own state: after the mission every keyframe's record
// at the server decodes to exactly what the robot's record encoder produces from its final descriptor, every
// requested scan at the server is byte-identical to the robot's stored encoded scan, and poses agree within the
// agent's pose-update thresholds. Also: no retransmission on a perfect link, restarts of either side, stale and
// foreign messages, and the token bucket's long-run rate.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/robot_link.hpp"
#include "core/agent/round_replay.hpp"
#include "core/agent/server_link.hpp"
#include "core/agent/delivery_digest.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"

using namespace commerge;

namespace {

constexpr std::int64_t kTickUs = 10000;  // 10 ms

struct Robot {
  std::unique_ptr<SolidDescriptor> solid;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotAgent> agent;
  std::unique_ptr<RobotLink> link;
  int scans_fed = 0;
  bool finished = false;
};

// How a test robot batches: 0 s (every keyframe at once, the timing the tests below were written for) or the
// daemon's delay, up to `records_per_batch` records a batch.
struct Batching {
  double delay_s = 0.0;
  std::size_t records_per_batch = 4;  // several batches per robot, so losses hit some and not others
};

std::unique_ptr<Robot> MakeRobot(int id, std::int64_t session, Batching batching = {}) {
  auto r = std::make_unique<Robot>();
  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneHdl64e));
  REQUIRE(solid.ok());
  r->solid = std::make_unique<SolidDescriptor>(std::move(*solid));
  ScanStoreParams sp;
  sp.capacity_bytes = 4u << 20;
  sp.max_scans = 256;
  auto store = ScanStore::Create(sp);
  REQUIRE(store.ok());
  r->store = std::move(*store);
  RobotMapperCapacity cap;
  cap.max_keyframes = 64;
  cap.max_points_per_raw_scan = 16 * 360;
  cap.max_points_per_stored_scan = 4096;
  RobotAgentParams params;
  params.max_records_per_batch = batching.records_per_batch;
  r->agent = std::make_unique<RobotAgent>(id, params, cap, r->solid.get(), r->store.get());
  RobotLinkParams link;
  link.batch_delay_s = batching.delay_s;
  r->link = std::make_unique<RobotLink>(session, link, r->agent.get());
  return r;
}

// A message in flight, of either direction.
struct Packet {
  std::int64_t deliver_us = 0;
  std::uint64_t order = 0;
  int to_robot = -1;  // -1: to the server
  RobotOutgoing up;
  ServerOutgoing down;
};

struct LinkModel {
  double loss = 0.0, duplicate = 0.0;
  std::int64_t delay_us = 20000, jitter_us = 0;  // jitter reorders
  /// Every message robot `mute_robot` sends before this time is lost.
  int mute_robot = -1;
  std::int64_t mute_until_us = 0;
};

std::size_t WireBytes(const RobotOutgoing& m) {  // close to the LCM sizes; only the bandwidth cap uses it
  switch (m.kind) {
    case RobotOutgoing::Kind::kKeyframeBatch: return 40 + m.batch.records.size() + 4 * m.batch.stored_points.size();
    case RobotOutgoing::Kind::kPoseUpdate: return 40 + 33 * m.poses.keyframes.size();
    case RobotOutgoing::Kind::kScanChunk: return 50 + m.chunk.payload.size();
  }
  return 0;
}

class Mission {
 public:
  Mission(int robots, int scans_per_robot, LinkModel link, std::uint32_t seed, ServerLinkParams server_params = {},
          Batching batching = {})
      : scans_(scans_per_robot), model_(link), rng_(seed), server_params_(server_params) {
    for (int i = 0; i < robots; ++i) robots_.push_back(MakeRobot(i, 1000 + i, batching));
    StartServer(500);
    scene_ = MakeStreetScene(5, 120.0f);
    lidar_.beams = 16;
    lidar_.azimuth_steps = 360;
    lidar_.max_range_m = 80.0f;
  }

  void StartServer(std::int64_t session) {
    MergeServerParams mp;
    mp.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
    mp.cascade.stage_a.tau_area = 4;  // short test missions
    merge_ = std::make_unique<MergeServer>(static_cast<int>(std::max<std::size_t>(2, robots_.size())), 64, mp);
    server_ = std::make_unique<ServerLink>(session, server_params_, merge_.get());
  }

  void RestartRobot(int id, std::int64_t session) {
    robots_[static_cast<std::size_t>(id)] = MakeRobot(id, session);
  }

  // Runs until `until_us`, feeding one scan per robot every 100 ms.
  void RunUntil(std::int64_t until_us) {
    for (; now_us_ < until_us; now_us_ += kTickUs) Tick();
  }

  void Tick() {
    if (now_us_ % 100000 == 0) {
      for (std::size_t i = 0; i < robots_.size(); ++i) {
        if (!Gone(i)) Feed(robots_[i].get(), ScansOf(i));
      }
    }
    // Deliver what is due (ordered by delivery time, then send order).
    std::sort(in_flight_.begin(), in_flight_.end(), [](const Packet& a, const Packet& b) {
      return a.deliver_us != b.deliver_us ? a.deliver_us < b.deliver_us : a.order < b.order;
    });
    while (!in_flight_.empty() && in_flight_.front().deliver_us <= now_us_) {
      Packet p = std::move(in_flight_.front());
      in_flight_.pop_front();
      Deliver(p);
    }
    std::vector<ServerOutgoing> out;
    REQUIRE(server_->Poll(now_us_, &out).ok());
    for (ServerOutgoing& o : out) {
      if (o.kind == ServerOutgoing::Kind::kMergeResult) ++merge_results_;
      if (o.kind == ServerOutgoing::Kind::kRoundStep) steps_.push_back({recorded_.size(), o.step});
      const int to = o.kind == ServerOutgoing::Kind::kTransferStatus ? o.status.robot_id
                     : o.kind == ServerOutgoing::Kind::kScanRequest ? o.request.robot_id
                                                                     : -2;  // broadcast: nobody consumes it here
      if (to >= 0 && o.kind == ServerOutgoing::Kind::kScanRequest && Gone(static_cast<std::size_t>(to))) {
        ++requests_to_gone_;
      }
      if (to >= 0) Send(to, RobotOutgoing{}, std::move(o));
    }
    for (std::size_t i = 0; i < robots_.size(); ++i) {
      if (Gone(i)) continue;
      Robot& r = *robots_[i];
      RobotOutgoing m;
      while (bucket_[i].CanSend(now_us_)) {
        auto more = r.link->Next(now_us_, &m);
        REQUIRE(more.ok());
        if (!*more) break;
        const std::size_t bytes = WireBytes(m);
        bucket_[i].Take(bytes);
        bytes_sent_ += bytes;
        if (m.resend) bytes_resent_ += bytes;
        Send(-1, m, ServerOutgoing{}, static_cast<int>(i));
      }
    }
  }

  // A robot that left: it neither sends nor receives any more (its process ended).
  void Leave(std::size_t robot) {
    if (gone_.size() < robots_.size()) gone_.resize(robots_.size(), 0);
    gone_[robot] = 1;
  }
  bool Gone(std::size_t robot) const { return robot < gone_.size() && gone_[robot] != 0; }
  int ScansOf(std::size_t robot) const {
    return robot < scans_per_robot_.size() ? scans_per_robot_[robot] : scans_;
  }

  void Feed(Robot* r, int scans) {
    if (r->scans_fed >= scans) {
      if (!r->finished) {
        REQUIRE(r->agent->Finish().ok());
        r->finished = true;
      }
      return;
    }
    const int k = r->scans_fed++;
    const float x = -30.0f + 1.1f * static_cast<float>(k);
    CastScan(scene_, lidar_, x, -1.5f, 1.73f, 0.0f, 100u + static_cast<std::uint32_t>(k), &raw_);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(1.1 * k, 0.0, 0.0);
    REQUIRE(r->agent->AddScan(Span<const PointXYZI>(raw_), T).ok());
  }

  void Send(int to_robot, RobotOutgoing up, ServerOutgoing down, int from_robot = -1) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (u(rng_) < model_.loss) return;
    if (from_robot >= 0 && from_robot == model_.mute_robot && now_us_ < model_.mute_until_us) return;
    const int copies = u(rng_) < model_.duplicate ? 2 : 1;
    for (int c = 0; c < copies; ++c) {
      Packet p;
      p.to_robot = to_robot;
      p.deliver_us = now_us_ + model_.delay_us +
                     (model_.jitter_us > 0 ? static_cast<std::int64_t>(u(rng_) * static_cast<double>(model_.jitter_us)) : 0);
      p.order = order_++;
      p.up = up;
      p.down = down;
      in_flight_.push_back(std::move(p));
    }
  }

  void Deliver(const Packet& p) {
    if (p.to_robot >= 0) {
      if (Gone(static_cast<std::size_t>(p.to_robot))) return;
      RobotLink& link = *robots_[static_cast<std::size_t>(p.to_robot)]->link;
      if (p.down.kind == ServerOutgoing::Kind::kTransferStatus) {
        CHECK(link.OnTransferStatus(p.down.status, now_us_).ok());
      } else {
        CHECK(link.OnScanRequest(p.down.request, now_us_).ok());
      }
      return;
    }
    recorded_.push_back({now_us_, p.up});  // what lcm-logger would record on the robot channels
    Status st;  // stale or duplicated messages may be refused: that is counted, not a failure
    switch (p.up.kind) {
      case RobotOutgoing::Kind::kKeyframeBatch: st = server_->OnKeyframeBatch(p.up.batch, now_us_); break;
      case RobotOutgoing::Kind::kPoseUpdate: st = server_->OnPoseUpdate(p.up.poses, now_us_); break;
      case RobotOutgoing::Kind::kScanChunk: st = server_->OnScanChunk(p.up.chunk, now_us_); break;
    }
    if (!st.ok()) ++refused_;
  }

  // Every keyframe of every robot is at the server exactly as the robot's record encoder makes it now (up to
  // the pose, checked separately), and poses are within the pose-update thresholds.
  void CheckAllKeyframesDelivered() {
    for (std::size_t i = 0; i < robots_.size(); ++i) {
      const RobotAgent& a = *robots_[i]->agent;
      const RobotKeyframeDb& db = merge_->robot(static_cast<int>(i));
      REQUIRE(db.size() == a.mapper().num_keyframes());
      for (std::size_t k = 0; k < db.size(); ++k) {
        CAPTURE(i);
        CAPTURE(k);
        REQUIRE(db.delivered(k));
        if (a.mapper().descriptor_valid(k)) {
          KeyframeRecord record;
          record.keyframe_index = static_cast<std::uint32_t>(k);
          record.T_map_sensor = a.mapper().pose(k);
          const Span<const float> d = a.mapper().descriptor(k);
          std::copy(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(kKeyframeDescriptorDim), record.descriptor.begin());
          record.descriptor_valid = true;
          std::vector<std::uint8_t> bytes(kKeyframeRecordBytes);
          REQUIRE(EncodeKeyframeRecord(record, Span<std::uint8_t>(bytes)).ok());
          auto expected = DecodeKeyframeRecord(Span<const std::uint8_t>(bytes));
          REQUIRE(expected.ok());
          for (std::size_t j = 0; j < kKeyframeDescriptorDim; ++j) {
            REQUIRE(db.descriptors[k * kKeyframeDescriptorDim + j] == expected->descriptor[j]);
          }
        }
        CHECK((db.T_map_sensor[k].translation() - a.mapper().pose(k).translation()).norm() <
              a.params().pose_update_min_translation_m + 0.01);
      }
      // The one-line digests the process-level fault tests compare agree, and would catch one changed or
      // missing descriptor.
      auto robot_digest = RobotDeliveryDigest(a.mapper());
      REQUIRE(robot_digest.ok());
      CHECK(ServerDeliveryDigest(db).ToText() == robot_digest->ToText());
      for (std::size_t k = 0; k < db.size(); ++k) {
        if (!db.valid[k]) continue;
        RobotKeyframeDb changed = db;
        changed.descriptors[k * kKeyframeDescriptorDim + 3] += 1e-6f;
        CHECK(ServerDeliveryDigest(changed).digest != robot_digest->digest);
        changed = db;
        changed.valid[k] = 0;
        CHECK(ServerDeliveryDigest(changed).descriptors + 1 == robot_digest->descriptors);
        break;
      }
    }
  }

  // Every scan the robots store is at the server, byte for byte.
  void CheckAllScansDelivered() {
    for (std::size_t i = 0; i < robots_.size(); ++i) {
      const RobotAgent& a = *robots_[i]->agent;
      std::vector<std::uint8_t> expected;
      for (std::size_t k = 0; k < a.mapper().num_keyframes(); ++k) {
        if (!a.store().CopyEncoded(static_cast<std::uint32_t>(k), &expected).ok()) continue;
        const std::vector<std::uint8_t>* got = merge_->scan_bytes(static_cast<int>(i), static_cast<std::uint32_t>(k));
        CAPTURE(i);
        CAPTURE(k);
        REQUIRE(got != nullptr);
        REQUIRE(*got == expected);
      }
    }
  }

  int scans_;
  std::vector<int> scans_per_robot_;  ///< per robot when set (else scans_)
  std::vector<char> gone_;
  int requests_to_gone_ = 0;  ///< scan requests the server sent to a robot after it left
  LinkModel model_;
  std::mt19937 rng_;
  ServerLinkParams server_params_;
  std::vector<std::unique_ptr<Robot>> robots_;
  std::vector<TokenBucket> bucket_{TokenBucket(250000.0, 16000.0), TokenBucket(250000.0, 16000.0),
                                   TokenBucket(250000.0, 16000.0)};
  std::unique_ptr<MergeServer> merge_;
  std::unique_ptr<ServerLink> server_;
  BoxScene scene_;
  SpinningLidar lidar_;
  std::vector<PointXYZI> raw_;
  std::deque<Packet> in_flight_;
  std::int64_t now_us_ = 0;
  std::uint64_t order_ = 0;
  std::uint64_t bytes_sent_ = 0, bytes_resent_ = 0;
  int merge_results_ = 0, refused_ = 0;
  std::vector<std::pair<std::int64_t, RobotOutgoing>> recorded_;  ///< robot -> server, as delivered
  /// The server's round steps, each after the first n messages of recorded_ (n = its first member).
  std::vector<std::pair<std::size_t, RoundStep>> steps_;
};

ServerLinkParams SendAllParams() {
  ServerLinkParams p;
  p.mode = ExchangeMode::kSendAll;  // every stored scan is requested: the transfer of all of them is checked
  p.round_quiet_s = 2.0;
  p.request_timeout_s = 600.0;
  return p;
}

}  // namespace

TEST_CASE("Reliable transfer: a perfect link delivers everything once, with no re-announcement or retransmission") {
  Mission m(2, 12, LinkModel{}, 1, SendAllParams());
  m.RunUntil(30000000);
  m.CheckAllKeyframesDelivered();
  m.CheckAllScansDelivered();
  CHECK(m.merge_results_ >= 1);
  CHECK(m.bytes_resent_ == 0);
  for (auto& r : m.robots_) {
    CHECK(r->link->stats().keyframes_requeued == 0);
    CHECK(r->link->stats().chunks_resent == 0);
    CHECK(r->link->stats().pose_updates_requeued == 0);
    CHECK(r->link->stats().requests_completed >= 1);
  }
  CHECK(m.merge_->stats().duplicate_chunks == 0);
  CHECK(m.refused_ == 0);
}

TEST_CASE("Reliable transfer: 10 and 50 percent loss with duplicates and reordering still deliver every keyframe and scan") {
  for (double loss : {0.1, 0.5}) {
    CAPTURE(loss);
    LinkModel link;
    link.loss = loss;
    link.duplicate = 0.1;
    link.jitter_us = 300000;  // up to 0.3 s extra: messages overtake each other
    Mission m(2, 12, link, 7, SendAllParams());
    m.RunUntil(120000000);
    m.CheckAllKeyframesDelivered();
    m.CheckAllScansDelivered();
    CHECK(m.merge_results_ >= 1);
    CHECK(m.bytes_resent_ > 0);
    std::uint64_t requeued = 0;
    for (auto& r : m.robots_) requeued += r->link->stats().keyframes_requeued + r->link->stats().chunks_resent;
    CHECK(requeued > 0);
  }
}

TEST_CASE("Reliable transfer: new keyframes wait up to batch_delay_s to share a batch, and all arrive under loss") {
  // A keyframe every 0.1 s, 16 records a batch: with 2 s of delay 12 keyframes go in one batch when the delay
  // since the first has passed; with none, one batch each.
  for (double loss : {0.0, 0.3}) {
    for (double delay : {0.0, 2.0}) {
      CAPTURE(loss);
      CAPTURE(delay);
      LinkModel link;
      link.loss = loss;
      Mission m(2, 12, link, 9, SendAllParams(), Batching{delay, 16});
      m.RunUntil(90000000);
      m.CheckAllKeyframesDelivered();
      CHECK(m.merge_results_ >= 1);
      if (loss > 0.0) continue;
      for (int robot = 0; robot < 2; ++robot) {
        CAPTURE(robot);
        std::vector<std::pair<std::int64_t, std::size_t>> batches;  // (delivered at, records)
        for (const auto& [t, up] : m.recorded_) {
          if (up.kind == RobotOutgoing::Kind::kKeyframeBatch && up.batch.robot_id == robot) {
            batches.emplace_back(t, up.batch.num_records());
          }
        }
        if (delay == 0.0) {
          CHECK(batches.size() == 12);
          continue;
        }
        REQUIRE(batches.size() == 1);
        CHECK(batches[0].second == 12);
        // The first keyframe is made at 0.1 s (the first scan at 0 makes keyframe 0 too); its batch leaves 2 s
        // later and arrives 20 ms after that.
        CHECK(batches[0].first >= 2000000);
        CHECK(batches[0].first <= 2200000);
      }
    }
  }
}

TEST_CASE("Reliable transfer: a robot whose first messages were all lost is heard once its link recovers") {
  // The server never heard of robot 1 during its first 10 s, so it sends it no status; robot 1 announces one
  // keyframe again after three resend timeouts of silence, the server learns of it, and the rest follows.
  LinkModel link;
  link.mute_robot = 1;
  link.mute_until_us = 10000000;
  Mission m(2, 12, link, 3, SendAllParams(), Batching{2.0, 16});
  m.RunUntil(9000000);
  CHECK(m.merge_->robot(1).size() == 0);
  CHECK(m.robots_[1]->link->stats().statuses == 0);
  m.RunUntil(60000000);
  m.CheckAllKeyframesDelivered();
  CHECK(m.robots_[1]->link->stats().keyframes_requeued >= 1);
  CHECK(m.robots_[0]->link->stats().keyframes_requeued == 0);  // robot 0 heard statuses all along
}

TEST_CASE("Reliable transfer: a 2 s one-way delay still delivers everything and merges every robot") {
  LinkModel link;
  link.delay_us = 2000000;
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  params.round_min_new_keyframes = 6;  // rounds start while the robots are still mapping
  Mission m(2, 12, link, 9, params);
  m.RunUntil(120000000);
  m.CheckAllKeyframesDelivered();
  const MergeResultMessage& r = m.server_->last_result();
  REQUIRE(r.in_world.size() == 2);
  CHECK(r.in_world[0] == 1);
  CHECK(r.in_world[1] == 1);
  // The last round saw every keyframe (what `commerge robot` waits for before it ends), and the server is
  // settled (what `commerge server --exit-when-merged` waits for).
  REQUIRE(r.keyframes.size() == 2);
  CHECK(r.keyframes[0] == m.robots_[0]->agent->mapper().num_keyframes());
  CHECK(r.keyframes[1] == m.robots_[1]->agent->mapper().num_keyframes());
  CHECK(m.server_->Settled(m.now_us_));
  CHECK(m.server_->rounds_merged() >= 2);  // rounds started while the robots were mapping
}

TEST_CASE("Reliable transfer: a restarted server gets every keyframe again and finishes the merge") {
  Mission m(2, 12, LinkModel{}, 3, SendAllParams());
  m.RunUntil(800000);  // part of the mission streamed
  m.StartServer(900);  // the server restarts: it lost everything
  m.RunUntil(40000000);
  m.CheckAllKeyframesDelivered();
  m.CheckAllScansDelivered();
  CHECK(m.merge_results_ >= 1);
  for (auto& r : m.robots_) {
    CHECK(r->link->stats().server_restarts == 1);
    CHECK(r->link->server_session() == 900);
  }
}

TEST_CASE("Reliable transfer: a restarted robot replaces its keyframes, and its old session is refused") {
  Mission m(2, 12, LinkModel{}, 4, SendAllParams());
  m.RunUntil(600000);
  const std::size_t before = m.merge_->robot(1).size();
  CHECK(before > 0);
  // A late message of the old session after the restart is stale.
  KeyframeBatch old_batch;
  old_batch.robot_id = 1;
  old_batch.session = 1001;
  m.RestartRobot(1, 2001);  // maps from scratch
  m.RunUntil(40000000);
  m.CheckAllKeyframesDelivered();
  m.CheckAllScansDelivered();
  CHECK(m.server_->stats().robot_restarts == 1);
  CHECK(m.server_->robot_session(1) == 2001);
  const std::uint64_t stale = m.server_->stats().stale_messages;
  CHECK_FALSE(m.server_->OnKeyframeBatch(old_batch, m.now_us_).ok());
  CHECK(m.server_->stats().stale_messages == stale + 1);
  CHECK(m.merge_->robot(1).size() == m.robots_[1]->agent->mapper().num_keyframes());
}

TEST_CASE("Reliable transfer: a robot restarted after a merge leaves the world frame until it is merged again") {
  Mission m(2, 12, LinkModel{}, 4, SendAllParams());
  m.RunUntil(40000000);
  REQUIRE(m.merge_results_ >= 1);
  const auto in_world = [&m](int robot) {
    const MergeResultMessage& r = m.server_->last_result();
    for (std::size_t i = 0; i < r.robot_ids.size(); ++i) {
      if (r.robot_ids[i] == robot) return r.in_world[i] != 0;
    }
    return false;
  };
  REQUIRE(in_world(1));
  const int rounds = m.server_->rounds_merged();
  m.RestartRobot(1, 2001);  // its new map frame is unrelated to the old one
  m.RunUntil(m.now_us_ + 300000);
  REQUIRE(m.server_->robot_session(1) == 2001);
  CHECK(m.server_->rounds_merged() == rounds);
  CHECK_FALSE(in_world(1));
  CHECK(in_world(0));  // robot 0's map is the world frame
  m.RunUntil(m.now_us_ + 40000000);
  CHECK(m.server_->rounds_merged() > rounds);
  CHECK(in_world(1));
}

TEST_CASE("Reliable transfer: a robot that left is asked for nothing and the round does not wait for it") {
  // Robot 0 ends (its process exits) as the first round starts, before it sent a scan. Told so (its last status
  // says "merged"), the server withdraws its request and merges at once with what it holds; not told, the round
  // waits the whole request_timeout_s (600 s here) for scans nobody will send: the control.
  for (const bool told : {false, true}) {
    CAPTURE(told);
    Mission m(2, 12, LinkModel{}, 5, SendAllParams());
    while (!m.server_->round_active() && m.now_us_ < 20000000) m.RunUntil(m.now_us_ + kTickUs);
    REQUIRE(m.server_->round_active());
    const int results = m.merge_results_;
    m.Leave(0);
    if (told) {
      m.server_->OnRobotLeft(0, 999);  // another session: ignored
      CHECK_FALSE(m.server_->robot_left(0));
      m.server_->OnRobotLeft(0, 1000);
      CHECK(m.server_->robot_left(0));
    }
    m.RunUntil(m.now_us_ + 20000000);
    if (!told) {
      CHECK(m.server_->round_active());
      CHECK(m.merge_results_ == results);
      CHECK(m.requests_to_gone_ > 0);  // repeated every policy_repeat_s
      continue;
    }
    CHECK_FALSE(m.server_->round_active());
    CHECK(m.merge_results_ == results + 1);
    CHECK(m.server_->stats().rounds_timed_out == 0);
    CHECK(m.requests_to_gone_ == 0);
    const MergeResultMessage& r = m.server_->last_result();
    REQUIRE(r.pairs.size() == 1);
    CHECK_FALSE(r.pairs[0].success);
    CHECK(r.pairs[0].verdict.find("no selected scan was received") != std::string::npos);
    // A restart of robot 0 (a new session) is asked again.
    m.RestartRobot(0, 1001);
    m.gone_[0] = 0;
    m.RunUntil(m.now_us_ + 500000);
    CHECK(m.server_->robot_session(0) == 1001);
    CHECK_FALSE(m.server_->robot_left(0));
  }
}

TEST_CASE("Reliable transfer: after a robot left, later rounds register with the scans held and keep it merged") {
  // Robot 0 maps 12 scans, robot 1 24 on the same street. Round 1 runs (requested) when robot 1 is half way and
  // places it; robot 0 then leaves. Round 2 (robot 1's new keyframes) asks robot 0 for nothing and registers with
  // the scans the server holds. (When a round holds none of the scans it selects of one robot, the pair keeps
  // the earlier round's result: KeepVerifiedPairs, tested on its own.)
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  params.request_timeout_s = 5.0;
  Mission m(2, 24, LinkModel{}, 6, params);
  m.scans_per_robot_ = {12, 24};
  m.RunUntil(1500000);
  m.server_->RequestRound();
  while (m.server_->rounds_merged() < 1 && m.now_us_ < 20000000) m.RunUntil(m.now_us_ + kTickUs);
  REQUIRE(m.server_->rounds_merged() == 1);
  const MergeResultMessage first = m.server_->last_result();
  REQUIRE(first.in_world.size() == 2);
  REQUIRE(first.in_world[1] == 1);
  REQUIRE(first.keyframes[1] < 24);
  m.Leave(0);
  m.server_->OnRobotLeft(0, 1000);
  m.RunUntil(m.now_us_ + 30000000);
  REQUIRE(m.server_->rounds_merged() >= 2);
  const MergeResultMessage& r = m.server_->last_result();
  CHECK(r.keyframes[1] == m.robots_[1]->agent->mapper().num_keyframes());
  CHECK(r.in_world[1] == 1);
  CHECK(m.requests_to_gone_ == 0);
  CHECK(m.server_->stats().rounds_timed_out == 0);
  const Eigen::Isometry3d d = first.T_world_map[1].inverse() * r.T_world_map[1];
  CHECK(d.translation().norm() < 0.3);
}

// Replays the recorded robot -> server traffic, with its timing, into a fresh server; returns its last result.
MergeResultMessage Replay(const std::vector<std::pair<std::int64_t, RobotOutgoing>>& recorded,
                          const ServerLinkParams& params) {
  MergeServerParams mp;
  mp.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
  mp.cascade.stage_a.tau_area = 4;
  MergeServer merge(2, 64, mp);
  ServerLink link(777, params, &merge);
  std::size_t next = 0;
  const std::int64_t end_us = recorded.back().first + 20000000;
  std::vector<ServerOutgoing> out;
  for (std::int64_t t = 0; t <= end_us; t += kTickUs) {
    for (; next < recorded.size() && recorded[next].first <= t; ++next) {
      const RobotOutgoing& m = recorded[next].second;
      switch (m.kind) {
        case RobotOutgoing::Kind::kKeyframeBatch: (void)link.OnKeyframeBatch(m.batch, t); break;
        case RobotOutgoing::Kind::kPoseUpdate: (void)link.OnPoseUpdate(m.poses, t); break;
        case RobotOutgoing::Kind::kScanChunk: (void)link.OnScanChunk(m.chunk, t); break;
      }
    }
    out.clear();
    REQUIRE(link.Poll(t, &out).ok());
  }
  return link.last_result();
}

TEST_CASE("Reliable transfer: a recorded mission replayed into a fresh server reproduces the merge") {
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  Mission m(2, 12, LinkModel{}, 4, params);
  m.RunUntil(40000000);
  const MergeResultMessage& original = m.server_->last_result();
  REQUIRE(original.robot_ids.size() == 2);
  REQUIRE(original.in_world[1] == 1);
  // The replayed server computes its own plan; no robot answers it, so it takes the recorded answers to the
  // recording server's requests. Those may carry other request ids (the recording server's round 3, say).
  std::vector<std::pair<std::int64_t, RobotOutgoing>> recorded = m.recorded_;
  for (auto& [t, msg] : recorded) {
    if (msg.kind == RobotOutgoing::Kind::kScanChunk) msg.chunk.request_id += 40;
  }
  params.accept_unrequested_scans = true;
  for (const auto* log : {&m.recorded_, &recorded}) {
    const MergeResultMessage replayed = Replay(*log, params);
    REQUIRE(replayed.robot_ids == original.robot_ids);
    CHECK(replayed.in_world == original.in_world);
    for (std::size_t i = 0; i < original.robot_ids.size(); ++i) {
      CAPTURE(i);
      CHECK((replayed.T_world_map[i].matrix() - original.T_world_map[i].matrix()).cwiseAbs().maxCoeff() < 1e-9);
    }
  }
  // Live rules refuse chunks that answer another request: the robot is not merged.
  params.accept_unrequested_scans = false;
  params.request_timeout_s = 5.0;
  const MergeResultMessage live_rules = Replay(recorded, params);
  REQUIRE(live_rules.in_world.size() == 2);
  CHECK(live_rules.in_world[1] == 0);
}

// What a replay that follows the recorded round steps did.
struct StepReplay {
  MergeResultMessage result;
  std::vector<RoundStep> steps;        ///< its own steps
  std::vector<std::string> mismatches; ///< FollowStep's errors, in order
};

// Replays `recorded` (robot -> server) and the recorded round steps into a fresh server as `commerge server
// --replay` does: robot messages wait in a queue, and each step record arriving `late` messages after the point
// where the recording server ran it (as a recorder sees it when the server's cascade took a while) first hands
// the link the messages the recording had taken (MessagesDue), then runs the step.
StepReplay ReplaySteps(const std::vector<std::pair<std::int64_t, RobotOutgoing>>& recorded,
                       const std::vector<std::pair<std::size_t, RoundStep>>& steps, std::size_t late, int robots) {
  MergeServerParams mp;
  mp.cascade.stage_a = SequentialMatchParams{};
  mp.cascade.stage_a.tau_area = 4;
  MergeServer merge(robots, 64, mp);
  ServerLinkParams params;
  params.mode = ExchangeMode::kStageABC;
  params.automatic_rounds = false;
  params.follow_recorded_steps = true;
  ServerLink link(777, params, &merge);
  StepReplay replay;
  std::vector<std::pair<std::int64_t, RobotOutgoing>> queue;
  const auto apply = [&](const std::pair<std::int64_t, RobotOutgoing>& m) {
    switch (m.second.kind) {
      case RobotOutgoing::Kind::kKeyframeBatch: (void)link.OnKeyframeBatch(m.second.batch, m.first); break;
      case RobotOutgoing::Kind::kPoseUpdate: (void)link.OnPoseUpdate(m.second.poses, m.first); break;
      case RobotOutgoing::Kind::kScanChunk: (void)link.OnScanChunk(m.second.chunk, m.first); break;
    }
  };
  std::size_t next_step = 0;
  std::vector<ServerOutgoing> out;
  for (std::size_t i = 0; i <= recorded.size() + late; ++i) {
    if (i < recorded.size()) queue.push_back(recorded[i]);
    for (; next_step < steps.size() && std::min(steps[next_step].first + late, recorded.size()) <= i; ++next_step) {
      const RoundStep& step = steps[next_step].second;
      std::vector<QueuedRobotMessage> refs;
      for (const auto& [t, m] : queue) {
        refs.push_back({m.kind == RobotOutgoing::Kind::kKeyframeBatch ? m.batch.robot_id
                        : m.kind == RobotOutgoing::Kind::kPoseUpdate  ? m.poses.robot_id
                                                                      : m.chunk.robot_id,
                        m.kind == RobotOutgoing::Kind::kKeyframeBatch ? RobotMessageKind::kKeyframeBatch
                        : m.kind == RobotOutgoing::Kind::kPoseUpdate  ? RobotMessageKind::kPoseUpdate
                                                                      : RobotMessageKind::kScanChunk});
      }
      const std::vector<RoundRobotInput> taken = link.TakenInputs();
      const std::vector<std::size_t> due = MessagesDue(Span<const QueuedRobotMessage>(refs),
                                                       Span<const RoundRobotInput>(step.robots),
                                                       Span<const RoundRobotInput>(taken));
      std::vector<std::pair<std::int64_t, RobotOutgoing>> kept;
      std::size_t d = 0;
      for (std::size_t q = 0; q < queue.size(); ++q) {
        if (d < due.size() && due[d] == q) {
          apply(queue[q]);
          ++d;
        } else {
          kept.push_back(std::move(queue[q]));
        }
      }
      queue = std::move(kept);
      out.clear();
      const Status st = link.FollowStep(step, step.utime_us, &out);
      if (!st.ok()) replay.mismatches.push_back(st.message());
      for (const ServerOutgoing& o : out) {
        if (o.kind == ServerOutgoing::Kind::kRoundStep) replay.steps.push_back(o.step);
      }
    }
  }
  replay.result = link.last_result();
  return replay;
}

TEST_CASE("Reliable transfer: a replay that follows the recorded round steps reproduces every round and request") {
  // Three robots, loss, duplicates and reordering, rounds every second: messages keep arriving between a
  // round's steps, so where a step cuts the data matters.
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  params.round_interval_s = 1.0;
  params.round_min_new_keyframes = 8;
  params.request_timeout_s = 3.0;
  Mission m(3, 48, LinkModel{0.1, 0.05, 20000, 60000}, 11, params);
  m.RunUntil(60000000);
  REQUIRE(m.server_->rounds_merged() >= 3);
  REQUIRE(m.steps_.size() >= 6);
  const MergeResultMessage& original = m.server_->last_result();
  REQUIRE(original.in_world.size() == 3);
  for (std::size_t late : {std::size_t{0}, std::size_t{7}, std::size_t{40}}) {
    CAPTURE(late);
    const StepReplay replay = ReplaySteps(m.recorded_, m.steps_, late, 3);
    CHECK(replay.mismatches.empty());
    if (!replay.mismatches.empty()) MESSAGE(replay.mismatches.front());
    REQUIRE(replay.steps.size() == m.steps_.size());
    for (std::size_t i = 0; i < replay.steps.size(); ++i) {
      CAPTURE(i);
      CHECK(RoundStepMismatch(m.steps_[i].second, replay.steps[i]).empty());
      CHECK(replay.steps[i].requests.size() == m.steps_[i].second.requests.size());
    }
    REQUIRE(replay.result.round == original.round);
    CHECK(replay.result.in_world == original.in_world);
    for (std::size_t r = 0; r < original.robot_ids.size(); ++r) {
      CHECK((replay.result.T_world_map[r].matrix() - original.T_world_map[r].matrix()).cwiseAbs().maxCoeff() == 0.0);
    }
  }
  // A log that lacks one of robot 1's keyframe batches: the step that had taken it says so, by robot and count.
  std::vector<std::pair<std::int64_t, RobotOutgoing>> lacking = m.recorded_;
  std::vector<std::pair<std::size_t, RoundStep>> steps = m.steps_;
  for (std::size_t i = 0; i < lacking.size(); ++i) {
    if (lacking[i].second.kind != RobotOutgoing::Kind::kKeyframeBatch || lacking[i].second.batch.robot_id != 1) continue;
    lacking.erase(lacking.begin() + static_cast<std::ptrdiff_t>(i));
    for (auto& [at, step] : steps) at -= at > i ? 1 : 0;
    break;
  }
  const StepReplay broken = ReplaySteps(lacking, steps, 0, 3);
  REQUIRE(!broken.mismatches.empty());
  MESSAGE(broken.mismatches.front());
  CHECK(broken.mismatches.front().find("robot 1 input: recorded session 1001") != std::string::npos);
}

TEST_CASE("Reliable transfer: a refused message of a newer session neither resets the robot nor locks it out") {
  // Found by the server-inbox fuzzer: the newer session used to be adopted (wiping the robot) before the message
  // was validated, and the robot's real session was refused as stale from then on.
  Mission m(2, 6, LinkModel{}, 3, SendAllParams());
  m.RunUntil(2000000);
  const std::size_t held = m.merge_->robot(0).size();
  REQUIRE(held > 0);
  const std::int64_t session = m.server_->robot_session(0);
  PoseUpdate beyond;  // a keyframe beyond the server's capacity (64)
  beyond.robot_id = 0;
  beyond.session = session + 1;
  beyond.keyframes = {100000};
  beyond.T_map_sensor = {Eigen::Isometry3d::Identity()};
  CHECK_FALSE(m.server_->OnPoseUpdate(beyond, m.now_us_).ok());
  KeyframeBatch corrupt;  // one record whose bytes decode to nothing valid
  corrupt.robot_id = 0;
  corrupt.session = session + 2;
  corrupt.records.assign(kKeyframeRecordBytes, 0xff);
  corrupt.stored_points = {10};
  CHECK_FALSE(m.server_->OnKeyframeBatch(corrupt, m.now_us_).ok());
  CHECK(m.server_->robot_session(0) == session);
  CHECK(m.server_->stats().robot_restarts == 0);
  CHECK(m.merge_->robot(0).size() == held);
  m.RunUntil(40000000);  // the real session goes on
  m.CheckAllKeyframesDelivered();
}

TEST_CASE("Reliable transfer: a status older than the robot's request does not withdraw it") {
  // Seen in the dup-reorder fault test: a status from before a round (no request) arrived after that round's
  // policy and made the robot drop the request, which then stayed unanswered until the server's timeout.
  Mission m(2, 4, LinkModel{}, 5, SendAllParams());
  m.RunUntil(600000);
  RobotLink& link = *m.robots_[0]->link;
  REQUIRE(m.robots_[0]->agent->mapper().num_keyframes() > 0);
  ScanRequest request;
  request.utime_us = m.now_us_;
  request.robot_id = 0;
  request.server_session = m.server_->session();
  request.request_id = 99;
  request.keyframes = {0};
  REQUIRE(link.OnScanRequest(request, m.now_us_).ok());
  REQUIRE(link.queued_chunks() > 0);
  TransferStatus stale = m.server_->MakeStatus(0, m.now_us_ - 200000);
  stale.request_id = -1;
  stale.request_complete = false;
  stale.missing.clear();
  REQUIRE(stale.utime_us < request.utime_us);
  CHECK(link.OnTransferStatus(stale, m.now_us_).ok());
  CHECK(link.active_request() == 99);
  CHECK(link.queued_chunks() > 0);
  TransferStatus later = stale;  // the server withdrew the request after issuing it: drop it
  later.utime_us = request.utime_us + 1000000;
  CHECK(link.OnTransferStatus(later, m.now_us_ + 1000000).ok());
  CHECK(link.queued_chunks() == 0);
}

TEST_CASE("Reliable transfer: chunks outside the active request and statuses for other robots are refused") {
  Mission m(2, 4, LinkModel{}, 5, SendAllParams());
  m.RunUntil(300000);
  ScanChunk chunk;
  chunk.robot_id = 0;
  chunk.request_id = 77;
  chunk.keyframe = 0;
  chunk.total_bytes = 30;
  chunk.num_chunks = 1;
  chunk.payload.assign(30, 1);
  const std::size_t held = m.merge_->scans_received();
  CHECK_FALSE(m.server_->OnScanChunk(chunk, m.now_us_).ok());
  CHECK(m.merge_->scans_received() == held);
  TransferStatus foreign = m.server_->MakeStatus(1, m.now_us_);
  CHECK_FALSE(m.robots_[0]->link->OnTransferStatus(foreign, m.now_us_).ok());
  CHECK(m.robots_[0]->link->stats().foreign_statuses == 1);
  ScanRequest other;
  other.robot_id = 1;
  CHECK_FALSE(m.robots_[0]->link->OnScanRequest(other, m.now_us_).ok());
  KeyframeBatch no_session;
  no_session.robot_id = 0;
  CHECK_FALSE(m.server_->OnKeyframeBatch(no_session, m.now_us_).ok());
}

TEST_CASE("Token bucket: the bytes let through never exceed rate x time + burst, and it does not starve") {
  TokenBucket bucket(1000.0, 500.0);
  std::int64_t sent = 0;
  const std::int64_t end_us = 10000000;
  for (std::int64_t t = 0; t <= end_us; t += 1000) {
    while (bucket.CanSend(t)) {
      bucket.Take(120);
      sent += 120;
    }
    if (t > 0) REQUIRE(sent <= static_cast<std::int64_t>(1000.0 * static_cast<double>(t) * 1e-6 + 500.0 + 120.0));
  }
  CHECK(sent >= 10000 - 120);  // 10 s at 1000 B/s
  TokenBucket empty(1000.0, 0.0);
  CHECK(empty.CanSend(0));
  empty.Take(2000);
  CHECK_FALSE(empty.CanSend(0));
  CHECK(empty.WaitUs(0) == 2000000);
  CHECK(empty.CanSend(2000000));
  TokenBucket unlimited(0.0, 0.0);
  unlimited.Take(1 << 20);
  CHECK(unlimited.CanSend(0));
}
