// SPDX-License-Identifier: BSD-3-Clause
// `commerge record`: writes the mission's LCM traffic to an LCM event log for `commerge server --replay`
// (played back with lcm-logplayer), and says whether the recording is complete by the senders' sequence
// numbers (platform/lcm/lcm_recorder).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/lcm_recorder.hpp"

namespace commerge::app {

namespace {

struct RecordOptions {
  platform::LcmRecorderParams params;
  double max_runtime_s = 0.0;
  bool quiet = false;
};

std::string SenderName(std::uint16_t sender) {
  return sender == platform::kAuthServerSender ? std::string("server") : "robot " + std::to_string(sender);
}

// One line: what was written and what the log lacks.
std::string Summary(const platform::LcmRecorder& rec) {
  const platform::LcmRecorderStats& s = rec.stats();
  const platform::SequenceGapCounter& q = rec.sequences();
  std::string line = "record: " + std::to_string(s.messages) + " messages, " + std::to_string(s.bytes) +
                     " bytes in " + rec.path() + "; " + std::to_string(q.missing()) +
                     " missing by the senders' sequence numbers";
  for (const platform::SenderSequences& sender : q.senders()) {
    line += "; " + SenderName(sender.sender) + " " + std::to_string(sender.received) + " (" +
            std::to_string(sender.missing + sender.older_sessions_missing) + " missing, " +
            std::to_string(sender.duplicates) + " duplicates)";
  }
  if (s.dropped > 0) line += "; " + std::to_string(s.dropped) + " dropped by the full queue";
  if (q.unsigned_messages() > 0) {
    line += "; " + std::to_string(q.unsigned_messages()) + " unsigned (their completeness is unknown)";
  }
  if (q.stale_messages() + q.unknown_senders() > 0) {
    line += "; " + std::to_string(q.stale_messages() + q.unknown_senders()) + " of old sessions or unknown senders";
  }
  return line;
}

/// On a stop: keep writing until this long passes without a message, at most kDrainMaxMs [ms].
constexpr int kDrainQuietMs = 200;
constexpr int kDrainMaxMs = 2000;

int RunRecord(const RecordOptions& o) {
  const char* tag = "commerge record";
  auto rec = platform::LcmRecorder::Open(o.params);
  if (!rec.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, rec.status().message().c_str());
    return kExitFailure;
  }
  InstallStopSignalHandlers();
  if (!o.quiet) {
    std::fprintf(stderr, "%s: writing channels %s on %s to %s; stop with Ctrl-C\n", tag, o.params.channels.c_str(),
                 o.params.url.empty() ? "the default LCM URL" : o.params.url.c_str(), o.params.out_path.c_str());
  }
  const std::int64_t start_us = platform::MonotonicUs();
  std::int64_t next_progress_us = start_us + 10000000;
  int exit_code = kExitOk;
  while (StopSignalCount() == 0) {
    if (Status st = (*rec)->Poll(100); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      exit_code = kExitFailure;
      break;
    }
    const std::int64_t now = platform::MonotonicUs();
    if (o.max_runtime_s > 0.0 && static_cast<double>(now - start_us) > o.max_runtime_s * 1e6) break;
    if (!o.quiet && now >= next_progress_us) {
      next_progress_us = now + 10000000;
      std::fprintf(stderr, "%s\n", Summary(**rec).c_str());
    }
  }
  // A stop request comes right after the mission's last messages (the script or the operator saw it end): take what
  // the network still holds for this process before closing, or the log can lack the final round step.
  if (exit_code == kExitOk) {
    if (auto drained = (*rec)->Drain(kDrainQuietMs, kDrainMaxMs); !drained.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, drained.status().message().c_str());
      exit_code = kExitFailure;
    }
  }
  if (Status st = (*rec)->Close(); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    exit_code = kExitFailure;
  }
  std::printf("%s\n", Summary(**rec).c_str());
  if ((*rec)->sequences().missing() > 0 || (*rec)->stats().dropped > 0) {
    std::fprintf(stderr, "%s: the recording is incomplete: a replay of it cannot reproduce the mission exactly\n", tag);
  }
  return exit_code;
}

}  // namespace

Command AddRecordCommand(CLI::App& root) {
  auto o = std::make_shared<RecordOptions>();
  CLI::App* cmd = root.add_subcommand(
      "record", "write the mission's LCM messages to an LCM event log (for lcm-logplayer and `commerge server "
                "--replay`), counting what the log misses by the senders' sequence numbers");
  cmd->add_option("--out", o->params.out_path, "the log file to write")->required();
  cmd->add_flag("--force", o->params.overwrite, "replace an existing log file");
  cmd->add_option("--lcm-url", o->params.url, "LCM provider URL (default: LCM_DEFAULT_URL or LCM's default)");
  cmd->add_option("--channels", o->params.channels,
                  "LCM channel regex to record; the completeness count needs every channel the senders sign")
      ->capture_default_str();
  cmd->add_option("--lcm-queue", o->params.lcm_queue_capacity,
                  "messages LCM may hold between two writes (lcm-logger keeps LCM's 30 and loses messages on a "
                  "loaded board)")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  cmd->add_option("--max-runtime-s", o->max_runtime_s, "stop after this long (0 = until SIGINT / SIGTERM)")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
  cmd->add_flag("--quiet", o->quiet, "no progress lines on stderr");
  cmd->footer(
      "Prints one line at the end: messages and bytes written, and per sender (robot id or server) the messages "
      "recorded, missing and duplicated by the sequence numbers of their MAC trailers (read, not verified: the "
      "recorder needs no key). Unsigned traffic (--auth-key not given) is written but cannot be counted.\n"
      "Example: commerge record --out mission.lcmlog & ... ; kill -INT %1; lcm-logplayer mission.lcmlog");
  return {cmd, [o]() { return RunRecord(*o); }};
}

}  // namespace commerge::app
