// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/place_consensus.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/common/number_text.hpp"
#include "core/geometry/angles.hpp"

namespace commerge {
namespace {

bool FiniteNonNegative(double v) { return std::isfinite(v) && v >= 0.0; }

double XyDiagonal(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return std::hypot(hi.x() - lo.x(), hi.y() - lo.y());
}

// a in (-pi, pi].
double WrappedRad(double a) {
  a = std::remainder(a, 2.0 * kPi);
  return a <= -kPi ? a + 2.0 * kPi : a;
}

}  // namespace

Eigen::Vector3d ClusterPlacement::Apply(const Eigen::Vector3d& p_beta) const {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  return Eigen::Vector3d(c * p_beta.x() - s * p_beta.y(), s * p_beta.x() + c * p_beta.y(), p_beta.z()) +
         t_alpha_beta_m;
}

Status ValidatePlaceConsensusParams(const PlaceConsensusParams& p) {
  const struct {
    const char* name;
    double value;
  } fields[] = {{"agree_m", p.agree_m}, {"agree_per_m", p.agree_per_m}, {"agree_deg", p.agree_deg},
                {"min_extent_m", p.min_extent_m}};
  for (const auto& f : fields) {
    if (!FiniteNonNegative(f.value)) {
      return InvalidArgument(std::string("place consensus: ") + f.name + " must be finite and >= 0, got " +
                             FormatNumber(f.value, 4));
    }
  }
  if (!(std::isfinite(p.switch_ratio) && p.switch_ratio >= 1.0)) {
    return InvalidArgument("place consensus: switch_ratio must be finite and >= 1, got " +
                           FormatNumber(p.switch_ratio, 4));
  }
  return Status::Ok();
}

Result<ClusterPlacement> PlaceCluster(Span<const SequentialLoopCell> cells, const SequentialCluster& cluster,
                                      Span<const Eigen::Vector3d> alpha_positions_m,
                                      Span<const Eigen::Vector3d> beta_positions_m, const PlaceConsensusParams& params) {
  if (cells.empty()) return InvalidArgument("place consensus: a cluster without cells");
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  Eigen::Vector3d lo_a = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi_a = -lo_a, lo_b = lo_a, hi_b = -lo_a;
  for (const SequentialLoopCell& c : cells) {
    if (c.alpha_index >= alpha_positions_m.size() || c.beta_index >= beta_positions_m.size()) {
      return InvalidArgument("place consensus: cell (" + std::to_string(c.alpha_index) + ", " +
                             std::to_string(c.beta_index) + ") outside the " + std::to_string(alpha_positions_m.size()) +
                             " x " + std::to_string(beta_positions_m.size()) + " keyframe positions");
    }
    const Eigen::Vector3d& a = alpha_positions_m[c.alpha_index];
    const Eigen::Vector3d& b = beta_positions_m[c.beta_index];
    if (!a.allFinite() || !b.allFinite()) {
      return InvalidArgument("place consensus: keyframe position not finite (alpha " + std::to_string(c.alpha_index) +
                             ", beta " + std::to_string(c.beta_index) + ")");
    }
    ca += a;
    cb += b;
    lo_a = lo_a.cwiseMin(a);
    hi_a = hi_a.cwiseMax(a);
    lo_b = lo_b.cwiseMin(b);
    hi_b = hi_b.cwiseMax(b);
  }
  const double n = static_cast<double>(cells.size());
  ca /= n;
  cb /= n;
  ClusterPlacement out;
  out.place_beta_m = cb;
  out.weight = static_cast<double>(std::min(cluster.span_rows(), cluster.span_cols()));
  if (std::min(XyDiagonal(lo_a, hi_a), XyDiagonal(lo_b, hi_b)) < params.min_extent_m) return out;
  double cross = 0.0, dot = 0.0;
  for (const SequentialLoopCell& c : cells) {
    const Eigen::Vector3d a = alpha_positions_m[c.alpha_index] - ca;
    const Eigen::Vector3d b = beta_positions_m[c.beta_index] - cb;
    cross += b.x() * a.y() - b.y() * a.x();
    dot += b.x() * a.x() + b.y() * a.y();
  }
  out.valid = true;
  out.yaw_rad = std::atan2(cross, dot);
  out.t_alpha_beta_m.setZero();
  out.t_alpha_beta_m = ca - out.Apply(cb);
  double sum_sq = 0.0;
  for (const SequentialLoopCell& c : cells) {
    sum_sq += (out.Apply(beta_positions_m[c.beta_index]) - alpha_positions_m[c.alpha_index]).squaredNorm();
  }
  out.rms_m = std::sqrt(sum_sq / n);
  return out;
}

bool PlacementsAgree(const ClusterPlacement& a, const ClusterPlacement& b, const PlaceConsensusParams& params) {
  if (!a.valid || !b.valid) return false;
  if (std::abs(WrappedRad(a.yaw_rad - b.yaw_rad)) > params.agree_deg * kDegToRad) return false;
  const double tolerance_m = params.agree_m + params.agree_per_m * (a.place_beta_m - b.place_beta_m).norm();
  for (const Eigen::Vector3d* p : {&a.place_beta_m, &b.place_beta_m}) {
    if ((a.Apply(*p) - b.Apply(*p)).norm() > tolerance_m) return false;
  }
  return true;
}

PlacementGap GapToPlacement(const ClusterPlacement& placement, const Eigen::Isometry3d& T_alpha_beta) {
  PlacementGap gap;
  gap.distance_m = (T_alpha_beta * placement.place_beta_m - placement.Apply(placement.place_beta_m)).norm();
  // Yaw of T: the heading of its image of the x axis, projected on the horizontal plane.
  const Eigen::Vector3d x = T_alpha_beta.linear() * Eigen::Vector3d::UnitX();
  gap.yaw_deg = std::abs(WrappedRad(std::atan2(x.y(), x.x()) - placement.yaw_rad)) / kDegToRad;
  return gap;
}

ClusterPlacement InvertPlacement(const ClusterPlacement& alpha_beta) {
  ClusterPlacement out;
  out.valid = alpha_beta.valid;
  out.yaw_rad = -alpha_beta.yaw_rad;
  const double c = std::cos(out.yaw_rad), s = std::sin(out.yaw_rad);
  const Eigen::Vector3d& t = alpha_beta.t_alpha_beta_m;
  out.t_alpha_beta_m = -Eigen::Vector3d(c * t.x() - s * t.y(), s * t.x() + c * t.y(), t.z());
  out.place_beta_m = alpha_beta.Apply(alpha_beta.place_beta_m);
  out.rms_m = alpha_beta.rms_m;
  out.weight = alpha_beta.weight;
  return out;
}

ClusterPlacement ComposePlacements(const ClusterPlacement& a_b, const ClusterPlacement& b_c) {
  ClusterPlacement out;
  out.valid = a_b.valid && b_c.valid;
  out.yaw_rad = WrappedRad(a_b.yaw_rad + b_c.yaw_rad);
  out.t_alpha_beta_m = a_b.Apply(b_c.t_alpha_beta_m);
  out.place_beta_m = b_c.place_beta_m;
  out.rms_m = a_b.rms_m + b_c.rms_m;
  out.weight = std::min(a_b.weight, b_c.weight);
  return out;
}

std::vector<PlaceCheckVerdict> CheckPlacesAcrossPairs(Span<const PairPlacement> pairs, int num_robots,
                                                      double min_support, const PlaceConsensusParams& agreement) {
  std::vector<PlaceCheckVerdict> out(pairs.size());
  // Robot `to`'s map in robot `from`'s from a strongly supported pair; invalid when there is none.
  auto strong = [&](int from, int to) {
    const int a = std::min(from, to), b = std::max(from, to);
    for (const PairPlacement& p : pairs) {
      if (p.alpha != a || p.beta != b) continue;
      if (!p.placed || !p.placement.valid || p.support < min_support) break;
      return from < to ? p.placement : InvertPlacement(p.placement);
    }
    return ClusterPlacement{};
  };
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const PairPlacement& p = pairs[i];
    PlaceCheckVerdict& v = out[i];
    v.checked = p.placed && p.placement.valid && p.support < min_support;
    if (!v.checked) continue;
    for (int c = 0; c < num_robots; ++c) {
      if (c == p.alpha || c == p.beta) continue;
      const ClusterPlacement chain = ComposePlacements(strong(p.alpha, c), strong(c, p.beta));
      if (!chain.valid) continue;
      ++v.chains;
      v.via.push_back(c);
      if (PlacementsAgree(p.placement, chain, agreement)) ++v.agreeing;
    }
  }
  return out;
}

