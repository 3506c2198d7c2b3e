// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/status_codec.hpp"

#include <cmath>
#include <initializer_list>
#include <limits>
#include <string>
#include <tuple>
#include <utility>

#include "commerge/merge_result_t.hpp"
#include "commerge/robot_status_t.hpp"
#include "commerge/server_status_t.hpp"
#include "commerge/transfer_status_t.hpp"
#include "platform/lcm/codec_util.hpp"

namespace commerge::platform {

const char* const kStatusChannel = "COMMERGE_TRANSFER_STATUS";
const char* const kMergeResultChannel = "COMMERGE_MERGE_RESULT";
const char* const kRobotStatusChannel = "COMMERGE_ROBOT_STATUS";
const char* const kServerStatusChannel = "COMMERGE_SERVER_STATUS";

namespace {

static_assert(commerge::transfer_status_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::transfer_status_t::MAX_GAPS == static_cast<std::int32_t>(kMaxStatusGaps), "");
static_assert(commerge::transfer_status_t::MAX_POSE_ACKS == static_cast<std::int32_t>(kMaxStatusPoseAcks), "");
static_assert(commerge::transfer_status_t::MAX_MISSING == static_cast<std::int32_t>(kMaxStatusMissingRanges), "");
static_assert(commerge::merge_result_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::merge_result_t::MAX_ROBOTS == static_cast<std::int32_t>(kMaxMergeRobots), "");
static_assert(commerge::merge_result_t::MAX_PAIRS == static_cast<std::int32_t>(kMaxMergePairs), "");
static_assert(commerge::merge_result_t::MAX_TEXT_BYTES == static_cast<std::int32_t>(kMaxStatusTextBytes), "");
static_assert(commerge::robot_status_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::robot_status_t::MAX_MODULES == static_cast<std::int16_t>(kMaxStatusModules), "");
static_assert(commerge::robot_status_t::MAX_TEXT_BYTES == static_cast<std::int32_t>(kMaxStatusTextBytes), "");
static_assert(commerge::server_status_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::server_status_t::MAX_MODULES == static_cast<std::int16_t>(kMaxStatusModules), "");
static_assert(commerge::server_status_t::MAX_TEXT_BYTES == static_cast<std::int32_t>(kMaxStatusTextBytes), "");
static_assert(commerge::server_status_t::MAX_ROBOTS == static_cast<std::int32_t>(kMaxMergeRobots), "");
// Missing chunk ranges travel as int16 first chunk and count.
static_assert(kMaxChunksPerScan == static_cast<std::size_t>(std::numeric_limits<std::int16_t>::max()), "");

}  // namespace

using namespace lcm_detail;  // NOLINT(google-build-using-namespace): the shared helpers of platform/lcm

namespace {

Status CheckSize(std::size_t size, std::size_t max, MakeError make, const char* type, const char* field) {
  if (size > max) {
    return make(std::string(type) + ": " + field + " has " + std::to_string(size) + " entries (at most " +
                std::to_string(max) + ")");
  }
  return Status::Ok();
}

Status CheckSameSize(std::size_t size, std::size_t expected, MakeError make, const char* type, const char* field,
                     const char* per) {
  if (size != expected) {
    return make(std::string(type) + ": " + field + " has " + std::to_string(size) + " entries for " +
                std::to_string(expected) + " " + per + " (one each)");
  }
  return Status::Ok();
}

Status DecodeFlag(std::int8_t value, const char* type, const std::string& field, bool* out) {
  if (Status st = CheckFlag(value, DataLoss, type, field); !st.ok()) return st;
  *out = value == 1;
  return Status::Ok();
}

// ---- memory: the block robot_status_t and server_status_t share ----

Status ValidateMemory(const std::vector<ModuleMemory>& modules, MakeError make, const char* type) {
  if (Status st = CheckSize(modules.size(), kMaxStatusModules, make, type, "modules"); !st.ok()) return st;
  for (std::size_t i = 0; i < modules.size(); ++i) {
    if (Status st = CheckText(modules[i].name, make, type, Indexed("modules", i, "name")); !st.ok()) return st;
  }
  return Status::Ok();
}

// Plain = RobotStatus or ServerStatus, Lcm = robot_status_t or server_status_t (same member names).
template <typename Plain, typename Lcm>
void MemoryToWire(const Plain& m, Lcm* msg) {
  msg->peak_rss_bytes = m.peak_rss_bytes;
  msg->budget_total_bytes = m.budget_total_bytes;
  msg->budget_limit_bytes = m.budget_limit_bytes;
  msg->num_modules = static_cast<std::int16_t>(m.modules.size());
  for (const ModuleMemory& module : m.modules) {
    msg->module_name.push_back(module.name);
    msg->module_budget_bytes.push_back(module.budget_bytes);
    msg->module_used_bytes.push_back(module.used_bytes);
    msg->module_high_water_bytes.push_back(module.high_water_bytes);
  }
}

template <typename Lcm, typename Plain>
void MemoryFromWire(Lcm* msg, Plain* m) {
  m->peak_rss_bytes = msg->peak_rss_bytes;
  m->budget_total_bytes = msg->budget_total_bytes;
  m->budget_limit_bytes = msg->budget_limit_bytes;
  m->modules.resize(static_cast<std::size_t>(msg->num_modules));
  for (std::size_t i = 0; i < m->modules.size(); ++i) {
    m->modules[i].name = std::move(msg->module_name[i]);
    m->modules[i].budget_bytes = msg->module_budget_bytes[i];
    m->modules[i].used_bytes = msg->module_used_bytes[i];
    m->modules[i].high_water_bytes = msg->module_high_water_bytes[i];
  }
}

// num_modules (int16), module_name[], then three int64 arrays.
void WalkModules(WireWalker* w) {
  const std::int64_t n = w->Count(2, static_cast<std::int64_t>(kMaxStatusModules), "num_modules", 5 + 24);
  w->Strings(n, "module_name");
  w->Skip(24 * n, "module_budget_bytes, module_used_bytes, module_high_water_bytes");
}

// ---- transfer_status_t ----

constexpr const char* kTransferType = "transfer_status_t";

// The rules both sides enforce on the plain struct (`make`: InvalidArgument when encoding, DataLoss when
// decoding).
Status ValidateTransferStatus(const TransferStatus& m, MakeError make) {
  const char* type = kTransferType;
  if (Status st = CheckRobotIdAs(make, m.robot_id, type, "robot_id"); !st.ok()) return st;
  if (Status st = CheckSize(m.gaps.size(), kMaxStatusGaps, make, type, "gaps"); !st.ok()) return st;
  if (Status st = CheckSize(m.pose_sequences.size(), kMaxStatusPoseAcks, make, type, "pose_sequences"); !st.ok()) {
    return st;
  }
  if (Status st = CheckSize(m.missing.size(), kMaxStatusMissingRanges, make, type, "missing"); !st.ok()) return st;
  if (m.keyframes_contiguous > m.keyframes_seen) {
    return make(std::string(type) + ": keyframes_contiguous = " + std::to_string(m.keyframes_contiguous) +
                " is above keyframes_seen = " + std::to_string(m.keyframes_seen));
  }
  std::uint32_t lowest = m.keyframes_contiguous;  // where the next gap may begin
  for (std::size_t i = 0; i < m.gaps.size(); ++i) {
    const KeyframeGap& g = m.gaps[i];
    const std::string what = std::string(type) + ": " + Indexed("gaps", i) + " = [" + std::to_string(g.begin) +
                             ", " + std::to_string(g.end) + ")";
    if (g.begin >= g.end) return make(what + " is empty");
    if (g.begin < lowest) {
      return make(what + (i == 0 ? " begins below keyframes_contiguous" : " is not ascending and disjoint"));
    }
    if (g.end > m.keyframes_seen) return make(what + " ends beyond keyframes_seen");
    lowest = g.end;
  }
  for (std::size_t i = 0; i < m.missing.size(); ++i) {
    const MissingChunkRange& r = m.missing[i];
    const std::string what = std::string(type) + ": " + Indexed("missing", i) + " (keyframe " +
                             std::to_string(r.keyframe) + ", chunks " + std::to_string(r.first_chunk) + " + " +
                             std::to_string(r.count) + ")";
    if (static_cast<std::size_t>(r.first_chunk) + r.count > kMaxChunksPerScan) {
      return make(what + " reaches beyond chunk " + std::to_string(kMaxChunksPerScan));
    }
    if (i == 0) continue;
    const MissingChunkRange& p = m.missing[i - 1];
    if (r.keyframe < p.keyframe) return make(what + " is not ascending by keyframe");
    if (r.keyframe == p.keyframe &&
        (r.count == 0 || p.count == 0 ||
         static_cast<std::size_t>(r.first_chunk) < static_cast<std::size_t>(p.first_chunk) + p.count)) {
      return make(what + " overlaps or precedes the range before it of the same keyframe");
    }
  }
  return Status::Ok();
}

// ---- merge_result_t ----

constexpr const char* kMergeType = "merge_result_t";

Status ValidateMergeResult(const MergeResultMessage& m, MakeError make) {
  const char* type = kMergeType;
  const std::size_t n = m.robot_ids.size();
  if (Status st = CheckSize(n, kMaxMergeRobots, make, type, "robot_ids"); !st.ok()) return st;
  if (Status st = CheckSameSize(m.in_world.size(), n, make, type, "in_world", "robot_ids"); !st.ok()) return st;
  if (Status st = CheckSameSize(m.T_world_map.size(), n, make, type, "T_world_map", "robot_ids"); !st.ok()) {
    return st;
  }
  if (Status st = CheckSameSize(m.keyframes.size(), n, make, type, "keyframes", "robot_ids"); !st.ok()) return st;
  if (Status st = CheckSize(m.pairs.size(), kMaxMergePairs, make, type, "pairs"); !st.ok()) return st;
  for (std::size_t i = 0; i < n; ++i) {
    if (Status st = CheckRobotIdAs(make, m.robot_ids[i], type, Indexed("robot_ids", i)); !st.ok()) return st;
    if (i > 0 && m.robot_ids[i] <= m.robot_ids[i - 1]) {
      return make(std::string(type) + ": " + Indexed("robot_ids", i) + " = " + std::to_string(m.robot_ids[i]) +
                  " does not follow " + std::to_string(m.robot_ids[i - 1]) + " (ascending, unique)");
    }
    if (Status st = CheckFlag(m.in_world[i], make, type, Indexed("in_world", i)); !st.ok()) return st;
    if (!m.T_world_map[i].matrix().allFinite()) {
      return make(std::string(type) + ": " + Indexed("T_world_map", i) + " is not finite");
    }
  }
  for (std::size_t i = 0; i < m.pairs.size(); ++i) {
    const MergePairOutcome& p = m.pairs[i];
    if (Status st = CheckRobotIdAs(make, p.alpha, type, Indexed("pairs", i, "alpha")); !st.ok()) return st;
    if (Status st = CheckRobotIdAs(make, p.beta, type, Indexed("pairs", i, "beta")); !st.ok()) return st;
    if (Status st = CheckText(p.verdict, make, type, Indexed("pairs", i, "verdict")); !st.ok()) return st;
    if (!p.T_alpha_beta.matrix().allFinite()) {
      return make(std::string(type) + ": " + Indexed("pairs", i, "T_alpha_beta") + " is not finite");
    }
    if (!std::isfinite(p.overlap)) {
      return make(std::string(type) + ": " + Indexed("pairs", i, "overlap") + " is not finite");
    }
    for (const auto& [name, stage] : {std::make_pair("stage_b", &p.stage_b), std::make_pair("stage_c", &p.stage_c)}) {
      if (stage->status > kMaxStageSolverStatus) {
        return make(std::string(type) + ": " + Indexed("pairs", i, (std::string(name) + "_status").c_str()) + " = " +
                    std::to_string(stage->status) + " (0..3)");
      }
      if (!(stage->gap >= 0.0f && stage->gap <= 1.0f)) {
        return make(std::string(type) + ": " + Indexed("pairs", i, (std::string(name) + "_gap").c_str()) +
                    " is not in [0, 1]");
      }
    }
  }
  return Status::Ok();
}

// ---- robot_status_t / server_status_t ----

constexpr const char* kRobotType = "robot_status_t";
constexpr const char* kServerType = "server_status_t";

Status ValidateRobotStatus(const RobotStatus& m, MakeError make) {
  const char* type = kRobotType;
  if (Status st = CheckRobotIdAs(make, m.robot_id, type, "robot_id"); !st.ok()) return st;
  if (Status st = ValidateMemory(m.modules, make, type); !st.ok()) return st;
  return CheckText(m.state, make, type, "state");
}

Status ValidateServerStatus(const ServerStatus& m, MakeError make) {
  const char* type = kServerType;
  if (Status st = ValidateMemory(m.modules, make, type); !st.ok()) return st;
  if (Status st = CheckText(m.state, make, type, "state"); !st.ok()) return st;
  if (Status st = CheckText(m.last_rejection, make, type, "last_rejection"); !st.ok()) return st;
  const std::size_t n = m.robot_ids.size();
  if (Status st = CheckSize(n, kMaxMergeRobots, make, type, "robot_ids"); !st.ok()) return st;
  if (Status st = CheckSameSize(m.keyframes.size(), n, make, type, "keyframes", "robot_ids"); !st.ok()) return st;
  if (Status st = CheckSameSize(m.scans.size(), n, make, type, "scans", "robot_ids"); !st.ok()) return st;
  if (Status st = CheckSameSize(m.chunks_missing.size(), n, make, type, "chunks_missing", "robot_ids"); !st.ok()) {
    return st;
  }
  if (Status st = CheckSameSize(m.descriptor_ids.size(), n, make, type, "descriptor_ids", "robot_ids"); !st.ok()) {
    return st;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (Status st = CheckRobotIdAs(make, m.robot_ids[i], type, Indexed("robot_ids", i)); !st.ok()) return st;
  }
  if (Status st = CheckSize(m.pairs.size(), kMaxMergePairs, make, type, "pairs"); !st.ok()) return st;
  for (std::size_t i = 0; i < m.pairs.size(); ++i) {
    const ServerStatus::PairSolvers& p = m.pairs[i];
    if (Status st = CheckRobotIdAs(make, p.alpha, type, Indexed("pairs", i, "alpha")); !st.ok()) return st;
    if (Status st = CheckRobotIdAs(make, p.beta, type, Indexed("pairs", i, "beta")); !st.ok()) return st;
    if (Status st = CheckText(p.text, make, type, Indexed("pairs", i, "solvers")); !st.ok()) return st;
  }
  return Status::Ok();
}

// Named uint32 counters to and from their int32 wire fields (field name = prefix + name).
struct CounterToWire {
  const char* name;
  std::uint32_t value;
  std::int32_t* wire;
};
Status CountersToWire(std::initializer_list<CounterToWire> counters, const char* type, const std::string& prefix) {
  for (const CounterToWire& c : counters) {
    if (Status st = ToWireInt32(c.value, type, prefix + c.name, c.wire); !st.ok()) return st;
  }
  return Status::Ok();
}
struct CounterFromWire {
  const char* name;
  std::int32_t wire;
  std::uint32_t* value;
};
Status CountersFromWire(std::initializer_list<CounterFromWire> counters, const char* type, const std::string& prefix) {
  for (const CounterFromWire& c : counters) {
    if (Status st = FromWireInt32(c.wire, type, prefix + c.name, c.value); !st.ok()) return st;
  }
  return Status::Ok();
}

// uint32 per-robot counters to and from int32 arrays.
Status ArrayToWire(const std::vector<std::uint32_t>& values, const char* type, const char* field,
                      std::vector<std::int32_t>* out) {
  out->resize(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (Status st = ToWireInt32(values[i], type, Indexed(field, i), &(*out)[i]); !st.ok()) return st;
  }
  return Status::Ok();
}
Status ArrayFromWire(const std::vector<std::int32_t>& values, const char* type, const char* field,
                        std::vector<std::uint32_t>* out) {
  out->resize(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (Status st = FromWireInt32(values[i], type, Indexed(field, i), &(*out)[i]); !st.ok()) return st;
  }
  return Status::Ok();
}

}  // namespace

// ---- TransferStatus ----

Status EncodeTransferStatus(const TransferStatus& m, std::vector<std::uint8_t>* out) {
  const char* type = kTransferType;
  if (Status st = ValidateTransferStatus(m, InvalidArgument); !st.ok()) return st;
  commerge::transfer_status_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.server_session = m.server_session;
  msg.robot_session = m.robot_session;
  if (Status st = ToWireInt32(m.keyframes_contiguous, type, "keyframes_contiguous", &msg.keyframes_contiguous);
      !st.ok()) {
    return st;
  }
  if (Status st = ToWireInt32(m.keyframes_seen, type, "keyframes_seen", &msg.keyframes_seen); !st.ok()) return st;
  // The gaps lie below keyframes_seen, which fits int32.
  msg.num_gaps = static_cast<std::int32_t>(m.gaps.size());
  for (const KeyframeGap& g : m.gaps) {
    msg.gap_begin.push_back(static_cast<std::int32_t>(g.begin));
    msg.gap_end.push_back(static_cast<std::int32_t>(g.end));
  }
  msg.gaps_truncated = m.gaps_truncated ? 1 : 0;
  msg.num_pose_acks = static_cast<std::int32_t>(m.pose_sequences.size());
  msg.pose_sequences = m.pose_sequences;
  msg.request_id = m.request_id;
  msg.request_complete = m.request_complete ? 1 : 0;
  msg.num_missing = static_cast<std::int32_t>(m.missing.size());
  msg.missing_keyframe.resize(m.missing.size());
  for (std::size_t i = 0; i < m.missing.size(); ++i) {
    const MissingChunkRange& r = m.missing[i];
    if (Status st = ToWireInt32(r.keyframe, type, Indexed("missing", i, "keyframe"), &msg.missing_keyframe[i]);
        !st.ok()) {
      return st;
    }
    // first_chunk + count <= 32767 (validated), so both fit int16.
    msg.missing_first_chunk.push_back(static_cast<std::int16_t>(r.first_chunk));
    msg.missing_count.push_back(static_cast<std::int16_t>(r.count));
  }
  return EncodeInto(msg, out, type);
}

Result<TransferStatus> DecodeTransferStatus(Span<const std::uint8_t> bytes) {
  const char* type = kTransferType;
  // After the hash: utime 8, robot_id 2, server_session 8, robot_session 8, keyframes_contiguous 4,
  // keyframes_seen 4, num_gaps 4.
  if (Status st = CheckHeader<commerge::transfer_status_t>(bytes, 38, type); !st.ok()) return st;
  WireWalker w(bytes, type);
  w.Skip(34, "the header");
  const std::int64_t gaps = w.Count(4, static_cast<std::int64_t>(kMaxStatusGaps), "num_gaps", 8);
  w.Skip(8 * gaps, "gap_begin, gap_end");
  w.Skip(1, "gaps_truncated");
  const std::int64_t acks = w.Count(4, static_cast<std::int64_t>(kMaxStatusPoseAcks), "num_pose_acks", 4);
  w.Skip(4 * acks, "pose_sequences");
  w.Skip(4 + 1, "request_id, request_complete");
  const std::int64_t missing = w.Count(4, static_cast<std::int64_t>(kMaxStatusMissingRanges), "num_missing", 8);
  w.Skip(8 * missing, "missing_keyframe, missing_first_chunk, missing_count");
  if (Status st = w.Finish(); !st.ok()) return st;
  commerge::transfer_status_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;

  TransferStatus m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.server_session = msg.server_session;
  m.robot_session = msg.robot_session;
  if (Status st = FromWireInt32(msg.keyframes_contiguous, type, "keyframes_contiguous", &m.keyframes_contiguous);
      !st.ok()) {
    return st;
  }
  if (Status st = FromWireInt32(msg.keyframes_seen, type, "keyframes_seen", &m.keyframes_seen); !st.ok()) return st;
  m.gaps.resize(static_cast<std::size_t>(gaps));
  for (std::size_t i = 0; i < m.gaps.size(); ++i) {
    if (Status st = FromWireInt32(msg.gap_begin[i], type, Indexed("gap_begin", i), &m.gaps[i].begin); !st.ok()) {
      return st;
    }
    if (Status st = FromWireInt32(msg.gap_end[i], type, Indexed("gap_end", i), &m.gaps[i].end); !st.ok()) return st;
  }
  if (Status st = DecodeFlag(msg.gaps_truncated, type, "gaps_truncated", &m.gaps_truncated); !st.ok()) return st;
  m.pose_sequences = std::move(msg.pose_sequences);
  m.request_id = msg.request_id;
  if (Status st = DecodeFlag(msg.request_complete, type, "request_complete", &m.request_complete); !st.ok()) {
    return st;
  }
  m.missing.resize(static_cast<std::size_t>(missing));
  for (std::size_t i = 0; i < m.missing.size(); ++i) {
    MissingChunkRange& r = m.missing[i];
    std::uint32_t first = 0, count = 0;
    if (Status st = FromWireInt32(msg.missing_keyframe[i], type, Indexed("missing_keyframe", i), &r.keyframe);
        !st.ok()) {
      return st;
    }
    if (Status st = FromWireInt32(msg.missing_first_chunk[i], type, Indexed("missing_first_chunk", i), &first);
        !st.ok()) {
      return st;
    }
    if (Status st = FromWireInt32(msg.missing_count[i], type, Indexed("missing_count", i), &count); !st.ok()) {
      return st;
    }
    r.first_chunk = static_cast<std::uint16_t>(first);  // 0..32767
    r.count = static_cast<std::uint16_t>(count);
  }
  if (Status st = ValidateTransferStatus(m, DataLoss); !st.ok()) return st;
  return m;
}

// ---- MergeResultMessage ----

Status EncodeMergeResult(const MergeResultMessage& m, std::vector<std::uint8_t>* out) {
  const char* type = kMergeType;
  if (Status st = ValidateMergeResult(m, InvalidArgument); !st.ok()) return st;
  commerge::merge_result_t msg{};
  msg.utime = m.utime_us;
  msg.server_session = m.server_session;
  msg.round = m.round;
  const std::size_t n = m.robot_ids.size();
  msg.num_robots = static_cast<std::int32_t>(n);
  msg.translation_m.resize(n);
  msg.quaternion.resize(n);
  msg.keyframes.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    msg.robot_id.push_back(static_cast<std::int16_t>(m.robot_ids[i]));
    msg.in_world.push_back(static_cast<std::int8_t>(m.in_world[i]));
    PoseToWire(m.T_world_map[i], &msg.translation_m[i], &msg.quaternion[i]);
    if (Status st = CountersToWire({{"keyframes", m.keyframes[i], &msg.keyframes[i]}}, type, Indexed("robots", i) + ".");
        !st.ok()) {
      return st;
    }
  }
  const std::size_t np = m.pairs.size();
  msg.num_pairs = static_cast<std::int32_t>(np);
  msg.pair_translation_m.resize(np);
  msg.pair_quaternion.resize(np);
  msg.loops_stage_a.resize(np);
  msg.loops_stage_c.resize(np);
  msg.alpha_scans.resize(np);
  msg.beta_scans.resize(np);
  msg.inliers.resize(np);
  msg.stage_b_nodes.resize(np);
  msg.stage_b_lp_solves.resize(np);
  msg.stage_c_nodes.resize(np);
  msg.stage_c_lp_solves.resize(np);
  msg.stage_c_loops_dropped.resize(np);
  for (std::size_t i = 0; i < np; ++i) {
    const MergePairOutcome& p = m.pairs[i];
    msg.alpha.push_back(static_cast<std::int16_t>(p.alpha));
    msg.beta.push_back(static_cast<std::int16_t>(p.beta));
    msg.success.push_back(p.success ? 1 : 0);
    msg.verdict.push_back(p.verdict);
    PoseToWire(p.T_alpha_beta, &msg.pair_translation_m[i], &msg.pair_quaternion[i]);
    if (Status st = CountersToWire({{"loops_stage_a", p.loops_stage_a, &msg.loops_stage_a[i]},
                                    {"loops_stage_c", p.loops_stage_c, &msg.loops_stage_c[i]},
                                    {"alpha_scans", p.alpha_scans, &msg.alpha_scans[i]},
                                    {"beta_scans", p.beta_scans, &msg.beta_scans[i]},
                                    {"inliers", p.inliers, &msg.inliers[i]},
                                    {"stage_b_nodes", p.stage_b.nodes, &msg.stage_b_nodes[i]},
                                    {"stage_b_lp_solves", p.stage_b.lp_solves, &msg.stage_b_lp_solves[i]},
                                    {"stage_c_nodes", p.stage_c.nodes, &msg.stage_c_nodes[i]},
                                    {"stage_c_lp_solves", p.stage_c.lp_solves, &msg.stage_c_lp_solves[i]},
                                    {"stage_c_loops_dropped", p.stage_c_loops_dropped, &msg.stage_c_loops_dropped[i]}},
                                   type, Indexed("pairs", i) + ".");
        !st.ok()) {
      return st;
    }
    msg.overlap.push_back(p.overlap);
    msg.consistent.push_back(p.consistent ? 1 : 0);
    msg.stage_b_status.push_back(static_cast<std::int8_t>(p.stage_b.status));
    msg.stage_b_gap.push_back(p.stage_b.gap);
    msg.stage_c_status.push_back(static_cast<std::int8_t>(p.stage_c.status));
    msg.stage_c_gap.push_back(p.stage_c.gap);
  }
  return EncodeInto(msg, out, type);
}

