// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/lcm_recorder.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include <lcm/lcm.h>

namespace commerge::platform {

// ---- sequence gaps ----

std::uint64_t SequenceGapCounter::Missing(const Track& track) noexcept {
  if (!track.seen) return 0;
  const std::uint64_t span = track.highest - track.lowest + 1;
  // received can exceed the span when a duplicate arrived beyond the window (taken as new): saturate.
  return span > track.summary.received ? span - track.summary.received : 0;
}

void SequenceGapCounter::Count(const std::uint8_t* data, std::size_t size) noexcept {
  AuthTrailerFields trailer;
  if (!ReadAuthTrailer(data, size, &trailer)) {
    ++unsigned_;
    return;
  }
  const std::uint16_t sender = trailer.sender;
  const std::int64_t session = trailer.session;
  const std::uint64_t sequence = trailer.sequence;
  std::size_t slot = 0;
  if (sender < kAuthMaxRobots) {
    slot = sender;
  } else if (sender == kAuthServerSender) {
    slot = kAuthMaxRobots;
  } else {
    ++unknown_senders_;
    return;
  }
  if (session <= 0 || sequence == 0) {  // never signed like this: not a message of a session
    ++stale_;
    return;
  }
  Track& track = tracks_[slot];
  const AuthVerdict verdict = track.window.Check(session, sequence);
  if (verdict == AuthVerdict::kOldSession) {
    ++stale_;
    return;
  }
  if (verdict == AuthVerdict::kReplayed) {
    ++track.summary.duplicates;
    return;
  }
  if (!track.seen || session > track.summary.session) {  // the sender's first or a newer session
    track.summary.older_sessions_missing += Missing(track);
    track.seen = true;
    track.summary.sender = sender;
    track.summary.session = session;
    track.summary.received = 0;
    track.lowest = track.highest = sequence;
  }
  track.window.Accept(session, sequence);  // kTooOld: beyond the window, taken as new (the window is unchanged)
  ++track.summary.received;
  track.lowest = std::min(track.lowest, sequence);
  track.highest = std::max(track.highest, sequence);
}

std::vector<SenderSequences> SequenceGapCounter::senders() const {
  std::vector<SenderSequences> out;
  for (const Track& track : tracks_) {
    if (!track.seen) continue;
    SenderSequences s = track.summary;
    s.missing = Missing(track);
    out.push_back(s);
  }
  return out;
}

std::uint64_t SequenceGapCounter::missing() const noexcept {
  std::uint64_t n = 0;
  for (const Track& track : tracks_) n += track.summary.older_sessions_missing + Missing(track);
  return n;
}

// ---- recorder ----

Result<std::unique_ptr<LcmRecorder>> LcmRecorder::Open(const LcmRecorderParams& params) {
  if (params.out_path.empty()) return InvalidArgument("record: no output file given");
  if (params.lcm_queue_capacity < 1) {
    return InvalidArgument("record: lcm_queue_capacity must be >= 1, not " + std::to_string(params.lcm_queue_capacity));
  }
  struct stat st {};
  if (!params.overwrite && ::stat(params.out_path.c_str(), &st) == 0) {
    return InvalidArgument(params.out_path + ": exists (give --force to replace it)");
  }
  std::unique_ptr<LcmRecorder> rec(new LcmRecorder(params));
  LcmBusParams bus_params;
  bus_params.url = params.url;
  bus_params.lcm_queue_capacity = params.lcm_queue_capacity;
  bus_params.receive_thread = params.receive_thread;
  bus_params.max_queued_messages = params.max_queued_messages;
  bus_params.max_queued_bytes = params.max_queued_bytes;
  auto bus = LcmBus::Create(bus_params);  // no authentication: the trailers are recorded as they came
  if (!bus.ok()) return bus.status();
  rec->bus_ = std::move(*bus);
  if (Status s = rec->bus_->Subscribe(params.channels); !s.ok()) return s;
  rec->log_ = lcm_eventlog_create(params.out_path.c_str(), "w");
  if (rec->log_ == nullptr) return IoError(params.out_path + ": cannot create the log: " + std::strerror(errno));
  rec->last_flush_us_ = MonotonicUs();
  return rec;
}

LcmRecorder::~LcmRecorder() { (void)Close(); }

Status LcmRecorder::Poll(int timeout_ms) {
  if (log_ == nullptr) return IoError(params_.out_path + ": the recorder is closed");
  if (Status st = bus_->Poll(timeout_ms); !st.ok()) return st;
  if (Status st = WriteQueued(); !st.ok()) return st;
  if (MonotonicUs() - last_flush_us_ >= 1000000) return Flush();
  return Status::Ok();
}

Result<std::uint64_t> LcmRecorder::Drain(int quiet_ms, int max_ms) {
  const std::uint64_t before = stats_.messages;
  const std::int64_t end_us = MonotonicUs() + static_cast<std::int64_t>(std::max(0, max_ms)) * 1000;
  for (;;) {
    const std::uint64_t seen = stats_.messages;
    if (Status st = Poll(std::max(1, quiet_ms)); !st.ok()) return st;
    if (stats_.messages == seen || MonotonicUs() >= end_us) break;
  }
  return stats_.messages - before;
}

Status LcmRecorder::WriteQueued() {
  BusMessage m;
  while (bus_->Take(&m)) {
    lcm_eventlog_event_t event{};
    event.eventnum = static_cast<std::int64_t>(stats_.messages);
    event.timestamp = m.recv_utime_us;
    event.channellen = static_cast<std::int32_t>(m.channel.size());
    event.datalen = static_cast<std::int32_t>(m.bytes.size());
    event.channel = const_cast<char*>(m.channel.c_str());
    event.data = m.bytes.data();
    if (lcm_eventlog_write_event(log_, &event) != 0) {
      return IoError(params_.out_path + ": writing event " + std::to_string(stats_.messages) +
                     " failed: " + std::strerror(errno));
    }
    ++stats_.messages;
    stats_.bytes += m.bytes.size();
    sequences_.Count(m.bytes.data(), m.bytes.size());
  }
  stats_.dropped = bus_->stats().dropped_queue_full;
  return Status::Ok();
}

Status LcmRecorder::Flush() {
  if (log_ == nullptr) return IoError(params_.out_path + ": the recorder is closed");
  last_flush_us_ = MonotonicUs();
  if (std::fflush(log_->f) != 0) return IoError(params_.out_path + ": flush failed: " + std::strerror(errno));
  return Status::Ok();
}

Status LcmRecorder::Close() {
  if (log_ == nullptr) return Status::Ok();
  Status st = WriteQueued();
  if (Status flushed = Flush(); st.ok()) st = flushed;
  lcm_eventlog_destroy(log_);
  log_ = nullptr;
  return st;
}

}  // namespace commerge::platform
