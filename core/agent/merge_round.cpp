// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/merge_round.hpp"

#include <algorithm>
#include <chrono>
#include <string>
#include <utility>

#include "core/agent/pair_refinement.hpp"
#include "core/common/number_text.hpp"

namespace commerge {

namespace {

double RoundSecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool MergeRoundResult::in_world(int robot) const {
  return frames_ok && robot >= 0 && static_cast<std::size_t>(robot) < frames.robots.size() &&
         frames.robots[static_cast<std::size_t>(robot)].connected_to_robot0;
}

Eigen::Isometry3d MergeRoundResult::T_world_map(int robot) const {
  return in_world(robot) ? frames.robots[static_cast<std::size_t>(robot)].T_world_map : Eigen::Isometry3d::Identity();
}

MergeRound::MergeRound(MergeServer* server, const MergeRoundParams& params) : server_(server), params_(params) {}

const PairHistory* MergeRound::history(int alpha, int beta) const {
  for (const PairHistory& h : histories_) {
    if (h.alpha == alpha && h.beta == beta) return &h;
  }
  return nullptr;
}

PairHistory* MergeRound::MutableHistory(int alpha, int beta) {
  return const_cast<PairHistory*>(history(alpha, beta));
}

RobotPoses MergeRound::PosesOf(int robot) const {
  if (robot < 0 || robot >= server_->max_robots()) return RobotPoses{};
  const RobotKeyframeDb& db = server_->robot(robot);
  return RobotPoses{Span<const Eigen::Isometry3d>(db.T_map_sensor), Span<const std::uint8_t>(db.pose_known)};
}

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

void MergeRound::AttributeRequests(const std::vector<Job>& jobs, const std::vector<ScanRequest>& requests,
                                   bool widened) {
  std::vector<std::pair<int, std::uint32_t>> open;
  for (const ScanRequest& q : requests) {
    for (std::uint32_t k : q.keyframes) open.emplace_back(q.robot_id, k);
  }
  std::sort(open.begin(), open.end());
  for (const Job& job : jobs) {
    std::size_t n = 0;
    for (const auto& [robot, keyframes] : {std::make_pair(job.selection.alpha, &job.selection.alpha_keyframes),
                                           std::make_pair(job.selection.beta, &job.selection.beta_keyframes)}) {
      for (std::uint32_t k : *keyframes) {
        auto it = std::lower_bound(open.begin(), open.end(), std::make_pair(robot, k));
        if (it == open.end() || *it != std::make_pair(robot, k)) continue;
        open.erase(it);
        ++n;
      }
    }
    PairExchangeDecision& d = current_.decisions[job.decision];
    (widened ? d.scans_widened : d.scans_requested) += n;
  }
}

void MergeRound::RefreshHistories() {
  const auto session_of = [&](int robot) {
    return robot >= 0 && static_cast<std::size_t>(robot) < sessions_.size() ? sessions_[static_cast<std::size_t>(robot)]
                                                                            : std::int64_t{0};
  };
  for (PairHistory& h : histories_) {
    const std::int64_t a = session_of(h.alpha), b = session_of(h.beta);
    if (a != h.alpha_session || b != h.beta_session || a == 0 || b == 0) {
      const bool had = !h.verified.empty() || !h.tried.empty() || h.restarted;
      const int alpha = h.alpha, beta = h.beta;
      h = PairHistory();
      h.alpha = alpha;
      h.beta = beta;
      h.alpha_session = a;
      h.beta_session = b;
      h.restarted = had;
      continue;
    }
    // A verified registration the last round's frame solver rejected is no longer trusted; where it was stays
    // tried.
    const auto rejected = [](const VerifiedRegion& v) { return v.verdict == MeasurementVerdict::kRejected; };
    if (std::any_of(h.verified.begin(), h.verified.end(), rejected)) {
      h.verified.erase(std::remove_if(h.verified.begin(), h.verified.end(), rejected), h.verified.end());
      h.rejected_round = result_.round;
    }
  }
}

PairExchangeDecision MergeRound::DecidePair(const PairSelection& plan_pair) const {
  const PairHistory* h = history(plan_pair.alpha, plan_pair.beta);
  PairExchangeInput in;
  in.plan = &plan_pair;
  in.history = h;
  in.restarted = h != nullptr && h->restarted;
  in.alpha_placed = result_.in_world(plan_pair.alpha);
  in.beta_placed = result_.in_world(plan_pair.beta);
  in.alpha = PosesOf(plan_pair.alpha);
  in.beta = PosesOf(plan_pair.beta);
  // The send-all baseline ships every stored scan every round: the rule is for the selecting modes.
  PairExchangeParams rule = params_.exchange;
  if (params_.mode == ExchangeMode::kSendAll) rule.enabled = false;
  return DecidePairExchange(in, rule);
}

void MergeRound::AddPair(const PairSelection& plan_pair, std::size_t decision, std::vector<Job>* jobs) {
  const PairHistory* h = history(plan_pair.alpha, plan_pair.beta);
  const PairExchangeDecision& d = current_.decisions[decision];
  const auto add_slot = [&](PairMergeResult entry, int region) {
    current_.pairs.push_back(std::move(entry));
    current_.widenings.push_back(0);
    current_.registration_s.push_back(0.0);
    entry_region_.push_back(region);
    return current_.pairs.size() - 1;
  };
  const auto kept = [&](std::size_t region) {
    PairMergeResult k = h->verified[region].result;
    k.kept_from_round = h->verified[region].region.round;
    // The decision speaks of the pair, or of the region registered beside this one.
    const bool about_this = !RegistersPair(d.reason);
    k.reason = "kept from round " + std::to_string(k.kept_from_round) + " (" +
               (about_this ? d.why : "region " + std::to_string(region + 1) + " of the pair; the other is registered") +
               ")";
    if (k.reason.size() > 255) k.reason.resize(255);  // merge_result_t's text limit
    return k;
  };
  PairMergeResult placeholder;
  placeholder.alpha = plan_pair.alpha;
  placeholder.beta = plan_pair.beta;
  if (!RegistersPair(d.reason)) {
    if (h != nullptr && !h->verified.empty()) {
      ++current_.pairs_kept;
      for (std::size_t i = 0; i < h->verified.size(); ++i) add_slot(kept(i), static_cast<int>(i));
    } else {
      placeholder.stop = PairStop::kNotThisRound;
      placeholder.reason = d.why.size() > 255 ? d.why.substr(0, 255) : d.why;
      add_slot(placeholder, -1);
    }
    return;
  }
  // The pair's slots: its registration, and the verified regions it keeps beside it (its primary while a second
  // region is registered, the other region while one is registered again at moved poses).
  const std::size_t verified = h != nullptr ? h->verified.size() : 0;
  std::size_t slot = 0;
  for (std::size_t i = 0; i < std::max(verified, d.region + 1); ++i) {
    if (i != d.region) {
      add_slot(kept(i), static_cast<int>(i));
      continue;
    }
    slot = add_slot(placeholder, d.reason == PairExchangeReason::kPosesMoved ? static_cast<int>(i) : -1);
  }
  ++current_.pairs_registered;
  Job job;
  job.selection = d.selection;
  job.selection.alpha = plan_pair.alpha;
  job.selection.beta = plan_pair.beta;
  job.slot = slot;
  job.decision = decision;
  jobs->push_back(std::move(job));
}

Status MergeRound::Begin(Span<const std::int64_t> sessions, std::vector<ScanRequest>* requests) {
  requests->clear();
  active_ = false;
  if (Status st = ValidatePairExchangeParams(params_.exchange); !st.ok()) return st;
  if (params_.run_cascades) {
    if (Status st = server_->RunCascades(); !st.ok()) return st;
  }
  // Step 2: the plan of the mode, what the round asks of each pair, and the requests of the pairs registered:
  // only the scans the server does not hold.
  auto plan = server_->Plan(params_.mode);
  if (!plan.ok()) return plan.status();
  current_ = MergeRoundResult();
  current_.round = rounds_finished_ + 1;
  current_.plan.mode = plan->mode;
  current_.plan.pairs = plan->pairs;
  current_.plan.selected_scans = plan->selected_scans;
  current_.plan.padded_scans = plan->padded_scans;
  sessions_.assign(sessions.begin(), sessions.end());
  RefreshHistories();
  widen_step_ = 0;
  refining_ = false;
  jobs_.clear();
  entry_region_.clear();
  for (const PairSelection& p : plan->pairs) current_.decisions.push_back(DecidePair(p));
  HoldSecondRegions(&current_.decisions);
  for (std::size_t i = 0; i < plan->pairs.size(); ++i) AddPair(plan->pairs[i], i, &jobs_);
  std::vector<PairSelection> selections;
  for (const Job& job : jobs_) selections.push_back(job.selection);
  const ExchangePlan wanted = server_->RequestsFor(Span<const PairSelection>(selections), next_request_id_);
  Request(wanted.requests, wanted.predicted_scan_bytes, requests);
  AttributeRequests(jobs_, *requests, /*widened=*/false);
  pending_ = jobs_;
  active_ = true;
  return Status::Ok();
}

Status MergeRound::Register(std::vector<Job>* jobs) {
  // Step 3: submaps from the received scans, coarse-to-fine registration.
  for (Job& job : *jobs) {
    const auto t0 = std::chrono::steady_clock::now();
    auto merged = server_->MergePair(job.selection);
    if (!merged.ok()) return merged.status();
    const double seconds = RoundSecondsSince(t0);
    const std::size_t i = job.slot;
    if (current_.pairs[i].attempted || current_.registration_s[i] > 0.0) ++current_.widenings[i];
    current_.registration_s[i] += seconds;
    const PairExchangeDecision& d = current_.decisions[job.decision];
    const PairHistory* h = history(job.selection.alpha, job.selection.beta);
    if (d.reason == PairExchangeReason::kPosesMoved && !merged->merged() &&
        h != nullptr && d.region < h->verified.size()) {
      // The overlap at its moved poses did not register: the earlier verification stands.
      job.refused_with_scans = merged->attempted && merged->alpha_missing + merged->beta_missing == 0;
      for (Job& j : jobs_) {
        if (j.slot == job.slot) j.refused_with_scans = job.refused_with_scans;
      }
      PairMergeResult k = h->verified[d.region].result;
      k.kept_from_round = h->verified[d.region].region.round;
      k.reason = "kept from round " + std::to_string(k.kept_from_round) + " (registration at the moved poses: " +
                 (merged->attempted ? PairVerdictName(*merged) : merged->reason) + ")";
      if (k.reason.size() > 255) k.reason.resize(255);
      current_.pairs[i] = std::move(k);
    } else {
      current_.pairs[i] = std::move(*merged);
    }
    if (observer_ != nullptr) observer_->OnPairRegistered(current_.pairs[i]);
  }
  return Status::Ok();
}

Result<bool> MergeRound::Continue(std::vector<ScanRequest>* requests) {
  requests->clear();
  if (!active_) return InvalidArgument("MergeRound::Continue without a round begun (call Begin first)");
  Status st = Status::Ok();
  if (refining_) {  // the spread scans of step 4b arrived
    st = Refine(pending_);
    pending_.clear();
  } else {
    st = Register(&pending_);
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
      std::vector<Job> widened;
      for (const PairSelection& w : wider->pairs) {
        for (Job& job : jobs_) {  // the pair's registration this round (widening leaves verified pairs alone)
          if (job.selection.alpha != w.alpha || job.selection.beta != w.beta) continue;
          job.selection = w;
          widened.push_back(job);
          break;
        }
      }
      Request(wider->requests, wider->predicted_scan_bytes, requests);
      for (const ScanRequest& q : *requests) current_.widened_scans += q.keyframes.size();
      AttributeRequests(widened, *requests, /*widened=*/true);
      if (!requests->empty()) {  // wait for the extra scans, then register these pairs again
        pending_ = std::move(widened);
        return false;
      }
      st = Register(&widened);  // every scan is held already
    }
    // Step 4b: the final refinement of the pairs accepted this round, once widening is done.
    if (st.ok()) {
      std::vector<Job> refine = RefineJobs();
      if (!refine.empty()) {
        refining_ = true;
        std::vector<PairSelection> selections;
        for (const Job& job : refine) selections.push_back(job.selection);
        const ExchangePlan wanted = server_->RequestsFor(Span<const PairSelection>(selections), next_request_id_);
        Request(wanted.requests, wanted.predicted_scan_bytes, requests);
        for (const ScanRequest& q : *requests) current_.refined_scans += q.keyframes.size();
        if (!requests->empty()) {
          pending_ = std::move(refine);
          return false;
        }
        st = Refine(refine);
      }
    }
  }
  if (st.ok()) st = Finish();
  active_ = false;
  refining_ = false;
  if (!st.ok()) return st;
  return true;
}

std::vector<MergeRound::Job> MergeRound::RefineJobs() const {
  std::vector<Job> out;
  const RefinementParams& params = server_->params().refine;
  if (params.scans_per_robot == 0 || params_.mode == ExchangeMode::kSendAll) return out;
  for (const Job& job : jobs_) {
    const PairMergeResult& r = current_.pairs[job.slot];
    if (!r.merged() || r.kept_from_round > 0) continue;
    const PairSelection& sel = job.selection;
    auto spread = SpreadAlongSharedPath(PosesOf(sel.alpha), PosesOf(sel.beta), r.registration.T_target_source,
                                        Span<const std::uint32_t>(sel.beta_keyframes), params);
    if (!spread.ok() || spread->beta_keyframes.size() < 2) continue;  // the anchor alone adds nothing
    Job j = job;
    const auto added = [](const std::vector<std::uint32_t>& picks, const std::vector<std::uint32_t>& held) {
      std::size_t n = 0;
      for (std::uint32_t k : picks) n += !std::binary_search(held.begin(), held.end(), k);
      return n;
    };
    j.spread_alpha = added(spread->alpha_keyframes, sel.alpha_keyframes);
    j.spread_beta = added(spread->beta_keyframes, sel.beta_keyframes);
    j.selection.alpha_keyframes = std::move(spread->alpha_keyframes);
    j.selection.beta_keyframes = std::move(spread->beta_keyframes);
    j.places = std::move(spread->places);
    out.push_back(std::move(j));
  }
  return out;
}

Status MergeRound::Refine(const std::vector<Job>& jobs) {
  for (const Job& job : jobs) {
    const auto t0 = std::chrono::steady_clock::now();
    PairMergeResult& result = current_.pairs[job.slot];
    const Status s = server_->RefinePair(job.selection, job.spread_alpha, job.spread_beta,
                                         Span<const std::pair<std::uint32_t, std::uint32_t>>(job.places), &result);
    if (!s.ok()) return s;
    current_.registration_s[job.slot] += RoundSecondsSince(t0);
  }
  return Status::Ok();
}

void MergeRound::RecordJob(const Job& job) {
  const PairSelection& sel = job.selection;
  PairHistory* h = MutableHistory(sel.alpha, sel.beta);
  if (h == nullptr) {
    PairHistory fresh;
    fresh.alpha = sel.alpha;
    fresh.beta = sel.beta;
    const auto session_of = [&](int r) {
      return r >= 0 && static_cast<std::size_t>(r) < sessions_.size() ? sessions_[static_cast<std::size_t>(r)] : 0;
    };
    fresh.alpha_session = session_of(sel.alpha);
    fresh.beta_session = session_of(sel.beta);
    histories_.push_back(std::move(fresh));
    h = &histories_.back();
  }
  PairMergeResult& result = current_.pairs[job.slot];
  const PairExchangeDecision& d = current_.decisions[job.decision];
  const bool success = result.merged() && result.kept_from_round == 0;
  PairRegion region = MakePairRegion(sel, PosesOf(sel.alpha), PosesOf(sel.beta), current_.round);
  if (d.reason == PairExchangeReason::kPosesMoved && d.region < h->verified.size()) {
    VerifiedRegion& v = h->verified[d.region];
    if (success) {
      v.result = result;
      v.region = std::move(region);
    } else if (job.refused_with_scans) {
      // Refused at the moved poses with every scan: those poses are judged, the next bound counts from them.
      region.round = v.region.round;
      v.region = std::move(region);
    }  // else scans were missing: the next round asks again
    return;
  }
  if (!success && d.region == 0 && result.alpha_missing + result.beta_missing > 0 && !h->verified.empty()) {
    // Selected scans missing (a robot left, or its scans did not arrive in time): the round could not judge the
    // pair; the registration verified before for the same sessions stands.
    PairMergeResult k = h->verified[0].result;
    k.kept_from_round = h->verified[0].region.round;
    k.reason = "kept from round " + std::to_string(k.kept_from_round) + " (this round: refused with " +
               std::to_string(result.alpha_missing + result.beta_missing) + " selected scans missing: " +
               result.reason + ")";
    if (k.reason.size() > 255) k.reason.resize(255);
    result = std::move(k);
    entry_region_[job.slot] = 0;
    return;
  }
  if (!result.attempted) return;  // nothing selected, or no scan arrived: nothing was tried
  h->restarted = false;
  if (h->tried.size() < params_.exchange.max_tried_regions) h->tried.push_back(region);
  if (!success) {
    h->refused_round = current_.round;
    h->refused_reason = PairVerdictName(result);
    return;
  }
  VerifiedRegion v;
  v.result = result;
  v.region = std::move(region);
  if (d.reason == PairExchangeReason::kNewOverlap && !h->verified.empty()) {
    if (h->verified.size() < kMaxVerifiedRegions) h->verified.push_back(std::move(v));
    entry_region_[job.slot] = static_cast<int>(h->verified.size()) - 1;
    return;
  }
  h->verified.assign(1, std::move(v));  // the pair's answer now
  h->rejected_round = 0;
  entry_region_[job.slot] = 0;
}

Status MergeRound::Finish() {
  // Step 5: what the round's registrations verified or tried, per pair. A second region that did not register
  // leaves no entry (the pair's verified one stands beside it).
  for (const Job& job : jobs_) RecordJob(job);
  std::vector<std::size_t> dropped;
  for (const Job& job : jobs_) {
    const PairMergeResult& p = current_.pairs[job.slot];
    if (current_.decisions[job.decision].region > 0 && entry_region_[job.slot] < 0 &&
        !p.merged()) {
      dropped.push_back(job.slot);
    }
  }
  std::sort(dropped.rbegin(), dropped.rend());
  for (std::size_t i : dropped) {
    const auto at = static_cast<std::ptrdiff_t>(i);
    current_.pairs.erase(current_.pairs.begin() + at);
    current_.widenings.erase(current_.widenings.begin() + at);
    current_.registration_s.erase(current_.registration_s.begin() + at);
    entry_region_.erase(entry_region_.begin() + at);
  }
  // Step 6: one frame per robot; pairs inconsistent with the rest are rejected.
  auto frames = server_->SolveFrames(Span<const PairMergeResult>(current_.pairs));
  if (frames.ok()) {
    current_.frames_ok = true;
    current_.frames = std::move(*frames);
    // Each verified region remembers its verdict (SolveFrames numbers the successful entries in order).
    std::size_t m = 0;
    for (std::size_t i = 0; i < current_.pairs.size(); ++i) {
      const PairMergeResult& p = current_.pairs[i];
      if (!p.merged()) continue;
      const MeasurementVerdict verdict = current_.frames.measurements[m++].verdict;
      PairHistory* h = MutableHistory(p.alpha, p.beta);
      if (h == nullptr || entry_region_[i] < 0 || static_cast<std::size_t>(entry_region_[i]) >= h->verified.size()) {
        continue;
      }
      h->verified[static_cast<std::size_t>(entry_region_[i])].verdict = verdict;
    }
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
    o.success = p.merged();
    o.verdict = !p.attempted || p.kept_from_round > 0 ? p.reason : PairVerdictName(p);
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