Result<MergeResultMessage> DecodeMergeResult(Span<const std::uint8_t> bytes) {
  const char* type = kMergeType;
  // After the hash: utime 8, server_session 8, round 4, num_robots 4.
  if (Status st = CheckHeader<commerge::merge_result_t>(bytes, 24, type); !st.ok()) return st;
  WireWalker w(bytes, type);
  w.Skip(20, "the header");
  // Per robot: robot_id 2, in_world 1, translation_m 12, quaternion 16, keyframes 4.
  const std::int64_t n = w.Count(4, static_cast<std::int64_t>(kMaxMergeRobots), "num_robots", 35);
  w.Skip(35 * n, "robot_id, in_world, translation_m, quaternion, keyframes");
  // Per pair: alpha 2, beta 2, success 1, verdict >= 5, then 12 + 16 + 4 x 4 + 4 + 4 + 1 = 53, then the solver
  // stages 2 x (1 + 4 + 4 + 4) + 4 = 30.
  const std::int64_t np = w.Count(4, static_cast<std::int64_t>(kMaxMergePairs), "num_pairs", 5 + 5 + 53 + 30);
  w.Skip(5 * np, "alpha, beta, success");
  w.Strings(np, "verdict");
  w.Skip((53 + 30) * np, "the per-pair arrays after verdict");
  if (Status st = w.Finish(); !st.ok()) return st;
  commerge::merge_result_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;

  MergeResultMessage m;
  m.utime_us = msg.utime;
  m.server_session = msg.server_session;
  m.round = msg.round;
  m.robot_ids.assign(msg.robot_id.begin(), msg.robot_id.end());
  m.T_world_map.resize(static_cast<std::size_t>(n));
  m.keyframes.resize(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < m.T_world_map.size(); ++i) {
    if (Status st = CountersFromWire({{"keyframes", msg.keyframes[i], &m.keyframes[i]}}, type, Indexed("robots", i) + ".");
        !st.ok()) {
      return st;
    }
    if (Status st = CheckFlag(msg.in_world[i], DataLoss, type, Indexed("in_world", i)); !st.ok()) return st;
    m.in_world.push_back(static_cast<std::uint8_t>(msg.in_world[i]));
    if (!PoseFromWire(msg.translation_m[i], msg.quaternion[i], &m.T_world_map[i])) {
      return DataLoss(std::string(type) + ": " + Indexed("T_world_map", i) +
                      " has a non-finite value or a quaternion that is not unit");
    }
  }
  m.pairs.resize(static_cast<std::size_t>(np));
  for (std::size_t i = 0; i < m.pairs.size(); ++i) {
    MergePairOutcome& p = m.pairs[i];
    p.alpha = msg.alpha[i];
    p.beta = msg.beta[i];
    if (Status st = DecodeFlag(msg.success[i], type, Indexed("pairs", i, "success"), &p.success); !st.ok()) return st;
    p.verdict = std::move(msg.verdict[i]);
    if (!PoseFromWire(msg.pair_translation_m[i], msg.pair_quaternion[i], &p.T_alpha_beta)) {
      return DataLoss(std::string(type) + ": " + Indexed("pairs", i, "T_alpha_beta") +
                      " has a non-finite value or a quaternion that is not unit");
    }
    if (Status st = CountersFromWire({{"loops_stage_a", msg.loops_stage_a[i], &p.loops_stage_a},
                                      {"loops_stage_c", msg.loops_stage_c[i], &p.loops_stage_c},
                                      {"alpha_scans", msg.alpha_scans[i], &p.alpha_scans},
                                      {"beta_scans", msg.beta_scans[i], &p.beta_scans},
                                      {"inliers", msg.inliers[i], &p.inliers},
                                      {"stage_b_nodes", msg.stage_b_nodes[i], &p.stage_b.nodes},
                                      {"stage_b_lp_solves", msg.stage_b_lp_solves[i], &p.stage_b.lp_solves},
                                      {"stage_c_nodes", msg.stage_c_nodes[i], &p.stage_c.nodes},
                                      {"stage_c_lp_solves", msg.stage_c_lp_solves[i], &p.stage_c.lp_solves},
                                      {"stage_c_loops_dropped", msg.stage_c_loops_dropped[i], &p.stage_c_loops_dropped}},
                                     type, Indexed("pairs", i) + ".");
        !st.ok()) {
      return st;
    }
    for (const auto& [name, wire_status, stage] :
         {std::make_tuple("stage_b_status", msg.stage_b_status[i], &p.stage_b),
          std::make_tuple("stage_c_status", msg.stage_c_status[i], &p.stage_c)}) {
      if (wire_status < 0 || wire_status > static_cast<std::int8_t>(kMaxStageSolverStatus)) {
        return DataLoss(std::string(type) + ": " + Indexed("pairs", i, name) + " = " + std::to_string(wire_status) +
                        " (0..3)");
      }
      stage->status = static_cast<std::uint8_t>(wire_status);
    }
    p.stage_b.gap = msg.stage_b_gap[i];
    p.stage_c.gap = msg.stage_c_gap[i];
    p.overlap = msg.overlap[i];
    if (Status st = DecodeFlag(msg.consistent[i], type, Indexed("pairs", i, "consistent"), &p.consistent);
        !st.ok()) {
      return st;
    }
  }
  if (Status st = ValidateMergeResult(m, DataLoss); !st.ok()) return st;
  return m;
}

