// SPDX-License-Identifier: BSD-3-Clause
// tests/fuzz/server_inbox.hpp: the replayed server and the checks it makes on every record.
#include "tests/fuzz/server_inbox.hpp"

#include <cstdlib>
#include <cstring>
#include <utility>

#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "platform/lcm/round_codec.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {

bool TakeInboxRecord(Span<const std::uint8_t>* stream, InboxRecord* record) {
  if (stream->empty()) return false;
  const Span<const std::uint8_t> s = *stream;
  record->channel = static_cast<InboxChannel>(s[0] % kInboxChannels);
  std::size_t length = 0;
  std::size_t header = 1;
  if (s.size() >= 3) {
    length = (static_cast<std::size_t>(s[1]) << 8) | s[2];
    header = 3;
  }
  if (length > s.size() - header) length = s.size() - header;
  record->payload = s.subspan(header, length);
  *stream = s.subspan(header + length, s.size() - header - length);
  return true;
}

void AppendInboxRecord(InboxChannel channel, Span<const std::uint8_t> payload, std::vector<std::uint8_t>* stream) {
  if (payload.size() > kInboxMaxPayloadBytes) Fail("inbox record of %zu bytes (at most 65535)", payload.size());
  stream->push_back(static_cast<std::uint8_t>(channel));
  stream->push_back(static_cast<std::uint8_t>(payload.size() >> 8));
  stream->push_back(static_cast<std::uint8_t>(payload.size() & 0xff));
  stream->insert(stream->end(), payload.begin(), payload.end());
}

MergeServerParams InboxMergeServerParams() {
  MergeServerParams p;
  // The recorded missions are short (tens of keyframes per robot): stage A's span area must let them through
  // (the daemon's --tau-area; the paper's 10000 cells is a 100 x 100 keyframe overlap).
  p.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
  p.cascade.stage_a.tau_area = 100;
  // A fuzzed keyframe database can make stage B / C search until their wall-clock limits (5 s / 2 s per pair
  // by default): 0.5 s keeps one input well inside libFuzzer's -timeout. Same code, smaller budget.
  p.cascade.stage_b.time_limit_s = 0.5;
  p.cascade.stage_c.time_limit_s = 0.5;
  // The recorded mission's L_K names 4 + 3 keyframes: 5 per robot keeps the padding of the exchange policy in
  // the fuzzed path while the stream (every requested scan's chunks) and one merge round stay small for
  // libFuzzer (5 + 5 scans: 142 KB and ~2 s; the default 10 would ask for up to 20 scans).
  p.cascade.policy.min_scans_per_robot = 5;
  // Partial scans are allocated whole on their first chunk: a scan may be kMaxChunksPerScan x 1200 bytes
  // (39.3 MB), and the daemon's 512 MB budget would let a stream of such chunks past -rss_limit_mb. 96 MB holds
  // two of the largest legal scans (what -malloc_limit_mb must allow) and keeps RSS bounded.
  p.max_scan_bytes = 96ull << 20;
  return p;
}

ServerLinkParams InboxServerLinkParams() { return ServerLinkParams{}; }  // the daemon's defaults

namespace {

// The daemon's status string field limit (apps/cmd_server.cpp cuts last_rejection the same way).
std::string Clip(std::string text) {
  if (text.size() > kMaxStatusTextBytes) text.resize(kMaxStatusTextBytes);
  return text;
}

// FNV-1a over raw bytes.
void Mix(std::uint64_t* h, const void* data, std::size_t bytes) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  for (std::size_t i = 0; i < bytes; ++i) *h = (*h ^ p[i]) * 1099511628211ull;
}
template <typename T>
void MixVector(std::uint64_t* h, const std::vector<T>& v) {
  const std::uint64_t n = v.size();
  Mix(h, &n, sizeof(n));
  if (!v.empty()) Mix(h, v.data(), v.size() * sizeof(T));
}

// Encodes one published message and decodes it again; Fail() when either side refuses.
template <typename Message, typename Encoder, typename Decoder>
std::vector<std::uint8_t> RoundTrip(const char* what, const Message& m, Encoder encode, Decoder decode) {
  std::vector<std::uint8_t> bytes;
  if (Status st = encode(m, &bytes); !st.ok()) {
    Fail("server inbox: the server published a %s its encoder refuses: %s", what, st.ToString().c_str());
  }
  if (auto back = decode(Span<const std::uint8_t>(bytes)); !back.ok()) {
    Fail("server inbox: the server published a %s whose encoding (%zu bytes) its decoder refuses: %s", what,
         bytes.size(), back.status().ToString().c_str());
  }
  return bytes;
}

std::unique_ptr<MergeServer> MakeInboxMergeServer() {
  auto server = MergeServer::Create(kInboxMaxRobots, kInboxMaxKeyframes, InboxMergeServerParams());
  if (!server.ok()) Fail("server inbox: bad server parameters: %s", server.status().ToString().c_str());
  return std::move(*server);
}

}  // namespace

InboxServer::InboxServer()
    : server_(MakeInboxMergeServer()), link_(kInboxServerSession, InboxServerLinkParams(), server_.get()) {
  const char* strict = std::getenv("CM_FUZZ_STRICT_REFUSALS");
  strict_refusals_ = strict == nullptr || std::strcmp(strict, "0") != 0;
}

std::uint64_t InboxServer::CountedRefusals() const {
  const MergeServerStats& s = server_->stats();
  return s.rejected_batches + s.rejected_records + s.rejected_pose_updates + s.rejected_chunks +
         link_.stats().stale_messages;
}