Result<PlaceConsensus> RunPlaceConsensus(const SequentialClusterSet& set, std::size_t preferred,
                                         std::uint64_t min_span_area, Span<const Eigen::Vector3d> alpha_positions_m,
                                         Span<const Eigen::Vector3d> beta_positions_m,
                                         const PlaceConsensusParams& params) {
  if (Status s = ValidatePlaceConsensusParams(params); !s.ok()) return s;
  const std::size_t k = set.clusters.size();
  if (preferred >= k) {
    return InvalidArgument("place consensus: preferred cluster " + std::to_string(preferred) + " of " +
                           std::to_string(k));
  }
  PlaceConsensus out;
  out.placements.reserve(k);
  for (std::size_t c = 0; c < k; ++c) {
    auto placed = PlaceCluster(set.CellsOf(c), set.clusters[c], alpha_positions_m, beta_positions_m, params);
    if (!placed.ok()) return placed.status();
    out.placements.push_back(*placed);
  }
  // Only valid clusters vote; an O(k^2) pass over the (budgeted) cluster set.
  std::vector<std::size_t> voters;
  for (std::size_t c = 0; c < k; ++c) {
    if (out.placements[c].valid) voters.push_back(c);
  }
  out.support.assign(k, 0.0);
  for (const std::size_t c : voters) {
    for (const std::size_t v : voters) {
      if (PlacementsAgree(out.placements[c], out.placements[v], params)) out.support[c] += out.placements[v].weight;
    }
  }
  out.chosen = preferred;
  std::size_t best = k;
  for (const std::size_t c : voters) {
    if (set.clusters[c].span_area() < min_span_area) continue;
    if (best == k || out.support[c] > out.support[best]) best = c;
  }
  if (best != k && best != preferred && out.support[best] >= params.switch_ratio * out.support[preferred] &&
      out.support[best] > out.support[preferred]) {
    out.chosen = best;
    out.switched = true;
    out.reason = "the cluster of lowest mean distance has support " + FormatNumber(out.support[preferred], 4) +
                 ", another qualifying cluster " + FormatNumber(out.support[best], 4) +
                 " (keyframes of clusters agreeing on where the robots met)";
  }
  return out;
}

}  // namespace commerge
