// SPDX-License-Identifier: BSD-3-Clause
#include "apps/merge_flags.hpp"

#include <cstdint>
#include <sstream>
#include <string>

#include "core/exchange/exchange_policy.hpp"
#include "core/exchange/neighbour_rank.hpp"
#include "core/exchange/sequence_smoothing.hpp"

namespace commerge::app {

namespace {

using FlagType = MergeFlag::Type;

const MergeFlag kMergeFlags[] = {
    {"--tau-inter", "cascade.stage_a.tau_inter", "", 0.0, 2.0, "tau_inter",
     "stage A: a keyframe pair is a candidate when its descriptor distance (unit vectors, L2) is at most this; "
     "with --neighbour-rank a cap on the nearest neighbours (the default shown); with --neighbour-rank 0 the "
     "default is the paper's per sensor: 0.10 for a spinning, 0.05 for a non-repetitive --lidar", FlagType::kDouble,
     [](MergeServerParams* p) -> void* { return &p->cascade.stage_a.tau_inter; }},
    {"--tau-area", "cascade.stage_a.tau_area", "cells", 0.0, 1e12, "tau_area",
     "stage A: smallest span area (rows x columns of the bounding box) of an accepted cluster", FlagType::kUint64,
     [](MergeServerParams* p) -> void* { return &p->cascade.stage_a.tau_area; }},
    {"--sequence-half-window", "cascade.stage_a.sequence_half_window", "keyframes", 0.0,
     static_cast<double>(kMaxSequenceHalfWindow), "ours",
     "stage A thresholds the mean descriptor distance along 2w+1 keyframes of the diagonal or anti-diagonal "
     "through each cell instead of the cell alone (sequence matching as in SeqSLAM); bridges single keyframes "
     "that jump above --tau-inter in corridors; 0 = the paper's per-cell threshold",
     FlagType::kSize, [](MergeServerParams* p) -> void* { return &p->cascade.stage_a.sequence_half_window; }},
    {"--neighbour-rank", "cascade.stage_a.neighbour_rank", "keyframes", 0.0, static_cast<double>(kMaxNeighbourRank),
     "ours",
     "stage A keeps a cell only when it is among the k nearest keyframes of its row or of its column (after the "
     "sequence smoothing); --tau-inter is then a cap; 0 = the paper's absolute threshold alone",
     FlagType::kSize, [](MergeServerParams* p) -> void* { return &p->cascade.stage_a.neighbour_rank; }},
    {"--tau-area-fraction", "cascade.stage_a.tau_area_fraction", "", 0.0, 1.0, "ours",
     "stage A asks short missions for less: the span area becomes at most (this x the shorter robot's keyframes)^2, "
     "never below 100 cells; 0 = --tau-area as given (the paper)",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->cascade.stage_a.tau_area_fraction; }},
    {"--verify-area-fraction", "cascade.verification_area_fraction", "", 0.0, 1.0, "ours",
     "when no cluster of stage A spans the area asked but the largest spans at least this fraction of it, pass "
     "that cluster on and let registration's gates decide on the few scans it names; 0 = the paper (nothing "
     "below tau_area is passed on)",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->cascade.verification_area_fraction; }},
    {"--max-ambiguous-fraction", "cascade.max_ambiguous_fraction", "", 0.0, 1.0, "ours",
     "register a pair once, never widened (unless --widen-ambiguous-support), when more than this fraction of "
     "its stage A cluster's keyframes of either robot look as alike to another place of the robot's own map "
     "(more than 20 m away) as to the other robot (repeated structure); 1 = off (the paper)",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->cascade.max_ambiguous_fraction; }},
    {"--min-ambiguous-support", "decision.min_ambiguous_support", "keyframes", 0.0, 1e7, "ours",
     "a stage A cluster at an ambiguous place (--max-ambiguous-fraction) is passed on only when the place "
     "consensus (--consensus-max-cells) confirms it with at least this summed weight of agreeing clusters, its "
     "own included; 0 = off (the paper)",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->decision.min_ambiguous_support; }},
    {"--widen-ambiguous-support", "decision.widen_ambiguous_support", "keyframes", 0.0, 1e7, "ours",
     "a pair at an ambiguous place (--max-ambiguous-fraction) whose stage A cluster the place consensus confirms "
     "with at least this summed weight may be widened like any other (--max-widen-steps), and is merged only "
     "where that consensus places it (within the tolerances by which two clusters agree); 0 = off: an ambiguous "
     "pair is never widened",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->decision.widen_ambiguous_support; }},
    {"--chain-check-support", "decision.chain_check_support", "keyframes", 0.0, 1e7, "ours",
     "a pair whose stage A cluster has less place-consensus support than this is not passed on when a third "
     "robot, through two pairs supported at least this much, places the two maps elsewhere and no such robot "
     "agrees; 0 = off (the paper)",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->decision.chain_check_support; }},
    {"--consensus-max-cells", "cascade.consensus_max_cells", "cells", 0.0, 1e7, "ours",
     "place every stage A cluster from the robots' keyframe positions and pass on the qualifying cluster the "
     "other clusters agree with when the lowest-mean one has less than half its support (repeated places); "
     "over this many cells below threshold the cluster passed on is placed alone, its support its own weight "
     "(said in the pair's reason); 0 = off (the paper)",
     FlagType::kSize, [](MergeServerParams* p) -> void* { return &p->cascade.consensus_max_cells; }},
    {"--stage-b-max-nodes", "cascade.stage_b.max_nodes", "nodes", 1.0, 1e9, "ours",
     "stage B's branch-and-bound stops after this many nodes with the best cover and its proven gap (printed per "
     "pair); the same selection on every machine (a wall-clock cap of 60 s only guards a pathological graph)",
     FlagType::kInt64, [](MergeServerParams* p) -> void* { return &p->cascade.stage_b.max_nodes; }},
    {"--stage-c-max-nodes", "cascade.stage_c.max_nodes", "nodes", 1.0, 1e12, "ours",
     "stage C's clique search stops after this many nodes with the best clique and its proven gap (printed per "
     "pair); a wall-clock cap of 30 s only guards a pathological graph",
     FlagType::kInt64, [](MergeServerParams* p) -> void* { return &p->cascade.stage_c.max_nodes; }},
    {"--tau-con-m", "cascade.stage_c.tau_con_m", "m", 1e-3, 1e4, "tau_con",
     "stage C: two loops are compatible when their positional inconsistency is below this", FlagType::kDouble,
     [](MergeServerParams* p) -> void* { return &p->cascade.stage_c.tau_con_m; }},
    {"--min-submap-scans", "cascade.policy.min_scans_per_robot", "scans", 0.0,
     static_cast<double>(kMaxMinScansPerRobot), "ours",
     "fewest scans asked of each robot per pair: L_K's keyframes plus the nearest other keyframes of stage A's "
     "loops (0 = no such floor; with --min-submap-stored-points 0 too, exactly L_K's: the paper's policy)",
     FlagType::kUint32, [](MergeServerParams* p) -> void* { return &p->cascade.policy.min_scans_per_robot; }},
    {"--min-submap-stored-points", "cascade.policy.min_points_per_robot", "points", 0.0,
     static_cast<double>(kMaxMinPointsPerRobot), "ours",
     "fewest stored points asked of each robot per pair, by the point counts the robots report with their "
     "keyframes: L_K's keyframes plus the nearest other keyframes of stage A's loops until their scans hold this "
     "many (0 = no such rule; with --min-submap-scans, both rules hold)",
     FlagType::kUint32, [](MergeServerParams* p) -> void* { return &p->cascade.policy.min_points_per_robot; }},
    {"--min-submap-points", "min_submap_points", "points", 0.0, 1e7, "ours",
     "when the smaller submap of a pair keeps fewer points than this at 1 m voxels (a small scene), voxelise "
     "both finer, in steps of 1/sqrt(2) down to 0.25 m, while the smaller gains points (the robots' scans must hold "
     "the detail: --min-scan-points; try 4000 with 1000 there); 0 = always 1 m (the paper)",
     FlagType::kSize, [](MergeServerParams* p) -> void* { return &p->min_submap_points; }},
    {"--disagree-odds", "decision.disagree_odds", "odds", 0.0, 1e12, "ours",
     "before asking for scans: do not request a pair when the keyframes that stage A's placement puts side by side "
     "(outside its cluster) agree in descriptor as strangers' do at least this many times likelier than as at a "
     "true place (a keyframe agrees: chance <= 0.05, strangers 5 %, a true place at least 25 %); 0 = off (the paper)",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->decision.disagree_odds; }},
    {"--max-colocated-chance", "decision.max_colocated_chance", "", 0.0, 1.0, "ours",
     "refuse a registration that places keyframes of the two robots together (away from stage A's cluster; "
     "within 3 m and, for a forward-looking --lidar, its field of view of heading) whose descriptors rank among "
     "each other's nearest no better than this median chance (0 = the co-located keyframe is the nearest, 0.5 = "
     "strangers); 0 = off",
     FlagType::kDouble, [](MergeServerParams* p) -> void* { return &p->decision.max_colocated_chance; }},
    {"--min-colocated-keyframes", "decision.min_colocated_keyframes", "keyframes", 0.0, 1e7, "ours",
     "--max-colocated-chance judges a registration only when it places at least this many keyframes together",
     FlagType::kSize, [](MergeServerParams* p) -> void* { return &p->decision.min_colocated_keyframes; }},
    {"--max-widen-steps", "max_widen_steps", "steps", 0.0, 8.0, "ours",
     "when registration refuses a pair, ask again for up to twice its scans (more of stage A's keyframes) and "
     "register again, at most this many times per round (0 = the paper's single exchange)",
     FlagType::kInt, [](MergeServerParams* p) -> void* { return &p->max_widen_steps; }},
    {"--refine-scans", "refine.scans_per_robot", "scans", 0.0, 64.0, "ours",
     "once a pair is accepted, ask for up to this many more scans per robot, spread along the path the two robots "
     "share (at least 10 m apart and from the scans it was registered with), and refine its transform by GICP on "
     "them and the scan nearest where it was registered; the refined transform is kept when it passes the "
     "registration gates and moved at most 1 m and 2 deg; 0 = off (the paper; the default for a --lidar narrower "
     "than 360 deg, such as avia)",
     FlagType::kSize, [](MergeServerParams* p) -> void* { return &p->refine.scans_per_robot; }},
};

