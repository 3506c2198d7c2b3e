// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/merge_server_params.hpp"

#include <cctype>
#include <cmath>
#include <string>
#include <utility>

#include "core/cloud/scan_codec.hpp"

namespace commerge {

SequentialMatchParams ServerStageADefaults() {
  SequentialMatchParams p;
  p.neighbour_rank = 1;
  p.sequence_half_window = 4;
  p.tau_area = 400;
  p.tau_area_fraction = 0.3;
  p.min_tau_area = 100;
  p.tau_inter = 0.5;
  return p;
}

ExchangeCascadeParams ServerCascadeDefaults() {
  ExchangeCascadeParams p;
  p.stage_a = ServerStageADefaults();
  p.verification_area_fraction = 0.5;
  p.max_ambiguous_fraction = 0.75;
  p.consensus_max_cells = kServerConsensusMaxCells;
  return p;
}

PlaceConsensusParams ChainAgreementDefaults() {
  PlaceConsensusParams p;
  p.agree_m = 8.0;
  p.agree_per_m = 0.05;
  p.agree_deg = 20.0;
  return p;
}

const char* ExchangeModeName(ExchangeMode mode) noexcept {
  switch (mode) {
    case ExchangeMode::kSendAll: return "send-all";
    case ExchangeMode::kStageA: return "A";
    case ExchangeMode::kStageAB: return "A+B";
    case ExchangeMode::kStageAC: return "A+C";
    case ExchangeMode::kStageABC: return "A+B+C";
  }
  return "?";
}

Result<ExchangeMode> ExchangeModeFromName(const std::string& name) {
  std::string n;
  for (char c : name) n.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  if (n == "send-all" || n == "all") return ExchangeMode::kSendAll;
  if (n == "a") return ExchangeMode::kStageA;
  if (n == "a+b" || n == "ab") return ExchangeMode::kStageAB;
  if (n == "a+c" || n == "ac") return ExchangeMode::kStageAC;
  if (n == "a+b+c" || n == "abc") return ExchangeMode::kStageABC;
  return InvalidArgument("unknown exchange mode '" + name + "' (send-all, A, A+B, A+C, A+B+C)");
}

const char* StageBCoverName(StageBCover cover) noexcept {
  switch (cover) {
    case StageBCover::kPairwise: return "pairwise";
    case StageBCover::kJoint: return "joint";
  }
  return "?";
}

Result<StageBCover> StageBCoverFromName(const std::string& name) {
  if (name == "pairwise") return StageBCover::kPairwise;
  if (name == "joint") return StageBCover::kJoint;
  return InvalidArgument("unknown stage B cover '" + name + "' (pairwise, joint)");
}

Status ValidateRefinementParams(const RefinementParams& params) {
  if (params.scans_per_robot > 64) {
    return InvalidArgument("refine.scans_per_robot = " + std::to_string(params.scans_per_robot) + " is above 64");
  }
  const std::pair<const char*, double> lengths[] = {{"shared_path_m", params.shared_path_m},
                                                    {"min_spacing_m", params.min_spacing_m},
                                                    {"max_correction_m", params.max_correction_m},
                                                    {"max_correction_deg", params.max_correction_deg}};
  for (const auto& [name, value] : lengths) {
    if (!(std::isfinite(value) && value > 0.0)) {
      return InvalidArgument(std::string("refine.") + name + " = " + std::to_string(value) + " must be finite and > 0");
    }
  }
  return Status::Ok();
}

Status ValidateMergeServerParams(const MergeServerParams& params) {
  if (!(params.submap_voxel_size_m >= 5e-3) || !std::isfinite(params.submap_voxel_size_m)) {
    return InvalidArgument("submap_voxel_size_m = " + std::to_string(params.submap_voxel_size_m) +
                           " must be finite and >= 0.005");
  }
  if (!(std::isfinite(params.min_submap_voxel_size_m) && params.min_submap_voxel_size_m >= 5e-3 &&
        params.min_submap_voxel_size_m <= params.submap_voxel_size_m)) {
    return InvalidArgument("min_submap_voxel_size_m = " + std::to_string(params.min_submap_voxel_size_m) +
                           " must be in [0.005, submap_voxel_size_m = " + std::to_string(params.submap_voxel_size_m) + "]");
  }
  if (Status s = ValidatePairDecisionParams(params.decision); !s.ok()) return s;
  if (Status s = ValidatePlaceConsensusParams(params.chain_agreement); !s.ok()) {
    return Status(s.code(), "chain_agreement: " + s.message());
  }
  if (Status s = ValidateTransformAgreementParams(params.colocation); !s.ok()) {
    return Status(s.code(), "colocation: " + s.message());
  }
  if (params.max_submap_points < 100) {
    return InvalidArgument("max_submap_points = " + std::to_string(params.max_submap_points) + " must be >= 100");
  }
  if (params.registration_hypotheses < 1 || params.registration_hypotheses > 8) {
    return InvalidArgument("registration_hypotheses = " + std::to_string(params.registration_hypotheses) +
                           " is outside 1..8");
  }
  if (params.max_scans_held < 1) return InvalidArgument("max_scans_held must be >= 1");
  if (params.max_scan_points < 1 || params.max_scan_points > kMaxEncodedScanPoints) {
    return InvalidArgument("max_scan_points = " + std::to_string(params.max_scan_points) + " is outside 1.." +
                           std::to_string(kMaxEncodedScanPoints));
  }
  if (params.max_widen_steps < 0 || params.max_widen_steps > 8) {
    return InvalidArgument("max_widen_steps = " + std::to_string(params.max_widen_steps) + " is outside 0..8");
  }
  if (Status s = ValidateRefinementParams(params.refine); !s.ok()) return s;
  if (params.max_scan_bytes < (1u << 16)) {
    return InvalidArgument("max_scan_bytes = " + std::to_string(params.max_scan_bytes) + " must be >= 65536");
  }
  if (Status st = ValidateSequentialMatchParams(params.cascade.stage_a); !st.ok()) return st;
  if (Status st = ValidateStageCParams(params.cascade.stage_c); !st.ok()) return st;
  if (Status st = ValidateExchangePolicyParams(params.cascade.policy); !st.ok()) return st;
  SubmapRegistrationParams reg = MakeSubmapRegistrationParams(params.submap_voxel_size_m);
  reg.gates = params.gates;
  reg.max_hypotheses = params.registration_hypotheses;
  if (Status st = ValidateSubmapRegistrationParams(reg); !st.ok()) return st;
  return ValidateFrameSolverParams(params.frames);
}

const char* MergeProfileName(MergeProfile profile) noexcept {
  switch (profile) {
    case MergeProfile::kCommerge: return "commerge";
    case MergeProfile::kPaper: return "paper";
  }
  return "?";
}

Result<MergeProfile> MergeProfileFromName(const std::string& name) {
  if (name == "commerge") return MergeProfile::kCommerge;
  if (name == "paper") return MergeProfile::kPaper;
  return InvalidArgument("unknown profile '" + name + "' (commerge, paper)");
}

MergeServerParams MergeProfileParams(MergeProfile profile, const LidarScanTraits& traits) {
  MergeServerParams p;
  if (profile == MergeProfile::kCommerge) {
    // A few scans of a sensor narrower than 360 deg see little of a place, and robots that pass it the other way
    // round see other sides of it: the spread scans made the real forward-looking splits worse (decisions/031).
    if (traits.horizontal_fov_deg < 360.0 || traits.non_repetitive) p.refine.scans_per_robot = 0;
    return p;
  }
  p.cascade.stage_a = SequentialMatchParams{};
  p.cascade.stage_a.tau_inter = PaperTauInter(traits);
  p.cascade.verification_area_fraction = 0.0;
  p.cascade.max_ambiguous_fraction = 1.0;
  p.cascade.consensus_max_cells = 0;
  p.cascade.policy.min_scans_per_robot = 0;
  p.cascade.policy.min_points_per_robot = 0;
  p.decision.min_ambiguous_support = 0.0;
  p.decision.widen_ambiguous_support = 0.0;
  p.decision.chain_check_support = 0.0;
  p.decision.max_colocated_chance = 0.0;
  p.decision.disagree_odds = 0.0;
  p.max_widen_steps = 0;
  p.refine.scans_per_robot = 0;
  p.cover = StageBCover::kPairwise;
  p.min_submap_points = 0;
  return p;
}

}  // namespace commerge