// For the strict-refusals check: the sessions and keyframe databases of every robot. (This check found that
// ServerLink adopted a newer session, wiping the robot, before MergeServer refused the message; ServerLink now
// runs MergeServer::CheckKeyframeBatch / CheckPoseUpdate first.)
std::uint64_t InboxServer::StateDigest() const {
  std::uint64_t h = 1469598103934665603ull;
  for (int r = 0; r < server_->max_robots(); ++r) {
    const std::int64_t session = link_.robot_session(r);
    Mix(&h, &session, sizeof(session));
    const RobotKeyframeDb& db = server_->robot(r);
    MixVector(&h, db.descriptors);
    MixVector(&h, db.valid);
    MixVector(&h, db.pose_known);
    MixVector(&h, db.no_descriptor);
    MixVector(&h, db.stored_points);
    for (const Eigen::Isometry3d& T : db.T_map_sensor) Mix(&h, T.matrix().data(), sizeof(double) * 16);
  }
  return h;
}

template <typename Message, typename Handler>
void InboxServer::Deliver(const char* channel, const Result<Message>& decoded, Handler handler) {
  if (!decoded.ok()) {
    if (decoded.status().code() != StatusCode::kDataLoss) {
      Fail("server inbox: %s: the decoder refused with '%s' (decoders refuse with DataLoss)", channel,
           decoded.status().ToString().c_str());
    }
    ++rejected_;
    last_rejection_ = Clip(std::string(channel) + ": " + decoded.status().message());
    return;
  }
  const std::uint64_t counted = CountedRefusals();
  const std::uint64_t records = server_->stats().records;
  const std::uint64_t digest = strict_refusals_ ? StateDigest() : 0;
  const Status st = handler(*decoded);
  if (st.ok()) {
    ++accepted_;
    return;
  }
  ++rejected_;
  last_rejection_ = Clip(std::string(channel) + ": " + st.message());
  if (CountedRefusals() <= counted) {
    Fail("server inbox: %s: the server refused a message without counting it: %s", channel, st.ToString().c_str());
  }
  if (strict_refusals_ && server_->stats().records == records && StateDigest() != digest) {
    Fail("server inbox: %s: a refused message changed a robot's session or keyframes: %s", channel,
         st.ToString().c_str());
  }
}

void InboxServer::Feed(const InboxRecord& record) {
  const Span<const std::uint8_t> bytes = record.payload;
  switch (record.channel) {
    case InboxChannel::kKeyframes:
      Deliver(platform::kKeyframesChannel, platform::DecodeKeyframeBatch(bytes),
              [this](const KeyframeBatch& m) { return link_.OnKeyframeBatch(m, now_us_); });
      break;
    case InboxChannel::kPoses:
      Deliver(platform::kPosesChannel, platform::DecodePoseUpdate(bytes),
              [this](const PoseUpdate& m) { return link_.OnPoseUpdate(m, now_us_); });
      break;
    case InboxChannel::kScans:
      Deliver(platform::kScansChannel, platform::DecodeScanChunk(bytes),
              [this](const ScanChunk& m) { return link_.OnScanChunk(m, now_us_); });
      break;
    case InboxChannel::kTick:
      now_us_ += kInboxTickUs * (1 + (bytes.empty() ? 0 : bytes[0]));
      break;
  }
  if (record.channel != InboxChannel::kTick) bytes_received_ += static_cast<std::int64_t>(bytes.size());
  Publish();
}

void InboxServer::Publish() {
  out_.clear();
  out_bytes_.clear();
  // A failed round (the cascade or the registration refused its input) is logged by the daemon and abandoned;
  // not a promise broken here.
  if (!link_.Poll(now_us_, &out_).ok()) ++failed_polls_;
  for (const ServerOutgoing& o : out_) {
    switch (o.kind) {
      case ServerOutgoing::Kind::kTransferStatus:
        out_bytes_.push_back(RoundTrip("transfer_status_t", o.status, platform::EncodeTransferStatus,
                                       platform::DecodeTransferStatus));
        break;
      case ServerOutgoing::Kind::kScanRequest:
        out_bytes_.push_back(RoundTrip("exchange_policy_t", o.request, platform::EncodeScanRequest,
                                       platform::DecodeScanRequest));
        break;
      case ServerOutgoing::Kind::kMergeResult:
        out_bytes_.push_back(RoundTrip("merge_result_t", o.result, platform::EncodeMergeResult,
                                       platform::DecodeMergeResult));
        break;
      case ServerOutgoing::Kind::kRoundStep:
        out_bytes_.push_back(RoundTrip("merge_round_t", o.step, platform::EncodeRoundStep, platform::DecodeRoundStep));
        break;
    }
  }
  if (now_us_ >= next_status_us_) {  // the daemon's once-per-second health message
    next_status_us_ = now_us_ + 1000000;
    (void)RoundTrip("server_status_t", MakeServerStatus(), platform::EncodeServerStatus,
                    platform::DecodeServerStatus);
  }
}

ServerStatus InboxServer::MakeServerStatus() const {
  ServerStatus status;  // as apps/cmd_server.cpp fills it
  status.utime_us = now_us_;
  status.session = kInboxServerSession;
  status.round = link_.rounds_merged();
  status.state = link_.state();
  status.bytes_received = bytes_received_;
  status.messages_rejected = static_cast<std::int64_t>(rejected_);
  status.last_rejection = last_rejection_;
  link_.AppendRobotStatus(&status);
  return status;
}

}  // namespace commerge::fuzz
