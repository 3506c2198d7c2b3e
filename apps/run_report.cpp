// SPDX-License-Identifier: BSD-3-Clause
// `commerge run`'s results: the modes side by side and the final mode's result on stdout, the merge files
// (platform/io/merge_outputs: transforms.txt, trajectories/, merged_map.pcd/.ply) and the report folder
// (affinity matrices, selected scans, top views, bytes per mode, summary.md, metrics.tsv).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "apps/run_job.hpp"
#include "core/agent/joint_edges.hpp"
#include "core/agent/merge_round.hpp"
#include "core/common/bytes.hpp"
#include "core/eval/descriptor_separation.hpp"
#include "core/eval/loop_errors.hpp"
#include "core/eval/merge_judgement.hpp"
#include "core/eval/shared_place.hpp"
#include "core/eval/path_agreement.hpp"
#include "core/merge/joint_graph.hpp"
#include "core/eval/stage_a_truth.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/merge/merged_map.hpp"
#include "platform/io/merge_outputs.hpp"
#include "platform/memory/peak_rss.hpp"
#include "platform/report/png_writer.hpp"
#include "platform/report/report_charts.hpp"

namespace commerge::app {

namespace {

std::string Bytes(std::uint64_t b) { return FormatBytes(static_cast<std::int64_t>(b)); }

std::string PoseText(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d t = T.translation();
  return "t = (" + Fmt("%.2f", t.x()) + ", " + Fmt("%.2f", t.y()) + ", " + Fmt("%.2f", t.z()) + ") m, yaw " +
         Fmt("%.2f", YawRad(T.linear()) * kRadToDeg) + " deg";
}

// ---- against ground truth (core/eval: merge_judgement, descriptor_separation, stage_a_truth): the run's data
// as the plain views those take; where unmerged pairs stopped

// A forward-looking sensor sees a place again only from a heading within its field of view.
SharedPlaceParams SharedPlaceFor(const RunJob& job) { return SharedPlaceParamsForSensor(job.options.sensor); }

MergeJudgementParams JudgementParamsFor(const RunJob& job) {
  MergeJudgementParams params;
  params.shared_place = SharedPlaceFor(job);
  return params;
}

// Mode m's round as core/eval views into the job: every robot's trajectories and placement, and per pair (in the
// round's order) whether it registered and the keyframes of its selection (plan.pairs, the same index).
struct JudgementInput {
  std::vector<RobotTrajectoryTruth> robots;
  std::vector<RobotPlacement> placements;
  std::vector<JudgedPair> pairs;
};

JudgementInput JudgementInputOf(const RunJob& job, const ModeOutcome& m) {
  JudgementInput in;
  for (int r = 0; r < job.num_robots(); ++r) {
    const Trajectories& t = job.trajectories[static_cast<std::size_t>(r)];
    in.robots.push_back({Span<const Eigen::Isometry3d>(t.estimated), Span<const Eigen::Isometry3d>(t.ground_truth),
                         t.T_gt_map});
    in.placements.push_back({m.round.in_world(r), m.round.T_world_map(r)});
  }
  for (std::size_t i = 0; i < m.round.pairs.size(); ++i) {
    const PairMergeResult& p = m.round.pairs[i];
    JudgedPair j;
    j.alpha = p.alpha;
    j.beta = p.beta;
    j.registered = p.merged();
    if (i < m.round.plan.pairs.size()) {
      j.alpha_keyframes = Span<const std::uint32_t>(m.round.plan.pairs[i].alpha_keyframes);
      j.beta_keyframes = Span<const std::uint32_t>(m.round.plan.pairs[i].beta_keyframes);
    }
    in.pairs.push_back(j);
  }
  return in;
}

// Per pair (in the final round's order): the two robots share a place by ground truth; empty without it.
std::vector<SharedPlace> SharedPlaces(const RunJob& job, const ModeOutcome& m) {
  const JudgementInput in = JudgementInputOf(job, m);
  return MeasurePairSharedPlaces(Span<const RobotTrajectoryTruth>(in.robots), Span<const JudgedPair>(in.pairs),
                                 SharedPlaceFor(job));
}

std::vector<RobotVerdict> RobotVerdicts(const RunJob& job, const ModeOutcome& m) {
  const JudgementInput in = JudgementInputOf(job, m);
  return JudgeRobots(Span<const RobotTrajectoryTruth>(in.robots), Span<const RobotPlacement>(in.placements),
                     Span<const JudgedPair>(in.pairs), JudgementParamsFor(job));
}

// How the placed robots agree along the path they share (core/eval/path_agreement.hpp), under mode m's
// placement; pairs 0 without ground truth or without two placed robots that came within 10 m.
PathAgreement PathAgreementOf(const RunJob& job, const ModeOutcome& m) {
  std::vector<std::vector<Eigen::Isometry3d>> world(static_cast<std::size_t>(job.num_robots()));
  std::vector<RobotPathTruth> robots;
  for (int r = 0; r < job.num_robots(); ++r) {
    const Trajectories& t = job.trajectories[static_cast<std::size_t>(r)];
    std::vector<Eigen::Isometry3d>& w = world[static_cast<std::size_t>(r)];
    if (m.round.in_world(r) && t.ground_truth.size() == t.estimated.size()) {
      for (const Eigen::Isometry3d& T : t.estimated) w.push_back(m.round.T_world_map(r) * T);
    }
    robots.push_back({Span<const Eigen::Isometry3d>(w), Span<const Eigen::Isometry3d>(t.ground_truth)});
  }
  auto agreement = MeasurePathAgreement(Span<const RobotPathTruth>(robots));
  return agreement.ok() ? *agreement : PathAgreement{};
}

}  // namespace

void SolveJoint(RunJob* job) {
  const ModeOutcome& m = job->outcomes.back();
  RunJob::Joint& out = job->joint;
  std::vector<std::vector<Eigen::Isometry3d>> T_map_keyframe;
  std::vector<std::uint8_t> placed;
  for (int r = 0; r < job->num_robots(); ++r) {
    T_map_keyframe.push_back(job->trajectories[static_cast<std::size_t>(r)].estimated);
    placed.push_back(m.round.in_world(r) ? 1 : 0);
  }
  const std::vector<InterRobotEdge> edges =
      JointEdgesOf(Span<const PairMergeResult>(m.round.pairs),
                   Span<const std::vector<Eigen::Isometry3d>>(T_map_keyframe), Span<const std::uint8_t>(placed));
  out.edges = edges.size();
  if (edges.empty() || T_map_keyframe[0].empty()) return;
  auto solved = SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>>(T_map_keyframe),
                                Span<const InterRobotEdge>(edges));
  if (!solved.ok()) {
    out.error = solved.status().message();
    return;
  }
  out.used_edges = solved->used_edges;
  std::vector<RobotPathTruth> robots;
  for (int r = 0; r < job->num_robots(); ++r) {
    const Trajectories& t = job->trajectories[static_cast<std::size_t>(r)];
    const std::vector<Eigen::Isometry3d>& w = solved->T_world_keyframe[static_cast<std::size_t>(r)];
    const bool measured = !w.empty() && t.ground_truth.size() == w.size();
    robots.push_back({measured ? Span<const Eigen::Isometry3d>(w) : Span<const Eigen::Isometry3d>(),
                      measured ? Span<const Eigen::Isometry3d>(t.ground_truth) : Span<const Eigen::Isometry3d>()});
  }
  auto agreement = MeasurePathAgreement(Span<const RobotPathTruth>(robots));
  if (agreement.ok()) out.agreement = *agreement;
}

