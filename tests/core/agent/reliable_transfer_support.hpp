// SPDX-License-Identifier: BSD-3-Clause
// The simulated mission shared by test_reliable_transfer.cpp (robot and server together) and test_server_link.cpp
// (the server's sessions, rounds, requests and replay): robots that map a street scene, RobotLink and ServerLink
// on a MergeServer, and a link that drops, duplicates, delays and reorders messages (seeded).
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "core/agent/delivery_digest.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/robot_link.hpp"
#include "core/agent/round_replay.hpp"
#include "core/agent/server_link.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "tests/core/agent/server_fixture.hpp"

namespace commerge::test {

inline constexpr std::int64_t kTickUs = 10000;  // 10 ms

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

inline std::unique_ptr<Robot> MakeRobot(int id, std::int64_t session, Batching batching = {}) {
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

inline std::size_t WireBytes(const RobotOutgoing& m) {  // close to the LCM sizes; only the bandwidth cap uses it
  switch (m.kind) {
    case RobotOutgoing::Kind::kKeyframeBatch: return 44 + m.batch.records.size() + 4 * m.batch.stored_points.size();
    case RobotOutgoing::Kind::kPoseUpdate: return 38 + 8 * m.poses.keyframes.size();  // compact pose list
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
    merge_ = commerge::test::MakeTestServer(static_cast<int>(std::max<std::size_t>(2, robots_.size())), 64, mp);
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
          // What the robot's record kind carries: the 92-byte record's 14 bits, or the compact batch's quantisation.
          std::array<float, kKeyframeDescriptorDim> expected{};
          const Span<const float> d = a.mapper().descriptor(k);
          if (a.params().record_descriptor_bits > 0) {
            CompactKeyframe keyframe;
            keyframe.pose = KeyframePose{static_cast<std::uint32_t>(k), a.mapper().pose(k)};
            std::copy(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(kKeyframeDescriptorDim), keyframe.descriptor.begin());
            auto quantised = QuantiseCompactKeyframe(keyframe, a.params().record_descriptor_bits);
            REQUIRE(quantised.ok());
            expected = quantised->descriptor;
          } else {
            KeyframeRecord record;
            record.keyframe_index = static_cast<std::uint32_t>(k);
            record.T_map_sensor = a.mapper().pose(k);
            std::copy(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(kKeyframeDescriptorDim), record.descriptor.begin());
            record.descriptor_valid = true;
            std::vector<std::uint8_t> bytes(kKeyframeRecordBytes);
            REQUIRE(EncodeKeyframeRecord(record, Span<std::uint8_t>(bytes)).ok());
            auto decoded = DecodeKeyframeRecord(Span<const std::uint8_t>(bytes));
            REQUIRE(decoded.ok());
            expected = decoded->descriptor;
          }
          for (std::size_t j = 0; j < kKeyframeDescriptorDim; ++j) {
            REQUIRE(db.descriptors[k * kKeyframeDescriptorDim + j] == expected[j]);
          }
        }
        CHECK((db.T_map_sensor[k].translation() - a.mapper().pose(k).translation()).norm() <
              a.params().pose_update_min_translation_m + 0.01);
      }
      // The one-line digests the process-level fault tests compare agree, and would catch one changed or
      // missing descriptor.
      auto robot_digest = RobotDeliveryDigest(a.mapper(), a.params().record_descriptor_bits);
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

inline ServerLinkParams SendAllParams() {
  ServerLinkParams p;
  p.mode = ExchangeMode::kSendAll;  // every stored scan is requested: the transfer of all of them is checked
  p.round_quiet_s = 2.0;
  p.request_timeout_s = 600.0;
  return p;
}

}  // namespace commerge::test