// ---- RobotStatus ----

Status EncodeRobotStatus(const RobotStatus& m, std::vector<std::uint8_t>* out) {
  const char* type = kRobotType;
  if (Status st = ValidateRobotStatus(m, InvalidArgument); !st.ok()) return st;
  commerge::robot_status_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.session = m.session;
  MemoryToWire(m, &msg);
  if (Status st = CountersToWire({{"keyframes", m.keyframes, &msg.keyframes},
                                  {"keyframes_acked", m.keyframes_acked, &msg.keyframes_acked},
                                  {"queued_keyframes", m.queued_keyframes, &msg.queued_keyframes},
                                  {"queued_poses", m.queued_poses, &msg.queued_poses},
                                  {"queued_chunks", m.queued_chunks, &msg.queued_chunks}},
                                 type, "");
      !st.ok()) {
    return st;
  }
  msg.bytes_sent = m.bytes_sent;
  msg.bytes_resent = m.bytes_resent;
  msg.request_id = m.request_id;
  msg.state = m.state;
  return EncodeInto(msg, out, type);
}

Result<RobotStatus> DecodeRobotStatus(Span<const std::uint8_t> bytes) {
  const char* type = kRobotType;
  // After the hash: utime 8, robot_id 2, session 8, peak_rss_bytes 8, budget_total_bytes 8, budget_limit_bytes 8,
  // num_modules 2.
  if (Status st = CheckHeader<commerge::robot_status_t>(bytes, 44, type); !st.ok()) return st;
  WireWalker w(bytes, type);
  w.Skip(42, "the header");
  WalkModules(&w);
  w.Skip(5 * 4 + 2 * 8 + 4, "keyframes .. request_id");
  w.String("state");
  if (Status st = w.Finish(); !st.ok()) return st;
  commerge::robot_status_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;

  RobotStatus m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.session = msg.session;
  MemoryFromWire(&msg, &m);
  if (Status st = CountersFromWire({{"keyframes", msg.keyframes, &m.keyframes},
                                    {"keyframes_acked", msg.keyframes_acked, &m.keyframes_acked},
                                    {"queued_keyframes", msg.queued_keyframes, &m.queued_keyframes},
                                    {"queued_poses", msg.queued_poses, &m.queued_poses},
                                    {"queued_chunks", msg.queued_chunks, &m.queued_chunks}},
                                   type, "");
      !st.ok()) {
    return st;
  }
  m.bytes_sent = msg.bytes_sent;
  m.bytes_resent = msg.bytes_resent;
  m.request_id = msg.request_id;
  m.state = std::move(msg.state);
  if (Status st = ValidateRobotStatus(m, DataLoss); !st.ok()) return st;
  return m;
}