namespace {

// The stage that stopped pair i (PairStopName): "merged", the frame solver, registration with its verdict, or where
// the pair stopped before.
std::string StoppedAt(const ModeOutcome& m, std::size_t i) {
  const PairMergeResult& p = m.round.pairs[i];
  if (p.merged()) {
    std::size_t k = 0;  // SolveFrames numbers the merged pairs in order
    for (std::size_t j = 0; j < i; ++j) k += m.round.pairs[j].merged();
    const bool rejected = m.round.frames_ok && k < m.round.frames.measurements.size() &&
                          m.round.frames.measurements[k].verdict == MeasurementVerdict::kRejected;
    return PairStopName(rejected ? PairStop::kInconsistent : PairStop::kNone);
  }
  if (p.stop == PairStop::kRegistration) {
    return std::string(PairStopName(p.stop)) + " (" + RegistrationVerdictName(p.registration.verdict) + ")";
  }
  return PairStopName(p.stop);
}

DescriptorSetView KeyframeDescriptors(const RobotKeyframeDb& db) {
  DescriptorSetView set;
  set.values = Span<const float>(db.descriptors);
  set.dim = db.dim;
  set.valid = Span<const std::uint8_t>(db.valid);
  return set;
}

// Descriptor distances of keyframe pairs at the same place and at different places, per robot pair.
DistanceQuantiles PairDescriptorSeparation(const RunJob& job, int a, int b) {
  DescriptorSeparationParams params;
  params.max_heading_deg = SharedPlaceFor(job).max_heading_deg;
  return DescriptorSeparation(KeyframeDescriptors(job.server->robot(a)),
                              Span<const Eigen::Isometry3d>(job.trajectories[static_cast<std::size_t>(a)].ground_truth),
                              KeyframeDescriptors(job.server->robot(b)),
                              Span<const Eigen::Isometry3d>(job.trajectories[static_cast<std::size_t>(b)].ground_truth),
                              job.server->params().cascade.metric, params);
}

// Stage A's chosen cluster: the fraction of its cells that were truly at one place (-1 without a cluster or
// ground truth).
double PairStageATrueFraction(const RunJob& job, int a, int b) {
  const ExchangeCascadeResult* c = job.server->cascade(a, b);
  if (!c || !c->stage_a.found) return -1.0;
  return StageATrueFraction(Span<const SequentialLoopCell>(c->stage_a.cells),
                            Span<const Eigen::Isometry3d>(job.trajectories[static_cast<std::size_t>(a)].ground_truth),
                            Span<const Eigen::Isometry3d>(job.trajectories[static_cast<std::size_t>(b)].ground_truth));
}

// The final refinement of a pair (core/agent/pair_refinement.hpp), when it ran.
template <typename KV>
void WriteRefinement(const PairRefinement& f, const std::string& k, const KV& kv) {
  if (!f.attempted) return;
  kv(k + "refined", std::string(f.taken ? "taken" : "not taken") + " " + RegistrationVerdictName(f.verdict));
  kv(k + "refined_scans", std::to_string(f.alpha_scans) + " " + std::to_string(f.beta_scans));
  kv(k + "refined_moved_m_deg", Fmt("%.3f", f.moved_m) + " " + Fmt("%.3f", f.moved_deg));
  std::size_t registered = 0;
  for (const PlaceRegistration& place : f.places) registered += place.success;
  kv(k + "refined_places", std::to_string(registered) + " " + std::to_string(f.places.size()));
}

// How the placed robots agree along the shared path: the rigid merge, and the joint pose graph's correction.
template <typename KV>
void WritePathAgreement(const RunJob& job, const ModeOutcome& m, const KV& kv) {
  const PathAgreement a = PathAgreementOf(job, m);
  if (a.pairs == 0) return;
  kv("path_agreement_pairs", std::to_string(a.pairs));
  kv("path_agreement_rms_m", Fmt("%.4f", a.rms_m));
  kv("path_agreement_p95_m", Fmt("%.4f", a.p95_m));
  kv("path_agreement_max_m", Fmt("%.4f", a.max_m));
  const RunJob::Joint& j = job.joint;
  kv("joint_edges", std::to_string(j.edges));
  kv("joint_edges_used", std::to_string(j.used_edges));
  if (j.agreement.pairs > 0) {
    kv("joint_path_agreement_rms_m", Fmt("%.4f", j.agreement.rms_m));
    kv("joint_path_agreement_p95_m", Fmt("%.4f", j.agreement.p95_m));
  }
}

// Every placed cluster of the pair's cascade, one key each (pair.A-B.placed.K): its keyframe ranges, weight,
// consensus support, whether it was passed on, the descriptor agreement at its placement (co-located, ranked,
// agreeing, median chance) and, with ground truth, how far its placement is from the true one at its place.
template <typename KV>
void WritePlacedClusters(const RunJob& job, int a, int b, const std::string& k, const KV& kv) {
  const ExchangeCascadeResult* c = job.server->cascade(a, b);
  if (!c || c->placed_clusters.empty()) return;
  auto agreement = job.server->MeasurePlacementAgreement(a, b);
  if (!agreement.ok()) {
    kv(k + "placed_error", agreement.status().message());
    return;
  }
  const Trajectories& ta = job.trajectories[static_cast<std::size_t>(a)];
  const Trajectories& tb = job.trajectories[static_cast<std::size_t>(b)];
  const bool has_gt = !ta.ground_truth.empty() && !tb.ground_truth.empty();
  const Eigen::Isometry3d T_true = ta.T_gt_map.inverse() * tb.T_gt_map;
  for (std::size_t i = 0; i < c->placed_clusters.size(); ++i) {
    const PlacedCluster& pc = c->placed_clusters[i];
    const SequentialCluster& cl = pc.cluster;
    std::string v = std::to_string(cl.row_min) + "-" + std::to_string(cl.row_max) + " " + std::to_string(cl.col_min) +
                    "-" + std::to_string(cl.col_max) + " weight " + Fmt("%.0f", pc.placement.weight) + " support " +
                    Fmt("%.0f", pc.support) + " passed_on " + (pc.passed_on ? "1" : "0") + " mean " +
                    Fmt("%.3f", cl.mean_distance());
    if (i < agreement->size() && (*agreement)[i].measured) {
      const PlacementAgreement& g = (*agreement)[i];
      v += " colocated " + std::to_string(g.colocated) + " ranked " + std::to_string(g.ranked) + " agreeing " +
           std::to_string(g.agreeing) + " median_chance " + Fmt("%.3f", g.median_chance);
    }
    if (has_gt && pc.placement.valid) {
      const PlacementGap gap = GapToPlacement(pc.placement, T_true);
      v += " truth_gap_m " + Fmt("%.2f", gap.distance_m) + " truth_gap_deg " + Fmt("%.1f", gap.yaw_deg);
    }
    kv(k + "placed." + std::to_string(i), v);
  }
}

// ---- stdout

std::string ModeRow(const RunJob& job, const ModeOutcome& m) {
  const std::uint64_t total = job.stream_bytes() + m.ledger->Total().bytes;
  const std::string vs =
      Fmt("%.2f %% less", 100.0 * (1.0 - static_cast<double>(total) / static_cast<double>(job.send_all_bytes)));
  std::string rmse;
  for (std::size_t r = 1; r < m.robot_eval.size(); ++r) {
    if (!rmse.empty()) rmse += ", ";
    rmse += m.robot_eval[r].has_gt ? Fmt("%.3f m", m.robot_eval[r].rmse_m) : std::string("-");
  }
  const std::string scans = std::to_string(m.scans_requested()) + " (" + std::to_string(m.round.plan.selected_scans) +
                            " + " + std::to_string(m.round.plan.padded_scans) + " + " +
                            std::to_string(m.round.widened_scans) + " + " + std::to_string(m.round.refined_scans) + ")";
  return "| " + std::string(ExchangeModeName(m.mode)) + " | " + scans + " | " +
         Bytes(m.scan_bytes()) + " | " + Bytes(m.ledger->KindTotal(MessageKind::kPolicies).bytes) + " | " +
         Bytes(m.ledger->KindTotal(MessageKind::kPoseUpdates).bytes) + " | " + Bytes(total) + " | " + vs + " | " +
         std::to_string(m.pairs_merged()) + "/" + std::to_string(m.round.pairs.size()) + " | " +
         (rmse.empty() ? "-" : rmse) + " | " + Fmt("%.2f", m.merge_s) + " |";
}

std::string PairText(const ModeOutcome& m, std::size_t i) {
  const PairMergeResult& p = m.round.pairs[i];
  const PairEval& e = m.pair_eval[i];
  std::string s = "  pair " + std::to_string(p.alpha) + "-" + std::to_string(p.beta) + ": ";
  if (!p.attempted) return s + "not merged: " + p.reason;
  const RegistrationResult& g = p.registration;
  s += std::to_string(p.alpha_scans) + " + " + std::to_string(p.beta_scans) + " scans, submaps " +
       std::to_string(p.alpha_submap_points) + " / " + std::to_string(p.beta_submap_points) + " points at " +
       Fmt("%.2f m", p.voxel_size_m) + "; " +
       RegistrationVerdictName(g.verdict) + " (coarse inliers " + std::to_string(g.num_coarse_inliers) + ", overlap " +
       Fmt("%.2f", g.overlap_ratio) + ", fitness " + Fmt("%.3f m", g.fitness_rmse_m) + "), " +
       Fmt("%.2f s", m.round.registration_s[i]);
  if (const PairRefinement& f = p.refinement; f.attempted) {
    s += "\n    refined on " + std::to_string(f.alpha_scans) + " + " + std::to_string(f.beta_scans) +
         " scans spread along the shared path: " + RegistrationVerdictName(f.verdict) + Fmt(" (overlap %.2f)", f.overlap_ratio) +
         ", moved " + Fmt("%.3f m", f.moved_m) + " and " + Fmt("%.2f deg", f.moved_deg) + (f.taken ? ", taken" : ", not taken");
    std::size_t registered = 0;
    for (const PlaceRegistration& place : f.places) registered += place.success;
    s += "; " + std::to_string(registered) + " of " + std::to_string(f.places.size()) +
         " places registered on their own (joint pose graph edges)";
  }
  if (m.round.widenings[i] > 0) {
    s += " (selection widened " + std::to_string(m.round.widenings[i]) +
         "x after registration refused it; core/README.md \"Server cascade\")";
  }
  if (g.success()) {
    s += "\n    T_" + std::to_string(p.alpha) + "_" + std::to_string(p.beta) + ": " + PoseText(g.T_target_source);
    if (e.has_gt) {
      s += "\n    against ground truth: " + Fmt("%.3f m", e.transform_error.translation_m) + ", " +
           Fmt("%.2f deg", e.transform_error.rotation_deg) + "; e_rmse " + Fmt("%.3f m", e.rmse_m) + " (max " +
           Fmt("%.3f m", e.max_error_m) + ")";
    }
  }
  return s;
}

void FinalResult(const RunJob& job, const ModeOutcome& m, const std::function<void(const std::string&)>& line) {
  line("");
  line("final result (" + std::string(ExchangeModeName(m.mode)) + "):");
  for (std::size_t i = 0; i < m.round.pairs.size(); ++i) line(PairText(m, i));
  if (!m.round.frames_ok) {
    line("  frames: " + m.round.frames_error);
    return;
  }
  for (int r = 0; r < job.num_robots(); ++r) {
    std::string s = "  robot " + std::to_string(r) + ": ";
    if (r == 0) {
      s += "world frame (robot 0's map)";
    } else if (!m.round.in_world(r)) {
      s += "not connected to robot 0 (no consistent merge)";
    } else {
      s += "T_world_map " + PoseText(m.round.T_world_map(r));
      const PairEval& e = m.robot_eval[static_cast<std::size_t>(r)];
      if (e.has_gt) s += "; e_rmse " + Fmt("%.3f m", e.rmse_m);
    }
    line(s);
  }
  const std::vector<RobotVerdict> verdicts = RobotVerdicts(job, m);
  if (job.num_robots() > 1 && verdicts[1].has_gt) {
    const WrongMergeCriterion criterion = JudgementParamsFor(job).wrong;
    int reachable = 0, merged = 0, wrong = 0;
    for (int r = 1; r < job.num_robots(); ++r) {
      const RobotVerdict& v = verdicts[static_cast<std::size_t>(r)];
      reachable += v.reachable;
      merged += v.merged && !v.wrong;
      wrong += v.wrong;
    }
    line("  against ground truth: " + std::to_string(reachable) + " of " + std::to_string(job.num_robots() - 1) +
         " robots share a place with robot 0's team, " + std::to_string(merged) + " placed right, " +
         std::to_string(wrong) + " wrong (> " + Fmt("%.0f m", criterion.max_translation_m) + " or " +
         Fmt("%.0f deg", criterion.max_rotation_deg) + " off where it met a placed robot)");
  }
  if (const PathAgreement a = PathAgreementOf(job, m); a.pairs > 0) {
    line("  along the shared path: keyframes of two robots within 10 m, relative position against ground truth " +
         Fmt("%.3f m RMS", a.rms_m) + ", " + Fmt("%.3f m", a.p95_m) + " at the 95th percentile, " +
         Fmt("%.3f m", a.max_m) + " at most (" + std::to_string(a.pairs) + " pairs)");
    const RunJob::Joint& j = job.joint;
    if (j.agreement.pairs > 0) {
      line("  after the joint pose graph (" + std::to_string(j.used_edges) + " of " + std::to_string(j.edges) +
           " inter-robot edges used): " + Fmt("%.3f m RMS", j.agreement.rms_m) + ", " +
           Fmt("%.3f m", j.agreement.p95_m) + " at the 95th percentile, " + Fmt("%.3f m", j.agreement.max_m) +
           " at most (" + std::to_string(j.agreement.pairs) + " pairs)");
    } else if (!j.error.empty()) {
      line("  joint pose graph: " + j.error);
    }
  }
  for (const MeasurementOutcome& mo : m.round.frames.measurements) {
    if (mo.verdict == MeasurementVerdict::kRejected) {
      line("  a pairwise merge was rejected as inconsistent with the others (cycle error " +
           Fmt("%.2f m", mo.cycle_translation_m) + ", " + Fmt("%.1f deg", mo.cycle_rotation_deg) + ")");
    }
  }
}

// ---- files

MergeResultMessage FinalMessage(const RunJob& job) {
  std::vector<int> ids;
  std::vector<std::uint32_t> keyframes;
  for (int r = 0; r < job.num_robots(); ++r) {
    ids.push_back(r);
    keyframes.push_back(static_cast<std::uint32_t>(job.server->robot(r).size()));
  }
  return MakeMergeResultMessage(job.outcomes.back().round, *job.server, Span<const int>(ids),
                                Span<const std::uint32_t>(keyframes), 0, 0);
}

// Robot r's stored scans placed with T_world_map (identity: its own frame) into `map`.
void AddRobotScans(const RobotRun& r, int robot, const Eigen::Isometry3d& T_world_map, MergedMapBuilder* map) {
  std::vector<PointXYZI> scan;
  std::vector<std::uint8_t> spill;
  const RobotMapper& m = r.agent->mapper();
  map->BeginRobot(static_cast<std::uint16_t>(robot), T_world_map);
  for (std::size_t k = 0; k < m.num_keyframes(); ++k) {
    if (!r.store->GetPoints(static_cast<std::uint32_t>(k), &scan, &spill).ok()) continue;
    map->AddScan(Span<const PointXYZI>(scan), m.pose(k));
  }
}

void Warn(const RunJob& job, const Status& st) {
  if (!st.ok()) std::fprintf(stderr, "%s: %s\n", job.tag, st.message().c_str());
}

// transforms.txt, trajectories/, and both maps (merged, and every robot in its own frame for the report).
// `before` may be null (no report).
void WriteMergeFiles(const RunJob& job, MergedMapBuilder* after, MergedMapBuilder* before) {
  const ModeOutcome& final_mode = job.outcomes.back();
  const std::string& dir = job.options.out_dir;
  Warn(job, platform::WriteTransforms(dir + "/transforms.txt", FinalMessage(job),
                                      std::string(job.options.tag) + ", mode " + ExchangeModeName(final_mode.mode)));
  for (int r = 0; r < job.num_robots(); ++r) {
    const RobotRun& rr = job.robots[static_cast<std::size_t>(r)];
    const Trajectories& tr = job.trajectories[static_cast<std::size_t>(r)];
    platform::RobotTrajectory t;
    t.robot = r;
    t.in_world = final_mode.round.in_world(r);
    t.T_world_map = final_mode.round.T_world_map(r);
    t.T_map_sensor = tr.estimated;
    t.times_s = tr.times_s;
    t.ground_truth = tr.ground_truth;
    Status st = platform::WriteTrajectory(dir + "/trajectories", t);
    if (st.ok()) st = WriteLoops(rr, dir + "/trajectories/robot_" + std::to_string(r) + "_loops.txt");
    Warn(job, st);
    if (t.in_world) AddRobotScans(rr, r, t.T_world_map, after);
  }
  after->Finish();  // one map's workspace at a time
  if (before != nullptr) {
    for (int r = 0; r < job.num_robots(); ++r) {
      AddRobotScans(job.robots[static_cast<std::size_t>(r)], r, Eigen::Isometry3d::Identity(), before);
    }
    before->Finish();
  }
  Warn(job, platform::WriteMergedMap(dir, *after));
}

// Min-pooled descriptor distance matrix (rows = alpha keyframes) for the report picture.
platform::HeatmapInput AffinityPicture(const RobotKeyframeDb& a, const RobotKeyframeDb& b, int max_cells,
                                       const DescriptorMetric& metric) {
  platform::HeatmapInput h;
  h.rows = static_cast<int>(std::min<std::size_t>(a.size(), static_cast<std::size_t>(max_cells)));
  h.cols = static_cast<int>(std::min<std::size_t>(b.size(), static_cast<std::size_t>(max_cells)));
  h.values.assign(static_cast<std::size_t>(h.rows) * static_cast<std::size_t>(h.cols), std::nanf(""));
  const std::size_t D = a.dim;
  const bool unit = metric.kind == DescriptorMetric::Kind::kUnitL2;
  // Subsample very large matrices (at most ~40M unit-L2 distances, ~40k Scan Context ones): the picture needs the
  // structure, not every cell.
  const std::size_t budget = unit ? 40000000 : 40000;
  const std::size_t stride_a = std::max<std::size_t>(1, a.size() * b.size() / budget + 1);
  const std::size_t stride_b = unit ? 1 : stride_a;
  for (std::size_t i = 0; i < a.size(); i += stride_a) {
    if (!a.valid[i]) continue;
    const int pr = static_cast<int>(i * static_cast<std::size_t>(h.rows) / a.size());
    const float* x = &a.descriptors[i * D];
    for (std::size_t j = 0; j < b.size(); j += stride_b) {
      if (!b.valid[j]) continue;
      const float* y = &b.descriptors[j * D];
      float dist = 0.0f;
      if (unit) {
        float dot = 0.0f;
        for (std::size_t d = 0; d < D; ++d) dot += x[d] * y[d];
        dist = std::sqrt(std::max(0.0f, 2.0f - 2.0f * dot));
      } else {
        dist = static_cast<float>(DescriptorDistance(metric, Span<const float>(x, D), Span<const float>(y, D)));
      }
      const int pc = static_cast<int>(j * static_cast<std::size_t>(h.cols) / b.size());
      float& v = h.values[static_cast<std::size_t>(pr) * static_cast<std::size_t>(h.cols) + static_cast<std::size_t>(pc)];
      if (std::isnan(v) || dist < v) v = dist;
    }
  }
  h.vmin = 0.0f;
  h.vmax = 0.6f;
  h.max_grid_px = 800;
  return h;
}

int CellOf(std::size_t index, std::size_t n, int cells) {
  return n == 0 ? 0 : static_cast<int>(index * static_cast<std::size_t>(cells) / n);
}

struct ReportWriter {
  std::string dir;
  std::vector<std::string> failed;
  void Write(const std::string& name, const Result<platform::RgbImage>& image) {
    const std::string path = dir + "/" + name;
    if (!image.ok()) {
      failed.push_back(name + ": " + image.status().message());
      return;
    }
    if (Status st = platform::WritePng(path, *image); !st.ok()) failed.push_back(st.message());
  }
};

// Affinity matrix per pair with stage A's cluster and L_K's loops.
void WriteAffinityPictures(const RunJob& job, ReportWriter* rep) {
  for (int a = 0; a < job.num_robots(); ++a) {
    for (int b = a + 1; b < job.num_robots(); ++b) {
      const ExchangeCascadeResult* c = job.server->cascade(a, b);
      if (!c) continue;
      const RobotKeyframeDb& A = job.server->robot(a);
      const RobotKeyframeDb& B = job.server->robot(b);
      platform::HeatmapInput h = AffinityPicture(A, B, 800, job.server->params().cascade.metric);
      if (c->stage_a.found) {
        platform::HeatmapRect rect;
        rect.row0 = CellOf(c->stage_a.best.row_min, A.size(), h.rows);
        rect.row1 = CellOf(c->stage_a.best.row_max, A.size(), h.rows);
        rect.col0 = CellOf(c->stage_a.best.col_min, B.size(), h.cols);
        rect.col1 = CellOf(c->stage_a.best.col_max, B.size(), h.cols);
        h.rects.push_back(rect);
      }
      for (const SequentialLoopCell& l : c->stage_c.selected_loops) {
        platform::HeatmapMark mark;
        mark.row = CellOf(l.alpha_index, A.size(), h.rows);
        mark.col = CellOf(l.beta_index, B.size(), h.cols);
        h.marks.push_back(mark);
      }
      h.title = "R-SOLiD distance, robot " + std::to_string(a) + " x robot " + std::to_string(b) +
                " (red: stage A cluster, dots: L_K)";
      h.row_label = "robot " + std::to_string(a) + " keyframe";
      h.col_label = "robot " + std::to_string(b) + " keyframe";
      rep->Write("affinity_" + std::to_string(a) + "_" + std::to_string(b) + ".png", platform::RenderHeatmap(h));
    }
  }
}

// Trajectories in the world frame with the scans the final mode requested.
void WriteTrajectoryPicture(const RunJob& job, ReportWriter* rep) {
  const ModeOutcome& final_mode = job.outcomes.back();
  platform::TrajectoryPlotInput tp;
  tp.title = "trajectories (world = robot 0), discs: scans sent in mode " + std::string(ExchangeModeName(final_mode.mode));
  for (int r = 0; r < job.num_robots(); ++r) {
    platform::TrajectorySeries s;
    s.name = "robot " + std::to_string(r);
    s.robot_index = r;
    const Eigen::Isometry3d T = final_mode.round.T_world_map(r);
    if (!final_mode.round.in_world(r)) s.name += " (own frame: not merged)";
    for (const Eigen::Isometry3d& P : job.trajectories[static_cast<std::size_t>(r)].estimated) {
      const Eigen::Vector3d p = (T * P).translation();
      s.path.push_back({static_cast<float>(p.x()), static_cast<float>(p.y())});
    }
    for (const ScanRequest& q : final_mode.round.plan.requests) {
      if (q.robot_id != r) continue;
      for (std::uint32_t k : q.keyframes) {
        if (k < s.path.size()) s.highlighted.push_back(static_cast<int>(k));
      }
    }
    tp.robots.push_back(std::move(s));
  }
  rep->Write("trajectories_selected.png", platform::RenderTrajectories(tp));
}

void WriteMapAndBytePictures(const RunJob& job, const MergedMapBuilder& after, const MergedMapBuilder& before,
                             ReportWriter* rep) {
  std::vector<std::string> names;
  for (int r = 0; r < job.num_robots(); ++r) names.push_back("robot " + std::to_string(r));
  platform::TopViewInput view;
  view.points = Span<const PointXYZI>(before.points());
  view.robot_ids = Span<const std::uint16_t>(before.robot_ids());
  view.robot_names = names;
  view.title = "before merging: every robot's map in its own frame";
  rep->Write("map_before.png", platform::RenderTopView(view));
  view.points = Span<const PointXYZI>(after.points());
  view.robot_ids = Span<const std::uint16_t>(after.robot_ids());
  view.title = "after merging (" + std::string(ExchangeModeName(job.outcomes.back().mode)) + "): world = robot 0";
  rep->Write("map_after.png", platform::RenderTopView(view));
  platform::BarChartInput bars;
  bars.series = {"keyframes", "pose updates", "policies", "scans"};
  bars.log_scale = true;
  bars.title = "bytes exchanged per mode (LCM-encoded)";
  bars.value_label = "bytes";
  for (const ModeOutcome& m : job.outcomes) {
    bars.groups.push_back(ExchangeModeName(m.mode));
    bars.values.push_back(static_cast<double>(job.stream_ledger->KindTotal(MessageKind::kKeyframes).bytes));
    bars.values.push_back(static_cast<double>(job.stream_ledger->KindTotal(MessageKind::kPoseUpdates).bytes +
                                              m.ledger->KindTotal(MessageKind::kPoseUpdates).bytes));
    bars.values.push_back(static_cast<double>(m.ledger->KindTotal(MessageKind::kPolicies).bytes));
    bars.values.push_back(static_cast<double>(m.scan_bytes()));
  }
  rep->Write("bytes_per_mode.png", platform::RenderBarChart(bars));
}

// Machine-readable figures (profiling/bench_scenarios.sh reads them).
void WriteMetrics(const RunJob& job) {
  std::string t = "key\tvalue\n";
  auto kv = [&t](const std::string& k, const std::string& v) { t += k + "\t" + v + "\n"; };
  kv("robots", std::to_string(job.num_robots()));
  std::size_t keyframes = 0;
  for (const RobotRun& r : job.robots) keyframes += r.agent->mapper().num_keyframes();
  kv("keyframes_total", std::to_string(keyframes));
  kv("robots_s", Fmt("%.3f", job.robots_s));
  kv("cascade_s", Fmt("%.3f", job.cascade_s));
  kv("stream_bytes", std::to_string(job.stream_bytes()));
  kv("raw_keyframe_scan_bytes", std::to_string(job.raw_keyframe_bytes()));
  for (int ri = 0; ri < job.num_robots(); ++ri) {
    const std::string p = "robot." + std::to_string(ri) + ".";
    const LoopErrors& le = job.loop_errors[static_cast<std::size_t>(ri)];
    kv(p + "loops", std::to_string(job.robots[static_cast<std::size_t>(ri)].loops.size()));
    kv(p + "false_loops", std::to_string(le.checked < 0 ? -1 : le.wrong));
    kv(p + "loop_candidates_refused",
       std::to_string(job.robots[static_cast<std::size_t>(ri)].agent->mapper().stats().loop_candidates_rejected));
    kv(p + "scans_stored_finer",
       std::to_string(job.robots[static_cast<std::size_t>(ri)].agent->mapper().stats().scans_stored_finer));
    kv(p + "ground_up_tilt_deg",
       Fmt("%.2f", job.robots[static_cast<std::size_t>(ri)].agent->mapper().ground_up().tilt_deg()));
    if (le.checked > 0) {
      kv(p + "loop_error_median_m", Fmt("%.4f", le.median_m));
      kv(p + "loop_error_max_m", Fmt("%.4f", le.max_m));
    }
  }
  kv("stored_send_all_bytes", std::to_string(job.send_all_bytes));
  const ModeOutcome& final_mode = job.outcomes.back();
  WritePathAgreement(job, final_mode, kv);
  const std::vector<SharedPlace> shared = SharedPlaces(job, final_mode);
  for (std::size_t i = 0; i < final_mode.round.pairs.size(); ++i) {
    const PairMergeResult& p = final_mode.round.pairs[i];
    const std::string k = "pair." + std::to_string(p.alpha) + "-" + std::to_string(p.beta) + ".";
    if (!shared.empty()) kv(k + "shared_path_m", Fmt("%.1f", std::min(shared[i].alpha_path_m, shared[i].beta_path_m)));
    const bool no_place = !shared.empty() && !shared[i].shared;
    const std::string stopped = StoppedAt(final_mode, i);
    kv(k + "stopped", no_place && stopped != "merged" ? "no shared place" : stopped);
    if (p.attempted) kv(k + "submap_voxel_m", Fmt("%.3f", p.voxel_size_m));
    WriteRefinement(p.refinement, k, kv);
    if (const ExchangeCascadeResult* c = job.server->cascade(p.alpha, p.beta); c) {
      // status incumbent bound gap nodes LPs (stage C also the loops dropped beyond max_loops)
      for (const auto& [name, o] : {std::make_pair("stage_b", StageBOutcome(*c)), std::make_pair("stage_c", StageCOutcome(*c))}) {
        if (!o.ran) continue;
        kv(k + name, std::string(o.status) + " " + Fmt("%.6g", o.incumbent) + " " + Fmt("%.6g", o.bound) + " " +
                         Fmt("%.4f", o.gap) + " " + std::to_string(o.nodes) + " " + std::to_string(o.lp_solves) +
                         (std::string(name) == "stage_c" ? " " + std::to_string(o.loops_dropped) : std::string()));
      }
    }
    if (const ExchangeCascadeResult* c = job.server->cascade(p.alpha, p.beta); c && c->stage_a.found) {
      const SequentialCluster& best = c->stage_a.best;
      kv(k + "stage_a_keyframes", std::to_string(best.row_min) + "-" + std::to_string(best.row_max) + " " +
                                      std::to_string(best.col_min) + "-" + std::to_string(best.col_max));
      kv(k + "stage_a_span_cells", std::to_string(best.span_area()));
      kv(k + "stage_a_next_span_cells", std::to_string(c->stage_a.second_span_area));
      if (c->verification) kv(k + "stage_a_verification", "1");
      if (c->ambiguous) kv(k + "stage_a_ambiguous", "1");
      if (c->ambiguity_measured) {
        kv(k + "stage_a_ambiguous_fraction", Fmt("%.2f", c->ambiguity.alpha_fraction()) + " " +
                                                 Fmt("%.2f", c->ambiguity.beta_fraction()));
      }
      if (c->consensus_measured) {
        kv(k + "stage_a_consensus_support", Fmt("%.0f", c->consensus_support_lowest_mean) + " " +
                                                Fmt("%.0f", c->consensus_support_chosen));
        if (c->consensus_switched) kv(k + "stage_a_consensus_switched", "1");
      }
      if (p.has_transform() && c->consensus_placement.valid) {
        const PlacementGap gap = GapToPlacement(c->consensus_placement, p.registration.T_target_source);
        kv(k + "registration_vs_placement_m_deg", Fmt("%.2f", gap.distance_m) + " " + Fmt("%.1f", gap.yaw_deg));
      }
      if (p.attempted && p.colocated_chance >= 0.0) {
        kv(k + "colocated_keyframes_chance", std::to_string(p.colocated_keyframes) + " " + Fmt("%.3f", p.colocated_chance));
      }
    }
    WritePlacedClusters(job, p.alpha, p.beta, k, kv);
    if (shared.empty()) continue;
    if (const double f = PairStageATrueFraction(job, p.alpha, p.beta); f >= 0.0) kv(k + "stage_a_true_fraction", Fmt("%.2f", f));
    const DistanceQuantiles q = PairDescriptorSeparation(job, p.alpha, p.beta);
    kv(k + "true_pairs", std::to_string(q.true_pairs));
    kv(k + "false_pairs", std::to_string(q.false_pairs));
    kv(k + "true_distance_p05_p50_p95", Fmt("%.3f", q.true_p05) + " " + Fmt("%.3f", q.true_p50) + " " + Fmt("%.3f", q.true_p95));
    kv(k + "false_distance_p01_p05_p50", Fmt("%.3f", q.false_p01) + " " + Fmt("%.3f", q.false_p05) + " " + Fmt("%.3f", q.false_p50));
  }
  const std::vector<RobotVerdict> verdicts = RobotVerdicts(job, final_mode);
  for (int r = 0; r < job.num_robots(); ++r) {
    const RobotVerdict& v = verdicts[static_cast<std::size_t>(r)];
    const std::string k = "robot." + std::to_string(r) + ".";
    kv(k + "reachable", v.has_gt ? std::to_string(v.reachable ? 1 : 0) : "-1");
    kv(k + "merged", std::to_string(v.merged ? 1 : 0));
    kv(k + "wrong", v.has_gt ? std::to_string(v.wrong ? 1 : 0) : "-1");
    if (v.merged && v.has_gt) {
      kv(k + "error_m", Fmt("%.3f", v.error.translation_m));
      kv(k + "error_deg", Fmt("%.2f", v.error.rotation_deg));
      if (v.judged_at_place) {
        kv(k + "error_at_place_m", Fmt("%.3f", v.error_at_place.translation_m));
        kv(k + "error_at_place_deg", Fmt("%.2f", v.error_at_place.rotation_deg));
        kv(k + "place_partner", std::to_string(v.place_partner));
      }
    }
  }
  kv("peak_rss_after_robots_bytes", std::to_string(job.robots_peak_rss));
  kv("peak_rss_end_bytes", std::to_string(platform::ReadRss().peak_bytes));
  for (const ModeOutcome& m : job.outcomes) {
    const std::string p = std::string("mode.") + ExchangeModeName(m.mode) + ".";
    std::size_t widened_pairs = 0;
    for (int w : m.round.widenings) widened_pairs += w > 0;
    kv(p + "scans", std::to_string(m.scans_requested()));
    kv(p + "scans_selected", std::to_string(m.round.plan.selected_scans));
    kv(p + "scans_padded", std::to_string(m.round.plan.padded_scans));
    kv(p + "scans_widened", std::to_string(m.round.widened_scans));
    kv(p + "scans_refined", std::to_string(m.round.refined_scans));
    kv(p + "widened_pairs", std::to_string(widened_pairs));
    kv(p + "scan_bytes", std::to_string(m.scan_bytes()));
    kv(p + "total_bytes", std::to_string(job.stream_bytes() + m.ledger->Total().bytes));
    // total_bytes by kind: the robots' stream (the same in every mode) plus this mode's ledger; "other" also takes
    // what either ledger could not classify, so the kinds sum to total_bytes exactly.
    for (std::size_t k = 0; k < kMessageKindCount; ++k) {
      const auto kind = static_cast<MessageKind>(k);
      std::uint64_t bytes = job.stream_ledger->KindTotal(kind).bytes + m.ledger->KindTotal(kind).bytes;
      if (kind == MessageKind::kOther) {
        bytes += job.stream_ledger->Unclassified().bytes + m.ledger->Unclassified().bytes;
      }
      kv(p + "bytes." + MessageKindName(kind), std::to_string(bytes));
    }
    kv(p + "pairs_merged", std::to_string(m.pairs_merged()) + "/" + std::to_string(m.round.pairs.size()));
    kv(p + "merge_s", Fmt("%.3f", m.merge_s));
    double worst = -1.0;
    std::size_t connected = 0;
    for (std::size_t r = 1; r < m.robot_eval.size(); ++r) {
      if (m.robot_eval[r].has_gt) {
        worst = std::max(worst, m.robot_eval[r].rmse_m);
        ++connected;
      }
    }
    kv(p + "robots_merged", std::to_string(connected) + "/" + std::to_string(job.num_robots() - 1));
    kv(p + "worst_rmse_m", Fmt("%.3f", worst));
  }
  if (std::FILE* f = std::fopen((job.report_dir + "/metrics.tsv").c_str(), "w")) {
    std::fputs(t.c_str(), f);
    std::fclose(f);
  }
}

}  // namespace

