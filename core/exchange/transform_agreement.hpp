// SPDX-License-Identifier: BSD-3-Clause
// commerge: descriptor agreement under a registered transform (ours, not in the paper). A transform between two
// robots' map frames says which of their keyframes stood at the same place: robot beta's keyframe j lies on top
// of robot alpha's keyframe i when T_alpha_beta maps j's position to within near_m of i's and their headings
// differ by at most max_heading_deg (a forward-looking sensor sees another scene from the other way round). At a
// true shared place the descriptors of such keyframes are near each other compared with the rest of alpha's
// keyframes; under a transform that aligned a look-alike they are as far as any two keyframes. The measure is a
// rank, so it needs no threshold per sensor: for each beta keyframe with m co-located alpha keyframes, the
// fraction r of alpha's keyframes whose descriptor is nearer to j's than the nearest co-located one, and the
// chance that the best of m keyframes drawn at random ranks as well, p = 1 - (1 - r)^m (0 = the co-located
// keyframe is j's nearest; uniform in [0, 1], median 0.5, when the transform placed j among strangers).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/place_consensus.hpp"

namespace commerge {

struct TransformAgreementParams {
  double near_m = 3.0;             ///< [m] co-located: positions within this after the transform
  double max_heading_deg = 180.0;  ///< [deg] and headings within this (180 = any)
  /// At most this many co-located beta keyframes are ranked, evenly spaced over them (>= 1): ranking one costs a
  /// descriptor distance to every alpha keyframe, and a median over 256 is as good as over 10 000
  /// (core/agent/decisions/010-descriptor-agreement.md).
  std::size_t max_ranked = 256;
};

/// InvalidArgument naming the field: near_m not positive and finite, max_heading_deg outside (0, 180],
/// max_ranked 0.
Status ValidateTransformAgreementParams(const TransformAgreementParams& params);

/// One robot's keyframes as the server holds them: descriptor_dim floats per keyframe (unit vectors), a valid
/// flag and a pose per keyframe in the robot's map frame.
struct KeyframeSetView {
  Span<const float> descriptors;
  Span<const std::uint8_t> valid;
  Span<const Eigen::Isometry3d> T_map_sensor;
  std::size_t size() const noexcept { return valid.size(); }
};

/// A beta keyframe with co-located alpha keyframes.
struct ColocatedKeyframe {
  std::uint32_t beta = 0;
  std::uint32_t alpha = 0;       ///< the co-located alpha keyframe of nearest descriptor
  float distance = 0.0f;         ///< its descriptor distance (the metric's; L2 of unit vectors by default)
  std::uint32_t candidates = 0;  ///< co-located alpha keyframes (m)
  float rank_fraction = 0.0f;    ///< fraction of alpha's valid keyframes strictly nearer in descriptor space (r)
  float chance = 0.0f;           ///< 1 - (1 - r)^m: how often the best of m random keyframes ranks as well
};

/// The beta keyframes (valid descriptor, outside [exclude_beta_min, exclude_beta_max]; min > max excludes none)
/// that T_alpha_beta (p_alpha = T p_beta) places within near_m and max_heading_deg of at least one valid alpha
/// keyframe, ranked, in ascending beta order: all of them, or max_ranked evenly spaced when there are more.
/// *colocated (optional) receives how many there are before that choice. Errors: sizes that disagree
/// (descriptors != dim x keyframes, poses != keyframes), dim 0, a non-finite transform, invalid params.
Result<std::vector<ColocatedKeyframe>> ColocatedKeyframes(const KeyframeSetView& alpha, const KeyframeSetView& beta,
                                                          std::size_t descriptor_dim,
                                                          const Eigen::Isometry3d& T_alpha_beta,
                                                          const TransformAgreementParams& params,
                                                          std::uint32_t exclude_beta_min = 1,
                                                          std::uint32_t exclude_beta_max = 0,
                                                          std::size_t* colocated = nullptr,
                                                          const DescriptorMetric& metric = {});

/// The median chance of the entries whose beta keyframe lies outside [exclude_beta_min, exclude_beta_max] (an
/// empty range, min > max, excludes nothing); -1 when none. *count receives how many entries it is over.
double MedianChance(Span<const ColocatedKeyframe> colocated, std::uint32_t exclude_beta_min,
                          std::uint32_t exclude_beta_max, std::size_t* count);

/// Descriptor agreement at a cluster's placement, before any scan is exchanged: the beta keyframes outside the
/// cluster's columns that the placement (as a transform about the vertical) co-locates with alpha keyframes.
struct PlacementAgreement {
  bool measured = false;       ///< the placement is valid and the keyframes could be ranked
  std::size_t colocated = 0;   ///< co-located beta keyframes outside the cluster (before max_ranked)
  std::size_t ranked = 0;      ///< of them, ranked
  std::size_t agreeing = 0;    ///< ranked ones of chance <= agree_chance
  double median_chance = -1.0; ///< over the ranked; -1 when none
};

/// How much likelier `agreeing` of `ranked` co-located keyframes are at a true shared place than among strangers,
/// as a natural log: each keyframe agrees (chance <= agree_chance) with probability agree_chance among strangers
/// (chance is uniform there) and with probability true_fraction at a true place, independently, so
/// ln odds = k ln(q / a) + (n - k) ln((1 - q) / (1 - a)) for n ranked, k agreeing, a = agree_chance,
/// q = true_fraction. 0 when nothing is ranked; negative: the keyframes look like strangers. Requires
/// 0 < agree_chance < true_fraction < 1 (ValidatePairDecisionParams) and agreeing <= ranked; NaN otherwise.
double AgreementLogOdds(std::size_t ranked, std::size_t agreeing, double agree_chance, double true_fraction);

/// T_alpha_beta of a placement: R_z(yaw_rad), t_alpha_beta_m.
Eigen::Isometry3d PlacementTransform(const ClusterPlacement& placement);

/// PlacementAgreement of `placement` (of `cluster`, whose beta columns are left out); an invalid placement gives
/// measured = false. Errors: agree_chance outside [0, 1] (or NaN), those of ColocatedKeyframes.
Result<PlacementAgreement> MeasurePlacementAgreement(const KeyframeSetView& alpha, const KeyframeSetView& beta,
                                                     std::size_t descriptor_dim, const ClusterPlacement& placement,
                                                     const SequentialCluster& cluster,
                                                     const TransformAgreementParams& params, double agree_chance,
                                                     const DescriptorMetric& metric = {});

}  // namespace commerge