// ---- ServerStatus ----

Status EncodeServerStatus(const ServerStatus& m, std::vector<std::uint8_t>* out) {
  const char* type = kServerType;
  if (Status st = ValidateServerStatus(m, InvalidArgument); !st.ok()) return st;
  commerge::server_status_t msg{};
  msg.utime = m.utime_us;
  msg.session = m.session;
  MemoryToWire(m, &msg);
  msg.round = m.round;
  msg.state = m.state;
  msg.bytes_received = m.bytes_received;
  msg.messages_rejected = m.messages_rejected;
  msg.last_rejection = m.last_rejection;
  msg.num_robots = static_cast<std::int32_t>(m.robot_ids.size());
  msg.robot_id.assign(m.robot_ids.begin(), m.robot_ids.end());  // 0..63 (validated)
  if (Status st = ArrayToWire(m.keyframes, type, "keyframes", &msg.keyframes); !st.ok()) return st;
  if (Status st = ArrayToWire(m.scans, type, "scans", &msg.scans); !st.ok()) return st;
  if (Status st = ArrayToWire(m.chunks_missing, type, "chunks_missing", &msg.chunks_missing); !st.ok()) return st;
  for (std::uint32_t id : m.descriptor_ids) msg.descriptor_id.push_back(static_cast<std::int32_t>(id));  // the bits
  msg.num_pairs = static_cast<std::int32_t>(m.pairs.size());
  for (const ServerStatus::PairSolvers& p : m.pairs) {
    msg.pair_alpha.push_back(static_cast<std::int16_t>(p.alpha));  // 0..63 (validated)
    msg.pair_beta.push_back(static_cast<std::int16_t>(p.beta));
    msg.pair_solvers.push_back(p.text);
  }
  return EncodeInto(msg, out, type);
}