Eigen::Isometry3d LoopError(const RobotRun& r, const RobotRun::Loop& l) {
  return LoopErrorTransform(l.T_match_query, r.data.ground_truth[r.keyframe_scan[l.match]],
                            r.data.ground_truth[r.keyframe_scan[l.query]]);
}

double RotationDeg(const Eigen::Isometry3d& T) { return RotationAngleDeg(T); }

Status WriteLoops(const RobotRun& r, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return IoError("cannot write " + path);
  std::fprintf(f, "# query match  tx ty tz qx qy qz qw (T_match_query: ICP, refined by GICP where the robot did)%s\n",
               r.data.ground_truth.empty() ? "" : "  ex ey ez [m] e_rot [deg] (error against ground truth)");
  for (const RobotRun::Loop& l : r.loops) {
    const Eigen::Quaterniond q(l.T_match_query.linear());
    const Eigen::Vector3d& t = l.T_match_query.translation();
    std::fprintf(f, "%u %u %.4f %.4f %.4f %.6f %.6f %.6f %.6f", l.query, l.match, t.x(), t.y(), t.z(), q.x(), q.y(),
                 q.z(), q.w());
    if (!r.data.ground_truth.empty() && l.query < r.keyframe_scan.size() && l.match < r.keyframe_scan.size()) {
      const Eigen::Isometry3d error = LoopError(r, l);
      std::fprintf(f, " %.4f %.4f %.4f %.4f", error.translation().x(), error.translation().y(),
                   error.translation().z(), RotationDeg(error));
    }
    std::fprintf(f, "\n");
  }
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok) return IoError("error writing " + path);
  return Status::Ok();
}

