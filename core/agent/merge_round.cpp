// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/merge_round.hpp"

#include <algorithm>
#include <chrono>
#include <string>
#include <utility>

#include "core/common/number_text.hpp"

namespace commerge {

namespace {

double RoundSecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

void KeepVerifiedPairs(int round, Span<const std::int64_t> sessions, std::vector<VerifiedPair>* verified,
                       std::vector<PairMergeResult>* results) {
  auto session_of = [&](int robot) {
    return robot >= 0 && static_cast<std::size_t>(robot) < sessions.size() ? sessions[static_cast<std::size_t>(robot)]
                                                                           : std::int64_t{0};
  };
  for (PairMergeResult& p : *results) {
    auto it = std::find_if(verified->begin(), verified->end(), [&](const VerifiedPair& v) {
      return v.result.alpha == p.alpha && v.result.beta == p.beta;
    });
    const std::int64_t alpha_session = session_of(p.alpha), beta_session = session_of(p.beta);
    if (p.attempted && p.registration.success()) {
      VerifiedPair v{p, round, alpha_session, beta_session};
      if (it == verified->end()) {
        verified->push_back(std::move(v));
      } else {
        *it = std::move(v);
      }
      continue;
    }
    if (p.alpha_missing + p.beta_missing == 0 || it == verified->end()) continue;
    if (it->alpha_session != alpha_session || it->beta_session != beta_session || alpha_session == 0 ||
        beta_session == 0) {
      continue;  // a robot restarted since: its map frame is new
    }
    std::string why = p.attempted ? "refused with " + std::to_string(p.alpha_missing + p.beta_missing) +
                                        " selected scans missing: " + p.reason
                                  : p.reason;
    PairMergeResult kept = it->result;
    kept.kept_from_round = it->round;
    kept.reason = "kept from round " + std::to_string(it->round) + " (this round: " + why + ")";
    if (kept.reason.size() > 255) kept.reason.resize(255);  // merge_result_t's text limit
    p = std::move(kept);
  }
}

bool MergeRoundResult::in_world(int robot) const {
  return frames_ok && robot >= 0 && static_cast<std::size_t>(robot) < frames.robots.size() &&
         frames.robots[static_cast<std::size_t>(robot)].connected_to_robot0;
}

Eigen::Isometry3d MergeRoundResult::T_world_map(int robot) const {
  return in_world(robot) ? frames.robots[static_cast<std::size_t>(robot)].T_world_map : Eigen::Isometry3d::Identity();
}

MergeRound::MergeRound(MergeServer* server, const MergeRoundParams& params) : server_(server), params_(params) {}

void MergeRound::Request(const std::vector<ScanRequest>& planned, std::uint64_t predicted_bytes,
                         std::vector<ScanRequest>* requests) {
  requests->clear();
  for (const ScanRequest& p : planned) {
    ScanRequest q;
    q.robot_id = p.robot_id;
    for (std::uint32_t k : p.keyframes) {  // scans held from earlier rounds (or modes) are not asked again
      if (!server_->has_scan(p.robot_id, k)) q.keyframes.push_back(k);
    }
    if (q.keyframes.empty()) continue;
    q.request_id = next_request_id_++;
    requests->push_back(q);
    current_.plan.requests.push_back(std::move(q));
  }
  current_.plan.predicted_scan_bytes += predicted_bytes;
}

Status MergeRound::Begin(Span<const std::int64_t> sessions, std::vector<ScanRequest>* requests) {
  requests->clear();
  active_ = false;
  if (params_.run_cascades) {
    if (Status st = server_->RunCascades(); !st.ok()) return st;
  }
  // Step 2: the plan of the mode; its requests name only the scans the server does not hold.
  auto plan = server_->Plan(params_.mode);
  if (!plan.ok()) return plan.status();
  current_ = MergeRoundResult();
  current_.round = rounds_finished_ + 1;
  current_.plan.mode = plan->mode;
  current_.plan.pairs = plan->pairs;
  current_.plan.selected_scans = plan->selected_scans;
  current_.plan.padded_scans = plan->padded_scans;
  sessions_.assign(sessions.begin(), sessions.end());
  widen_step_ = 0;
  pending_ = plan->pairs;
  Request(plan->requests, plan->predicted_scan_bytes, requests);
  active_ = true;
  return Status::Ok();
}

Status MergeRound::Register(const std::vector<PairSelection>& selections) {
  // Step 3: submaps from the received scans, coarse-to-fine registration.
  for (const PairSelection& sel : selections) {
    const auto t0 = std::chrono::steady_clock::now();
    auto merged = server_->MergePair(sel);
    if (!merged.ok()) return merged.status();
    const double seconds = RoundSecondsSince(t0);
    std::size_t i = 0;
    while (i < current_.pairs.size() && !(current_.pairs[i].alpha == sel.alpha && current_.pairs[i].beta == sel.beta)) {
      ++i;
    }
    if (i == current_.pairs.size()) {
      current_.pairs.emplace_back();
      current_.widenings.push_back(0);
      current_.registration_s.push_back(0.0);
    } else {
      ++current_.widenings[i];
    }
    current_.registration_s[i] += seconds;
    current_.pairs[i] = std::move(*merged);
    if (observer_ != nullptr) observer_->OnPairRegistered(current_.pairs[i]);
  }
  return Status::Ok();
}

Result<bool> MergeRound::Continue(std::vector<ScanRequest>* requests) {
  requests->clear();
  if (!active_) return InvalidArgument("MergeRound::Continue without a round begun (call Begin first)");
  Status st = Register(pending_);
  pending_.clear();
  // Step 4: widening. Pairs that registration refused ask for more of stage A's scans and register again.
  while (st.ok() && widen_step_ < server_->params().max_widen_steps) {
    auto wider = server_->WidenPlan(current_.plan, Span<const PairMergeResult>(current_.pairs), next_request_id_);
    if (!wider.ok()) {
      st = wider.status();
      break;
    }
    if (wider->pairs.empty()) break;
    ++widen_step_;
    widened_selections_ += wider->pairs.size();
    AdoptSelections(Span<const PairSelection>(wider->pairs), &current_.plan.pairs);
    Request(wider->requests, wider->predicted_scan_bytes, requests);
    for (const ScanRequest& q : *requests) current_.widened_scans += q.keyframes.size();
    if (!requests->empty()) {  // wait for the extra scans, then register these pairs again
      pending_ = std::move(wider->pairs);
      return false;
    }
    st = Register(wider->pairs);  // every scan is held already
  }
  if (st.ok()) st = Finish();
  active_ = false;
  if (!st.ok()) return st;
  return true;
}

Status MergeRound::Finish() {
  // Step 5: a pair this round could not judge for missing scans keeps what an earlier round verified.
  KeepVerifiedPairs(current_.round, Span<const std::int64_t>(sessions_), &verified_, &current_.pairs);
  // Step 6: one frame per robot; pairs inconsistent with the rest are rejected.
  auto frames = server_->SolveFrames(Span<const PairMergeResult>(current_.pairs));
  if (frames.ok()) {
    current_.frames_ok = true;
    current_.frames = std::move(*frames);
  } else {
    current_.frames_error = frames.status().message();
  }
  ++rounds_finished_;
  result_ = std::move(current_);
  current_ = MergeRoundResult();
  return Status::Ok();
}

namespace {

constexpr std::int64_t kMaxWireCount = 2147483647;  // int32 wire counters saturate here

std::uint32_t SaturatedCount(std::int64_t count) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>(count, 0, kMaxWireCount));
}
std::uint32_t SaturatedCount(std::size_t count) {
  return static_cast<std::uint32_t>(std::min<std::size_t>(count, static_cast<std::size_t>(kMaxWireCount)));
}

StageSolverSummary SummariseStage(const StageSolverOutcome& o) {
  StageSolverSummary s;
  if (!o.ran) return s;
  s.status = o.no_selection ? 3 : (o.limit_hit ? 2 : 1);
  s.gap = static_cast<float>(std::clamp(o.gap, 0.0, 1.0));
  s.nodes = SaturatedCount(o.nodes);
  s.lp_solves = SaturatedCount(o.lp_solves);
  return s;
}

}  // namespace

