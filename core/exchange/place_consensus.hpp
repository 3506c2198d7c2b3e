// SPDX-License-Identifier: BSD-3-Clause
// commerge: place consensus among stage A's clusters (ours, not in the paper). Read with the two robots'
// keyframe positions, every cluster of stage A says where robot beta's map lies in robot alpha's: the
// transform about the vertical (yaw and a translation) that best maps beta's keyframe positions of its cells
// onto alpha's. The true shared places of a pair all say the same thing, up to odometry drift; a place that
// only looks alike (a repeated corridor, a second aisle) says something else. A cluster's support is the summed
// weight of the clusters that agree with it. The cascade (exchange_cascade.hpp) passes on the qualifying
// cluster of most support when the one of lowest mean distance (the paper's S*) has clearly less: the scans
// requested then come from the place the rest of the matrix confirms. No bytes are sent for this; the
// registration gates still decide every merge (core/agent/decisions/004-place-consensus.md).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/sequential_matching.hpp"
#include "core/memory/consensus_bound.hpp"

namespace commerge {

struct PlaceConsensusParams {
  /// [m] Two placements agree when each maps the other's place to within agree_m plus agree_per_m times the
  /// distance between the two places (odometry drift grows with it) ...
  double agree_m = 4.0;
  double agree_per_m = 0.05;  ///< [m per m]
  /// [deg] ... and their yaws differ by at most this.
  double agree_deg = 10.0;
  /// [m] A cluster whose keyframes of either robot span less than this gives no placement: its yaw is not
  /// determined by a few keyframes at one spot.
  double min_extent_m = 4.0;
  /// The cascade switches from S* to the best-supported qualifying cluster only when that one has at least
  /// this many times S*'s support (>= 1).
  double switch_ratio = 2.0;
};

/// InvalidArgument naming the field: a negative or non-finite tolerance, switch_ratio below 1.
Status ValidatePlaceConsensusParams(const PlaceConsensusParams& params);

/// Where one cluster places robot beta's map frame in robot alpha's: p_alpha = R_z(yaw_rad) p_beta + t_alpha_beta_m.
struct ClusterPlacement {
  bool valid = false;  ///< false when the cluster's keyframes span less than min_extent_m
  double yaw_rad = 0.0;
  Eigen::Vector3d t_alpha_beta_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d place_beta_m = Eigen::Vector3d::Zero();  ///< centroid of the cells' beta keyframes, beta's frame
  double rms_m = 0.0;  ///< residual of the fit over the cells
  double weight = 0.0; ///< min(span rows, span cols): keyframes of shared path the cluster stands for

  Eigen::Vector3d Apply(const Eigen::Vector3d& p_beta) const;
};

/// The least-squares yaw + translation over the cells (each cell pairs alpha keyframe i with beta keyframe j).
/// Errors: a cell index outside the positions, a non-finite position, no cells.
Result<ClusterPlacement> PlaceCluster(Span<const SequentialLoopCell> cells, const SequentialCluster& cluster,
                                      Span<const Eigen::Vector3d> alpha_positions_m,
                                      Span<const Eigen::Vector3d> beta_positions_m, const PlaceConsensusParams& params);

/// Symmetric; false when either is invalid.
bool PlacementsAgree(const ClusterPlacement& a, const ClusterPlacement& b, const PlaceConsensusParams& params);

/// The placement of robot alpha's map in robot beta's (p_beta = R_z(-yaw) (p_alpha - t)); its place is the
/// cluster's place seen in alpha's frame. Valid when `alpha_beta` is.
ClusterPlacement InvertPlacement(const ClusterPlacement& alpha_beta);
/// Robot c's map in robot a's through robot b: a_b after b_c (yaws add, t = R_z(yaw_ab) t_bc + t_ab); its place
/// is b_c's (in c's frame), its weight the smaller. Valid when both are.
ClusterPlacement ComposePlacements(const ClusterPlacement& a_b, const ClusterPlacement& b_c);

/// How far a registered transform (p_alpha = T_alpha_beta p_beta) lies from a placement at the placement's place:
/// the distance between the two images of place_beta_m, and the difference of the yaws (T's about the vertical).
struct PlacementGap {
  double distance_m = 0.0;
  double yaw_deg = 0.0;  ///< in [0, 180]
};
PlacementGap GapToPlacement(const ClusterPlacement& placement, const Eigen::Isometry3d& T_alpha_beta);

/// One robot pair's place for the check across pairs: robot beta's map in robot alpha's (alpha < beta), from the
/// cluster stage A passes on, and that cluster's consensus support; `placed` false when there is none.
struct PairPlacement {
  int alpha = 0, beta = 0;
  bool placed = false;
  double support = 0.0;
  ClusterPlacement placement;
};

struct PlaceCheckVerdict {
  bool checked = false;  ///< placed and support < min_support
  int chains = 0;        ///< third robots joined to both by pairs of support >= min_support
  int agreeing = 0;      ///< of those, the chains that agree with the pair's placement
  std::vector<int> via;  ///< the third robots of the chains
  bool refused() const { return checked && chains > 0 && agreeing == 0; }
};

/// The place check across pairs (ours): for each placed pair of support below min_support, every third robot c
/// whose pairs with both robots are placed with support >= min_support gives a chain, alpha_c after c_beta
/// (ComposePlacements, InvertPlacement for pairs stored the other way round); the pair is refused when it has
/// a chain and agrees (PlacementsAgree with `agreement`) with none. Pairs of one (alpha, beta) appear at most
/// once; robots are 0..num_robots-1. One verdict per pair, in order.
std::vector<PlaceCheckVerdict> CheckPlacesAcrossPairs(Span<const PairPlacement> pairs, int num_robots,
                                                      double min_support, const PlaceConsensusParams& agreement);

struct PlaceConsensus {
  std::vector<ClusterPlacement> placements;  ///< per cluster of the set
  std::vector<double> support;               ///< per cluster: summed weight of the valid clusters agreeing with it
  std::size_t chosen = 0;                    ///< index into the set: S*, or the cluster switched to
  bool switched = false;
  std::string reason;                        ///< when switched: S*'s support against the chosen one's
};

/// Places every cluster and scores it. `preferred` is S*'s index in the set; candidates are the clusters of
/// span area >= min_span_area. chosen = the valid candidate of most support (ties: the lower index) when its
/// support is at least switch_ratio times S*'s (an invalid S* has support 0), else `preferred`.
/// Errors: preferred out of range, bad params, PlaceCluster's errors.
Result<PlaceConsensus> RunPlaceConsensus(const SequentialClusterSet& set, std::size_t preferred,
                                         std::uint64_t min_span_area, Span<const Eigen::Vector3d> alpha_positions_m,
                                         Span<const Eigen::Vector3d> beta_positions_m,
                                         const PlaceConsensusParams& params);

}  // namespace commerge