std::string PrintResults(const RunJob& job) {
  std::string summary;
  auto line = [&summary](const std::string& s) {
    std::printf("%s\n", s.c_str());
    summary += s + "\n";
  };
  line("");
  line("| mode | scans sent (selected + padded + widened + refined) | scan bytes | policies | pose refresh | total exchanged | vs send-all | pairs merged | e_rmse (robots vs robot 0) | merge s |");
  line("|---|---|---|---|---|---|---|---|---|---|");
  for (const ModeOutcome& m : job.outcomes) line(ModeRow(job, m));
  line("(total exchanged = streamed keyframe records " + Bytes(job.stream_ledger->KindTotal(MessageKind::kKeyframes).bytes) +
       " + streamed pose updates " + Bytes(job.stream_ledger->KindTotal(MessageKind::kPoseUpdates).bytes) +
       ", the same in every mode, + policies + the requested keyframes' current poses + scans; LCM-encoded sizes)");
  const std::uint64_t raw_bytes = job.raw_keyframe_bytes();
  if (raw_bytes > 0) {
    const ModeOutcome& last = job.outcomes.back();
    line("(the paper's baseline, every keyframe's scan at full resolution as recorded (16 B per point), would be " +
         Bytes(raw_bytes) + "; " + std::string(ExchangeModeName(last.mode)) + " exchanges " +
         Fmt("%.2f %% less", 100.0 * (1.0 - static_cast<double>(job.stream_bytes() + last.ledger->Total().bytes) /
                                              static_cast<double>(raw_bytes))) +
         ". send-all above ships the robots' stored voxel-downsampled scans, a much smaller baseline)");
  }
  FinalResult(job, job.outcomes.back(), line);
  return summary;
}