std::string StageSolverText(const char* stage, const StageSolverSummary& s) {
  std::string text = std::string(stage) + " ";
  switch (s.status) {
    case 0: return text + "not run";
    case 1: text += "optimal"; break;
    case 2: text += "limit, gap " + FormatFixed(100.0 * static_cast<double>(s.gap), 2) + " %"; break;
    case 3: text += "no selection"; break;
    default: return text + "status " + std::to_string(s.status);
  }
  text += ", " + std::to_string(s.nodes) + (s.nodes == 1 ? " node, " : " nodes, ") + std::to_string(s.lp_solves) +
          (s.lp_solves == 1 ? " LP" : " LPs");
  return text;
}

MergeResultMessage MakeMergeResultMessage(const MergeRoundResult& round, const MergeServer& server,
                                          Span<const int> robot_ids, Span<const std::uint32_t> keyframes,
                                          std::int64_t server_session, std::int64_t utime_us) {
  MergeResultMessage m;
  m.utime_us = utime_us;
  m.server_session = server_session;
  m.round = round.round;
  for (std::size_t i = 0; i < robot_ids.size(); ++i) {
    const int r = robot_ids[i];
    m.robot_ids.push_back(r);
    m.in_world.push_back(round.in_world(r) ? 1 : 0);
    m.T_world_map.push_back(round.T_world_map(r));
    m.keyframes.push_back(i < keyframes.size() ? keyframes[i] : 0);
  }
  std::size_t measurement = 0;  // SolveFrames numbers the successful pairs in order
  for (const PairMergeResult& p : round.pairs) {
    MergePairOutcome o;
    o.alpha = p.alpha;
    o.beta = p.beta;
    o.success = p.attempted && p.registration.success();
    o.verdict = !p.attempted || p.kept_from_round > 0 ? p.reason : RegistrationVerdictName(p.registration.verdict);
    o.T_alpha_beta = o.success ? p.registration.T_target_source : Eigen::Isometry3d::Identity();
    o.alpha_scans = static_cast<std::uint32_t>(p.alpha_scans);
    o.beta_scans = static_cast<std::uint32_t>(p.beta_scans);
    o.overlap = static_cast<float>(p.registration.overlap_ratio);
    o.inliers = static_cast<std::uint32_t>(p.registration.num_fine_inliers);
    if (const ExchangeCascadeResult* c = server.cascade(p.alpha, p.beta)) {
      o.loops_stage_a = static_cast<std::uint32_t>(c->stage_a.cells.size());
      o.loops_stage_c = static_cast<std::uint32_t>(c->stage_c.selected_loops.size());
      o.stage_b = SummariseStage(StageBOutcome(*c));
      o.stage_c = SummariseStage(StageCOutcome(*c));
      o.stage_c_loops_dropped = SaturatedCount(c->stage_c.loops_dropped);
    }
    if (o.success && round.frames_ok && measurement < round.frames.measurements.size()) {
      o.consistent = round.frames.measurements[measurement].verdict != MeasurementVerdict::kRejected;
      ++measurement;
    }
    m.pairs.push_back(std::move(o));
  }
  return m;
}

}  // namespace commerge