template <typename V>
CLI::Option* AddTyped(CLI::App* cmd, const std::string& name, void* field, const std::string& help) {
  return cmd->add_option(name, *static_cast<V*>(field), help);
}

}  // namespace

Span<const MergeFlag> MergeFlagTable() { return Span<const MergeFlag>(kMergeFlags, std::size(kMergeFlags)); }

std::string MergeFlagValue(const MergeFlag& f, MergeServerParams* params) {
  std::ostringstream text;
  void* field = f.bind(params);
  switch (f.type) {
    case FlagType::kDouble: text << *static_cast<double*>(field); break;
    case FlagType::kUint64: text << *static_cast<std::uint64_t*>(field); break;
    case FlagType::kSize: text << *static_cast<std::size_t*>(field); break;
    case FlagType::kUint32: text << *static_cast<std::uint32_t*>(field); break;
    case FlagType::kInt: text << *static_cast<int*>(field); break;
    case FlagType::kInt64: text << *static_cast<std::int64_t*>(field); break;
  }
  return text.str();
}

void AddMergeFlags(CLI::App* cmd, MergeServerParams* params, std::string* profile) {
  cmd->add_option("--profile", *profile,
                  "a named set of every flag below: 'commerge' = ours (the defaults shown), 'paper' = the paper's "
                  "cascade (stage A B_ij = [A_ij <= tau_inter] with the paper's tau_inter for --lidar, tau_area "
                  "10000, exactly the scans of L_K, one registration, none of our checks; SOLiD unless --descriptor "
                  "is given); a flag given on the command line wins over its profile")
      ->check(CLI::IsMember({"commerge", "paper"}))
      ->capture_default_str();
  for (const MergeFlag& f : MergeFlagTable()) {
    std::string help = f.help;
    help += std::string(" [") + (f.unit[0] != '\0' ? f.unit : "dimensionless") + "; " +
            (std::string(f.paper_symbol) == "ours" ? std::string("ours, not in the paper")
                                                   : std::string("paper: ") + f.paper_symbol) +
            "]";
    void* field = f.bind(params);
    CLI::Option* o = nullptr;
    switch (f.type) {
      case FlagType::kDouble: o = AddTyped<double>(cmd, f.flag, field, help); break;
      case FlagType::kUint64: o = AddTyped<std::uint64_t>(cmd, f.flag, field, help); break;
      case FlagType::kSize: o = AddTyped<std::size_t>(cmd, f.flag, field, help); break;
      case FlagType::kUint32: o = AddTyped<std::uint32_t>(cmd, f.flag, field, help); break;
      case FlagType::kInt: o = AddTyped<int>(cmd, f.flag, field, help); break;
      case FlagType::kInt64: o = AddTyped<std::int64_t>(cmd, f.flag, field, help); break;
    }
    o->check(CLI::Range(f.min_value, f.max_value))->capture_default_str();
  }
  cmd->add_option_function<std::string>(
         "--cover",
         [params](const std::string& name) {
           auto cover = StageBCoverFromName(name);
           if (!cover.ok()) throw CLI::ValidationError("--cover", cover.status().message());
           params->cover = *cover;
         },
         "stage B with three or more robots: 'pairwise' = one balanced cover per robot pair, each robot sends the "
         "union of its pairs' selections (the paper); 'joint' = one balanced cover of every pair's loops over all "
         "robots, a scan that serves two pairs paid for once [ours]")
      ->check(CLI::IsMember({"pairwise", "joint"}))
      ->default_str(StageBCoverName(params->cover));
}