Result<ServerStatus> DecodeServerStatus(Span<const std::uint8_t> bytes) {
  const char* type = kServerType;
  // After the hash: utime 8, session 8, peak_rss_bytes 8, budget_total_bytes 8, budget_limit_bytes 8,
  // num_modules 2.
  if (Status st = CheckHeader<commerge::server_status_t>(bytes, 42, type); !st.ok()) return st;
  WireWalker w(bytes, type);
  w.Skip(40, "the header");
  WalkModules(&w);
  w.Skip(4, "round");
  w.String("state");
  w.Skip(16, "bytes_received, messages_rejected");
  w.String("last_rejection");
  // Per robot: robot_id 2, keyframes 4, scans 4, chunks_missing 4, descriptor_id 4.
  const std::int64_t n = w.Count(4, static_cast<std::int64_t>(kMaxMergeRobots), "num_robots", 18);
  w.Skip(18 * n, "robot_id, keyframes, scans, chunks_missing, descriptor_id");
  // Per pair: pair_alpha 2, pair_beta 2, pair_solvers >= 5.
  const std::int64_t np = w.Count(4, static_cast<std::int64_t>(kMaxMergePairs), "num_pairs", 4 + 5);
  w.Skip(4 * np, "pair_alpha, pair_beta");
  w.Strings(np, "pair_solvers");
  if (Status st = w.Finish(); !st.ok()) return st;
  commerge::server_status_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;

  ServerStatus m;
  m.utime_us = msg.utime;
  m.session = msg.session;
  MemoryFromWire(&msg, &m);
  m.round = msg.round;
  m.state = std::move(msg.state);
  m.bytes_received = msg.bytes_received;
  m.messages_rejected = msg.messages_rejected;
  m.last_rejection = std::move(msg.last_rejection);
  m.robot_ids.assign(msg.robot_id.begin(), msg.robot_id.end());
  if (Status st = ArrayFromWire(msg.keyframes, type, "keyframes", &m.keyframes); !st.ok()) return st;
  if (Status st = ArrayFromWire(msg.scans, type, "scans", &m.scans); !st.ok()) return st;
  if (Status st = ArrayFromWire(msg.chunks_missing, type, "chunks_missing", &m.chunks_missing); !st.ok()) {
    return st;
  }
  for (std::int32_t id : msg.descriptor_id) m.descriptor_ids.push_back(static_cast<std::uint32_t>(id));
  for (std::size_t i = 0; i < static_cast<std::size_t>(np); ++i) {
    m.pairs.push_back({msg.pair_alpha[i], msg.pair_beta[i], std::move(msg.pair_solvers[i])});
  }
  if (Status st = ValidateServerStatus(m, DataLoss); !st.ok()) return st;
  return m;
}

}  // namespace commerge::platform
