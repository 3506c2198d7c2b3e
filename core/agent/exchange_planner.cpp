// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/exchange_planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "core/cloud/scan_codec.hpp"
#include "core/common/number_text.hpp"

namespace commerge {

namespace {

// Unique ascending keyframes of one side of a loop list.
std::vector<std::uint32_t> Endpoints(Span<const SequentialLoopCell> loops, bool alpha_side) {
  std::vector<std::uint32_t> out;
  out.reserve(loops.size());
  for (const SequentialLoopCell& l : loops) {
    out.push_back(static_cast<std::uint32_t>(alpha_side ? l.alpha_index : l.beta_index));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::uint32_t> SortedKeyframes(const std::vector<int>& v) {
  std::vector<std::uint32_t> out(v.begin(), v.end());
  std::sort(out.begin(), out.end());
  return out;
}

Status CascadeError(int a, int b, const Status& st) {
  return Status(st.code(), "cascade of robots " + std::to_string(a) + " and " + std::to_string(b) + ": " + st.message());
}

// The words of a pair DecideRequest refused after stage A: its cluster is at an ambiguous place that the place
// consensus does not confirm.
std::string AmbiguousUnconfirmedText(const ExchangeCascadeResult& c, double min_support) {
  return "stage A: ambiguous place (" + c.ambiguity_reason + ") that other clusters do not confirm: place consensus " +
         "support " + FormatNumber(c.consensus_support_chosen, 4) + " keyframes < " + FormatNumber(min_support, 4) +
         " (min_ambiguous_support)" + (c.consensus_capped ? "; " + c.consensus_reason : "");
}

// The words of a pair DecideRequest refused for the descriptors at its placement.
std::string PlacementDisagreesText(const PairEvidence& e, const PairDecisionParams& params) {
  const PlacementAgreement& a = e.placement_agreement;
  return "stage A: at its cluster's placement " + std::to_string(a.agreeing) + " of " + std::to_string(a.ranked) +
         " co-located keyframes agree (chance <= " + FormatNumber(params.agree_chance, 3) + "), " +
         FormatNumber(std::exp(-PlacementLogOdds(e, params)), 3) +
         " times likelier among strangers than at a true place (--disagree-odds " +
         FormatNumber(params.disagree_odds, 4) + ")";
}

// A robot's keyframes as the descriptor agreement reads them.
KeyframeSetView View(const RobotKeyframeDb& r) {
  return {Span<const float>(r.descriptors), Span<const std::uint8_t>(r.valid), Span<const Eigen::Isometry3d>(r.T_map_sensor)};
}

// Stops after which no scan of the pair is asked for in any mode but send-all.
bool RefusedForItsPlace(PairStop stop) {
  return stop == PairStop::kAmbiguousUnconfirmed || stop == PairStop::kPlacementDisagrees ||
         stop == PairStop::kPlaceCheck;
}

}  // namespace

void AdoptSelections(Span<const PairSelection> adopted, std::vector<PairSelection>* pairs) {
  for (const PairSelection& a : adopted) {
    for (PairSelection& p : *pairs) {
      if (p.alpha == a.alpha && p.beta == a.beta) p = a;
    }
  }
}

const ExchangePlanner::PairState* ExchangePlanner::FindPair(int alpha, int beta) const {
  for (const PairState& p : pairs_) {
    if (p.alpha == alpha && p.beta == beta) return &p;
  }
  return nullptr;
}

const ExchangeCascadeResult* ExchangePlanner::cascade(int alpha, int beta) const {
  const PairState* p = FindPair(alpha, beta);
  return p ? &p->cascade : nullptr;
}

const PairEvidence* ExchangePlanner::evidence(int alpha, int beta) const {
  const PairState* p = FindPair(alpha, beta);
  return p ? &p->evidence : nullptr;
}

const StageCResult* ExchangePlanner::stage_ac(int alpha, int beta) const {
  const PairState* p = FindPair(alpha, beta);
  return p && p->stage_ac_ran ? &p->stage_ac : nullptr;
}

void ExchangePlanner::ForgetRobot(int robot) {
  pairs_.erase(std::remove_if(pairs_.begin(), pairs_.end(),
                              [robot](const PairState& p) { return p.alpha == robot || p.beta == robot; }),
               pairs_.end());
}

CascadeRobotInput ExchangePlanner::Input(const KeyframeDatabase& db, int robot) const {
  const RobotKeyframeDb& r = db.robot(robot);
  return CascadeRobotInput{{Span<const float>(r.descriptors), r.dim, Span<const std::uint8_t>(r.valid)},
                           Span<const Eigen::Vector3d>(positions_[static_cast<std::size_t>(robot)]),
                           Span<const std::uint32_t>(r.stored_points)};
}

Status ExchangePlanner::RunCascades(const KeyframeDatabase& db) {
  pairs_.clear();
  incomparable_pairs_.clear();
  positions_.resize(static_cast<std::size_t>(db.max_robots()));
  for (int r = 0; r < db.max_robots(); ++r) {
    const RobotKeyframeDb& kf = db.robot(r);
    std::vector<Eigen::Vector3d>& p = positions_[static_cast<std::size_t>(r)];
    p.resize(kf.size());
    for (std::size_t k = 0; k < kf.size(); ++k) p[k] = kf.T_map_sensor[k].translation();
  }
  for (int a = 0; a < db.max_robots(); ++a) {
    for (int b = a + 1; b < db.max_robots(); ++b) {
      const RobotKeyframeDb& A = db.robot(a);
      const RobotKeyframeDb& B = db.robot(b);
      if (A.size() == 0 || B.size() == 0) continue;
      if (DescriptorIdsConflict(A.descriptor_id, B.descriptor_id)) {
        incomparable_pairs_.emplace_back(a, b);
        continue;
      }
      if (Status st = RunPair(db, a, b); !st.ok()) return st;
    }
  }
  if (params_.cover == StageBCover::kJoint) {
    if (Status st = RunJointStageB(db); !st.ok()) return st;
  }
  ApplyPlaceCheck(db.max_robots());
  return Status::Ok();
}

Result<std::vector<PlacementAgreement>> ExchangePlanner::MeasurePlacementAgreement(const KeyframeDatabase& db,
                                                                                  int alpha, int beta) const {
  const PairState* p = FindPair(alpha, beta);
  if (p == nullptr) {
    return InvalidArgument("placement agreement: no cascade of robots " + std::to_string(alpha) + " and " +
                           std::to_string(beta) + " in the last round");
  }
  std::vector<PlacementAgreement> out;
  for (const PlacedCluster& c : p->cascade.placed_clusters) {
    auto agreement = AgreementAt(db, alpha, beta, c);
    if (!agreement.ok()) return agreement.status();
    out.push_back(*agreement);
  }
  return out;
}

Status ExchangePlanner::RunPair(const KeyframeDatabase& db, int a, int b) {
  auto result = RunCascadeStageA(Input(db, a), Input(db, b), params_.cascade);
  if (!result.ok()) return CascadeError(a, b, result.status());
  PairState state;
  state.alpha = a;
  state.beta = b;
  state.cascade = std::move(*result);
  state.evidence = CascadeEvidence(state.cascade);
  state.stop = DecideRequest(state.evidence, params_.decision).stop;
  if (state.stop == PairStop::kNone && params_.decision.disagree_odds > 0.0) {
    if (Status st = MeasurePassedOnPlacement(db, &state); !st.ok()) return CascadeError(a, b, st);
    state.stop = DecideRequest(state.evidence, params_.decision).stop;
  }
  if (state.stop == PairStop::kAmbiguousUnconfirmed) {
    state.cascade.no_candidate_reason = AmbiguousUnconfirmedText(state.cascade, params_.decision.min_ambiguous_support);
  } else if (state.stop == PairStop::kPlacementDisagrees) {
    state.cascade.no_candidate_reason = PlacementDisagreesText(state.evidence, params_.decision);
  } else if (params_.cover == StageBCover::kPairwise && CascadeAwaitsStageB(state.cascade)) {
    // Pairwise: the rest of the cascade here. Joint: stage B over every pair in RunJointStageB.
    Status st = RunCascadeFromStageB(Input(db, a), Input(db, b), params_.cascade, nullptr, 0, &state.cascade);
    if (!st.ok()) return CascadeError(a, b, st);
    RefreshEvidence(&state);
  }
  const auto& l_seq = state.cascade.stage_a.cells;
  if (!l_seq.empty() && params_.stage_ac_ablation) {
    // The A+C ablation: stage C over every loop of L_seq (both endpoints "selected").
    std::vector<int> all_a, all_b;
    for (std::uint32_t k : Endpoints(Span<const SequentialLoopCell>(l_seq), true)) all_a.push_back(static_cast<int>(k));
    for (std::uint32_t k : Endpoints(Span<const SequentialLoopCell>(l_seq), false)) all_b.push_back(static_cast<int>(k));
    StageCParams c = params_.cascade.stage_c;
    c.loop_set = StageCLoopSet::kBothEndpointsSelected;
    auto ac = RunStageC(Span<const SequentialLoopCell>(l_seq), Span<const int>(all_a), Span<const int>(all_b),
                        Span<const Eigen::Vector3d>(positions_[static_cast<std::size_t>(a)]),
                        Span<const Eigen::Vector3d>(positions_[static_cast<std::size_t>(b)]), c);
    if (!ac.ok()) return ac.status();
    state.stage_ac = std::move(*ac);
    state.stage_ac_ran = true;
  }
  pairs_.push_back(std::move(state));
  return Status::Ok();
}

Result<PlacementAgreement> ExchangePlanner::AgreementAt(const KeyframeDatabase& db, int alpha, int beta,
                                                        const PlacedCluster& c) const {
  const RobotKeyframeDb& A = db.robot(alpha);
  return commerge::MeasurePlacementAgreement(View(A), View(db.robot(beta)), A.dim, c.placement, c.cluster,
                                             params_.colocation, params_.decision.agree_chance, params_.cascade.metric);
}

Status ExchangePlanner::MeasurePassedOnPlacement(const KeyframeDatabase& db, PairState* state) const {
  for (const PlacedCluster& c : state->cascade.placed_clusters) {
    if (!c.passed_on) continue;
    auto agreement = AgreementAt(db, state->alpha, state->beta, c);
    if (!agreement.ok()) return agreement.status();
    state->evidence.placement_agreement = *agreement;
    return Status::Ok();
  }
  return Status::Ok();
}

void ExchangePlanner::RefreshEvidence(PairState* state) const {
  const PlacementAgreement agreement = state->evidence.placement_agreement;
  state->evidence = CascadeEvidence(state->cascade);
  state->evidence.placement_agreement = agreement;
  state->stop = DecideRequest(state->evidence, params_.decision).stop;
}

Status ExchangePlanner::RunJointStageB(const KeyframeDatabase& db) {
  // One balanced cover over the loops of every pair that stage A passed on, then stage C and the policy per pair.
  std::vector<JointCoverPair> waiting;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    if (pairs_[i].stop != PairStop::kNone || !CascadeAwaitsStageB(pairs_[i].cascade)) continue;
    waiting.push_back({pairs_[i].alpha, pairs_[i].beta, Span<const SequentialLoopCell>(pairs_[i].cascade.stage_a.cells)});
    index.push_back(i);
  }
  if (waiting.empty()) return Status::Ok();
  Result<JointCoverResult> cover = Status(StatusCode::kInternal, "no joint cover");
  if (waiting.size() > 1) {
    cover = SolveJointStageB(Span<const JointCoverPair>(waiting), params_.cascade.stage_b);
    if (!cover.ok()) return Status(cover.status().code(), "joint stage B: " + cover.status().message());
  }
  for (std::size_t w = 0; w < index.size(); ++w) {
    PairState& state = pairs_[index[w]];
    // One pair: its own cover is the joint one.
    const bool joint = waiting.size() > 1;
    Status st = RunCascadeFromStageB(Input(db, state.alpha), Input(db, state.beta), params_.cascade,
                                     joint ? &cover->pairs[w] : nullptr,
                                     joint ? static_cast<int>(cover->robots.size()) : 0, &state.cascade);
    if (!st.ok()) return CascadeError(state.alpha, state.beta, st);
    if (joint) state.cascade.stage_b_s += cover->seconds;  // the one joint solve, in every pair's time
    RefreshEvidence(&state);
  }
  return Status::Ok();
}

void ExchangePlanner::ApplyPlaceCheck(int max_robots) {
  const double min_support = params_.decision.chain_check_support;
  if (min_support <= 0.0) return;
  std::vector<PairPlacement> places;
  places.reserve(pairs_.size());
  for (const PairState& p : pairs_) {
    const ExchangeCascadeResult& c = p.cascade;
    places.push_back({p.alpha, p.beta, c.outcome == CascadeOutcome::kPolicy && c.consensus_measured,
                      c.consensus_support_chosen, c.consensus_placement});
  }
  const std::vector<PlaceCheckVerdict> verdicts =
      CheckPlacesAcrossPairs(Span<const PairPlacement>(places), max_robots, min_support, params_.chain_agreement);
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    PairState& p = pairs_[i];
    p.evidence.chains = verdicts[i];
    p.stop = DecideRequest(p.evidence, params_.decision).stop;
    if (p.stop != PairStop::kPlaceCheck) continue;
    const PlaceCheckVerdict& v = verdicts[i];
    std::string via;
    for (int c : v.via) via += (via.empty() ? "" : ", ") + std::to_string(c);
    p.cascade.outcome = CascadeOutcome::kNoCandidate;
    p.cascade.no_candidate_reason =
        "place check: stage A's place (consensus support " + FormatNumber(places[i].support, 4) + " keyframes < " +
        FormatNumber(min_support, 4) + ") disagrees with where robot" + (v.chains > 1 ? "s " : " ") + via + " place" +
        (v.chains > 1 ? "" : "s") + " the two maps (--chain-check-support)";
    p.cascade.policy = ExchangePolicy{};
  }
}

Result<ExchangePlan> ExchangePlanner::Plan(ExchangeMode mode, const KeyframeDatabase& db) const {
  if (mode == ExchangeMode::kStageAC && !params_.stage_ac_ablation) {
    return InvalidArgument("mode A+C needs the A+C ablation's stage C (MergeServerParams::stage_ac_ablation), "
                           "which this server does not run");
  }
  ExchangePlan plan;
  plan.mode = mode;
  const std::size_t robots = static_cast<std::size_t>(db.max_robots());
  std::vector<std::vector<std::uint32_t>> wanted(robots), own(robots);
  for (const PairState& p : pairs_) {
    PairSelection s;
    s.alpha = p.alpha;
    s.beta = p.beta;
    const auto& l_seq = p.cascade.stage_a.cells;
    if (RefusedForItsPlace(p.stop) && mode != ExchangeMode::kSendAll) {
      s.stop = p.stop;
      s.no_selection_reason = p.cascade.no_candidate_reason;
      plan.pairs.push_back(std::move(s));
      continue;
    }
    switch (mode) {
      case ExchangeMode::kSendAll:
        // The baseline of shipping everything: each pair registers the two robots' complete stored maps
        // (map-level global registration), whatever stage A found.
        s.alpha_keyframes = db.StoredKeyframes(p.alpha);
        s.beta_keyframes = db.StoredKeyframes(p.beta);
        s.loops = l_seq.size();
        break;
      case ExchangeMode::kStageA:
        s.alpha_keyframes = Endpoints(Span<const SequentialLoopCell>(l_seq), true);
        s.beta_keyframes = Endpoints(Span<const SequentialLoopCell>(l_seq), false);
        s.loops = l_seq.size();
        break;
      case ExchangeMode::kStageAB:
        s.alpha_keyframes = SortedKeyframes(p.cascade.stage_b.selected_left);
        s.beta_keyframes = SortedKeyframes(p.cascade.stage_b.selected_right);
        s.loops = l_seq.size();
        break;
      case ExchangeMode::kStageAC:
        if (p.stage_ac_ran) {
          s.alpha_keyframes = Endpoints(Span<const SequentialLoopCell>(p.stage_ac.selected_loops), true);
          s.beta_keyframes = Endpoints(Span<const SequentialLoopCell>(p.stage_ac.selected_loops), false);
          s.loops = p.stage_ac.selected_loops.size();
          if (s.loops == 0) s.no_selection_reason = "stage C (over L_seq): " + p.stage_ac.no_candidate_reason;
        }
        break;
      case ExchangeMode::kStageABC:
        s.alpha_keyframes = p.cascade.policy.alpha.keyframes;
        s.beta_keyframes = p.cascade.policy.beta.keyframes;
        s.loops = p.cascade.policy.loops;
        break;
    }
    if (s.alpha_keyframes.empty() && s.beta_keyframes.empty()) {
      s.stop = p.stop != PairStop::kNone ? p.stop : PairStop::kNothingSelected;
      if (s.no_selection_reason.empty()) {
        s.no_selection_reason =
            p.cascade.no_candidate_reason.empty() ? "nothing selected" : p.cascade.no_candidate_reason;
      }
    }
    if (mode != ExchangeMode::kSendAll) {
      // One rule for every mode: a robot's selection of the pair is padded with keyframes that stage A matched to
      // the other robot (ExchangePolicyParams::min_scans_per_robot, min_points_per_robot; A+B+C's policy has
      // done it already, with the same pool and order). What the mode selected and what padding added are
      // counted apart.
      std::vector<std::uint32_t> own_a = s.alpha_keyframes, own_b = s.beta_keyframes;
      if (mode == ExchangeMode::kStageABC) {
        own_a = Endpoints(Span<const SequentialLoopCell>(p.cascade.stage_c.selected_loops), true);
        own_b = Endpoints(Span<const SequentialLoopCell>(p.cascade.stage_c.selected_loops), false);
      } else {
        const auto target = [&](int robot) {
          return PolicyPadTarget(params_.cascade.policy, Span<const std::uint32_t>(db.robot(robot).stored_points));
        };
        PadKeyframesFromPool(&s.alpha_keyframes, Endpoints(Span<const SequentialLoopCell>(l_seq), true),
                             target(p.alpha));
        PadKeyframesFromPool(&s.beta_keyframes, Endpoints(Span<const SequentialLoopCell>(l_seq), false),
                             target(p.beta));
      }
      auto& oa = own[static_cast<std::size_t>(p.alpha)];
      auto& ob = own[static_cast<std::size_t>(p.beta)];
      oa.insert(oa.end(), own_a.begin(), own_a.end());
      ob.insert(ob.end(), own_b.begin(), own_b.end());
      auto& wa = wanted[static_cast<std::size_t>(p.alpha)];
      auto& wb = wanted[static_cast<std::size_t>(p.beta)];
      wa.insert(wa.end(), s.alpha_keyframes.begin(), s.alpha_keyframes.end());
      wb.insert(wb.end(), s.beta_keyframes.begin(), s.beta_keyframes.end());
    }
    plan.pairs.push_back(std::move(s));
  }
  if (mode == ExchangeMode::kSendAll) {
    for (std::size_t r = 0; r < robots; ++r) wanted[r] = db.StoredKeyframes(static_cast<int>(r));
    own = wanted;
  }
  AddRequests(&wanted, 1, db, nullptr, &plan);
  for (std::size_t r = 0; r < robots; ++r) {  // wanted[r] is sorted and unique now
    std::vector<std::uint32_t>& o = own[r];
    std::sort(o.begin(), o.end());
    o.erase(std::unique(o.begin(), o.end()), o.end());
    plan.selected_scans += o.size();
    plan.padded_scans += wanted[r].size() - o.size();
  }
  return plan;
}

void ExchangePlanner::AddRequests(std::vector<std::vector<std::uint32_t>>* wanted, std::int32_t request_id,
                                  const KeyframeDatabase& db, const ScanInbox* inbox, ExchangePlan* plan) const {
  for (std::size_t r = 0; r < wanted->size(); ++r) {
    auto& w = (*wanted)[r];
    std::sort(w.begin(), w.end());
    w.erase(std::unique(w.begin(), w.end()), w.end());
    if (inbox != nullptr) {
      w.erase(std::remove_if(w.begin(), w.end(),
                             [&](std::uint32_t k) { return inbox->has_scan(static_cast<int>(r), k); }),
              w.end());
    }
    if (w.empty()) continue;
    ScanRequest req;
    req.robot_id = static_cast<int>(r);
    req.request_id = request_id++;
    req.keyframes = w;
    const RobotKeyframeDb& kf = db.robot(static_cast<int>(r));
    for (std::uint32_t k : w) {
      const std::uint32_t n = k < kf.size() ? kf.stored_points[k] : 0;
      plan->predicted_scan_bytes += EncodedScanBytes(n > 0 ? n : params_.cascade.policy.assumed_points_per_scan);
    }
    plan->requests.push_back(std::move(req));
  }
}

ExchangePlan ExchangePlanner::RequestsFor(Span<const PairSelection> selections, std::int32_t first_request_id,
                                          const KeyframeDatabase& db, const ScanInbox& inbox) const {
  ExchangePlan plan;
  std::vector<std::vector<std::uint32_t>> wanted(static_cast<std::size_t>(db.max_robots()));
  for (const PairSelection& s : selections) {
    for (const auto& [robot, keyframes] :
         {std::make_pair(s.alpha, &s.alpha_keyframes), std::make_pair(s.beta, &s.beta_keyframes)}) {
      if (robot < 0 || robot >= db.max_robots()) continue;
      auto& w = wanted[static_cast<std::size_t>(robot)];
      w.insert(w.end(), keyframes->begin(), keyframes->end());
    }
  }
  AddRequests(&wanted, first_request_id, db, &inbox, &plan);
  return plan;
}

Result<ExchangePlan> ExchangePlanner::WidenPlan(const ExchangePlan& plan, Span<const PairOutcome> outcomes,
                                                std::int32_t first_request_id, const KeyframeDatabase& db,
                                                const ScanInbox& inbox) const {
  ExchangePlan wider;
  wider.mode = plan.mode;
  if (plan.mode == ExchangeMode::kSendAll) return wider;
  const int robots = db.max_robots();
  // Robots already joined by merged pairs (union-find).
  std::vector<int> root(static_cast<std::size_t>(robots));
  for (std::size_t r = 0; r < root.size(); ++r) root[r] = static_cast<int>(r);
  const auto find = [&root](int r) {
    while (root[static_cast<std::size_t>(r)] != r) r = root[static_cast<std::size_t>(r)];
    return r;
  };
  const auto in_range = [robots](int a, int b) { return a >= 0 && b >= 0 && a < robots && b < robots; };
  for (const PairOutcome& o : outcomes) {
    if (o.merged && in_range(o.alpha, o.beta)) root[static_cast<std::size_t>(find(o.alpha))] = find(o.beta);
  }
  std::vector<std::vector<std::uint32_t>> wanted(static_cast<std::size_t>(robots));
  for (const PairSelection& sel : plan.pairs) {
    if (!in_range(sel.alpha, sel.beta)) continue;
    const PairOutcome* outcome = nullptr;
    for (const PairOutcome& o : outcomes) {
      if (o.alpha == sel.alpha && o.beta == sel.beta) outcome = &o;
    }
    if (!outcome || !outcome->attempted || outcome->merged) continue;
    const PairState* p = FindPair(sel.alpha, sel.beta);
    if (!p || sel.alpha_keyframes.empty() || sel.beta_keyframes.empty()) continue;
    PairEvidence e = p->evidence;
    e.joined_elsewhere = find(sel.alpha) == find(sel.beta);
    if (!DecideWiden(e, params_.decision).yes) continue;
    const Span<const SequentialLoopCell> l_seq(p->cascade.stage_a.cells);
    PairSelection w = sel;
    const auto grow = [](std::vector<std::uint32_t>* keyframes, std::vector<std::uint32_t> pool) {
      const std::size_t target = std::min<std::size_t>(2 * keyframes->size(), std::numeric_limits<std::uint32_t>::max());
      PadTarget twice;
      twice.min_scans = static_cast<std::uint32_t>(target);
      return PadKeyframesFromPool(keyframes, std::move(pool), twice);
    };
    const std::size_t added = grow(&w.alpha_keyframes, Endpoints(l_seq, true)) +
                              grow(&w.beta_keyframes, Endpoints(l_seq, false));
    if (added == 0) continue;
    auto& wa = wanted[static_cast<std::size_t>(w.alpha)];
    auto& wb = wanted[static_cast<std::size_t>(w.beta)];
    wa.insert(wa.end(), w.alpha_keyframes.begin(), w.alpha_keyframes.end());
    wb.insert(wb.end(), w.beta_keyframes.begin(), w.beta_keyframes.end());
    wider.pairs.push_back(std::move(w));
  }
  AddRequests(&wanted, first_request_id, db, &inbox, &wider);
  return wider;
}

std::size_t ExchangePlanner::AffinityBytes() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t bytes = held(positions_);
  for (const std::vector<Eigen::Vector3d>& p : positions_) bytes += held(p);
  for (const PairState& p : pairs_) {
    bytes += held(p.cascade.stage_a.cells) + held(p.cascade.placed_clusters);
  }
  return bytes;
}

std::size_t ExchangePlanner::SolverBytes() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t bytes = held(pairs_);
  for (const PairState& p : pairs_) {
    const ExchangeCascadeResult& c = p.cascade;
    bytes += held(c.stage_b.selected_left) + held(c.stage_b.selected_right) + held(c.stage_c.candidate_loops) +
             held(c.stage_c.selected_loops) + held(c.stage_c.clique.clique) + held(c.policy.alpha.keyframes) +
             held(c.policy.beta.keyframes) + held(p.stage_ac.candidate_loops) + held(p.stage_ac.selected_loops) +
             held(p.stage_ac.clique.clique);
  }
  return bytes;
}

}  // namespace commerge