Status ApplyMergeProfile(const CLI::App& cmd, const std::string& profile, const std::string& lidar,
                         MergeServerParams* params) {
  auto named = MergeProfileFromName(profile);
  if (!named.ok()) return Status(named.status().code(), "--profile: " + named.status().message());
  MergeServerParams out = MergeProfileParams(*named, ScanTraitsFor(lidar));
  for (const MergeFlag& f : MergeFlagTable()) {
    if (cmd.count(f.flag) == 0) continue;
    void* from = f.bind(params);
    void* to = f.bind(&out);
    switch (f.type) {
      case FlagType::kDouble: *static_cast<double*>(to) = *static_cast<double*>(from); break;
      case FlagType::kUint64: *static_cast<std::uint64_t*>(to) = *static_cast<std::uint64_t*>(from); break;
      case FlagType::kSize: *static_cast<std::size_t*>(to) = *static_cast<std::size_t*>(from); break;
      case FlagType::kUint32: *static_cast<std::uint32_t*>(to) = *static_cast<std::uint32_t*>(from); break;
      case FlagType::kInt: *static_cast<int*>(to) = *static_cast<int*>(from); break;
      case FlagType::kInt64: *static_cast<std::int64_t*>(to) = *static_cast<std::int64_t*>(from); break;
    }
  }
  if (cmd.count("--cover") > 0) out.cover = params->cover;
  *params = out;
  return Status::Ok();
}

std::string ProfileDescriptor(const std::string& profile, const std::string& fallback) {
  return profile == "paper" ? "solid" : fallback;
}

}  // namespace commerge::app