void DumpKeyframes(const RunJob& job) {
  for (int r = 0; r < job.num_robots(); ++r) {
    const RobotKeyframeDb& db = job.server->robot(r);
    const Trajectories& t = job.trajectories[static_cast<std::size_t>(r)];
    const std::string path = job.report_dir + "/keyframes_" + std::to_string(r) + ".tsv";
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (f == nullptr) {
      std::fprintf(stderr, "%s: cannot write %s\n", job.tag, path.c_str());
      continue;
    }
    std::fprintf(f, "# keyframe valid x y z yaw_deg (map frame) gx gy gz gyaw_deg (ground truth, nan without) "
                    "then the %zu descriptor values\n", db.dim);
    for (std::size_t k = 0; k < db.size(); ++k) {
      const Eigen::Isometry3d& T = db.T_map_sensor[k];
      const bool gt = k < t.ground_truth.size();
      const Eigen::Isometry3d G = gt ? t.ground_truth[k] : Eigen::Isometry3d::Identity();
      const double nan = std::nan("");
      std::fprintf(f, "%zu %d %.4f %.4f %.4f %.3f %.4f %.4f %.4f %.3f", k, db.valid[k] ? 1 : 0, T.translation().x(),
                   T.translation().y(), T.translation().z(), YawRad(T.linear()) * kRadToDeg,
                   gt ? G.translation().x() : nan, gt ? G.translation().y() : nan, gt ? G.translation().z() : nan,
                   gt ? YawRad(G.linear()) * kRadToDeg : nan);
      for (std::size_t d = 0; d < db.dim; ++d) std::fprintf(f, " %.6g", static_cast<double>(db.descriptors[k * db.dim + d]));
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
}

std::string WriteRunOutputs(const RunJob& job, const std::string& summary) {
  // Both maps within the merged_map module (--merged-map-mb): half each when the report draws the map before.
  const std::int64_t map_bytes = job.memory.config.merged_map_bytes / (job.options.report ? 2 : 1);
  MergedMapBuilder after{MergedMapParamsForBytes(map_bytes)}, before{MergedMapParamsForBytes(map_bytes)};
  WriteMergeFiles(job, &after, job.options.report ? &before : nullptr);
  if (job.options.report) {
    ReportWriter rep{job.report_dir, {}};
    WriteAffinityPictures(job, &rep);
    WriteTrajectoryPicture(job, &rep);
    WriteMapAndBytePictures(job, after, before, &rep);
    for (const std::string& f : rep.failed) std::fprintf(stderr, "%s: report: %s\n", job.tag, f.c_str());
    if (std::FILE* f = std::fopen((job.report_dir + "/summary.md").c_str(), "w")) {
      std::fputs(("# commerge run\n\n```\n" + summary + "```\n").c_str(), f);
      std::fclose(f);
    }
  }
  WriteMetrics(job);
  if (job.options.dump_keyframes) DumpKeyframes(job);
  std::string text = std::to_string(after.points().size()) + " points";
  if (after.scans_left_out() > 0) {
    text += ", " + std::to_string(after.scans_left_out()) + " scans left out: the map is full at " +
            FormatBytes(map_bytes) + " (--merged-map-mb)";
  }
  return text;
}

}  // namespace commerge::app
