// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/pair_refinement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace commerge {

namespace {

bool Known(const RobotPoses& poses, std::size_t k) {
  return k < poses.T_map_sensor.size() && k < poses.pose_known.size() && poses.pose_known[k] != 0;
}

// Cell of a uniform grid (side `cell_m`) as one sortable key; coordinates are clamped to +-2^20 cells.
std::int64_t CellKey(const Eigen::Vector3d& p, double cell_m, int dx = 0, int dy = 0, int dz = 0) {
  constexpr double kHalf = static_cast<double>(1 << 20);
  const auto index = [&](double v, int d) {
    const double c = std::floor(v / cell_m) + d;
    return static_cast<std::int64_t>(std::clamp(c, -kHalf, kHalf - 1.0) + kHalf);
  };
  return (index(p.x(), dx) << 42) | (index(p.y(), dy) << 21) | index(p.z(), dz);
}

}  // namespace

Result<SpreadKeyframes> SpreadAlongSharedPath(const RobotPoses& alpha, const RobotPoses& beta,
                                              const Eigen::Isometry3d& T_alpha_beta,
                                              Span<const std::uint32_t> held_beta, const RefinementParams& params) {
  if (Status s = ValidateRefinementParams(params); !s.ok()) return s;
  if (!T_alpha_beta.matrix().allFinite()) return InvalidArgument("SpreadAlongSharedPath: T_alpha_beta is not finite");
  SpreadKeyframes out;
  if (params.scans_per_robot == 0) return out;
  // Alpha's keyframes by grid cell (side shared_path_m): a keyframe's neighbours within shared_path_m are in the 27
  // cells around its own.
  const double cell_m = params.shared_path_m;
  std::vector<std::pair<std::int64_t, std::uint32_t>> alpha_cells;
  for (std::size_t k = 0; k < alpha.T_map_sensor.size(); ++k) {
    if (Known(alpha, k)) alpha_cells.emplace_back(CellKey(alpha.T_map_sensor[k].translation(), cell_m), k);
  }
  std::sort(alpha_cells.begin(), alpha_cells.end());
  const auto nearest_alpha = [&](const Eigen::Vector3d& q, std::uint32_t* best) {
    double best_d2 = params.shared_path_m * params.shared_path_m;
    bool found = false;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const std::int64_t key = CellKey(q, cell_m, dx, dy, dz);
          auto it = std::lower_bound(alpha_cells.begin(), alpha_cells.end(), std::make_pair(key, std::uint32_t{0}));
          for (; it != alpha_cells.end() && it->first == key; ++it) {
            const double d2 = (alpha.T_map_sensor[it->second].translation() - q).squaredNorm();
            if (d2 <= best_d2 && (!found || d2 < best_d2 || it->second < *best)) {
              best_d2 = d2;
              *best = it->second;
              found = true;
            }
          }
        }
      }
    }
    return found;
  };
  // Candidates: beta's keyframes on the shared path, with alpha's nearest.
  struct Candidate {
    std::uint32_t beta = 0, alpha = 0;
    Eigen::Vector3d position;  // in alpha's map frame
    bool held = false;
    double distance_m = std::numeric_limits<double>::infinity();  // to the nearest pick
  };
  std::vector<Candidate> candidates;
  Eigen::Vector3d held_sum = Eigen::Vector3d::Zero();
  std::size_t held_count = 0;
  for (std::uint32_t k : held_beta) {
    if (!Known(beta, k)) continue;
    held_sum += T_alpha_beta * beta.T_map_sensor[k].translation();
    ++held_count;
  }
  for (std::size_t k = 0; k < beta.T_map_sensor.size(); ++k) {
    if (!Known(beta, k)) continue;
    Candidate c;
    c.beta = static_cast<std::uint32_t>(k);
    c.position = T_alpha_beta * beta.T_map_sensor[k].translation();
    if (!nearest_alpha(c.position, &c.alpha)) continue;
    c.held = std::find(held_beta.begin(), held_beta.end(), c.beta) != held_beta.end();
    candidates.push_back(c);
  }
  if (candidates.empty()) return out;
  // The first pick anchors the set where the pair was registered: the held candidate nearest the held keyframes'
  // centroid (any candidate when none is held).
  const Eigen::Vector3d centre = held_count > 0 ? Eigen::Vector3d(held_sum / static_cast<double>(held_count))
                                                : candidates.front().position;
  const auto anchor = std::min_element(candidates.begin(), candidates.end(), [&](const Candidate& a, const Candidate& b) {
    if (a.held != b.held) return a.held;
    return (a.position - centre).squaredNorm() < (b.position - centre).squaredNorm();
  });
  const auto take = [&](const Candidate& chosen) {
    out.beta_keyframes.push_back(chosen.beta);
    out.alpha_keyframes.push_back(chosen.alpha);
    out.places.emplace_back(chosen.alpha, chosen.beta);
    for (Candidate& c : candidates) c.distance_m = std::min(c.distance_m, (c.position - chosen.position).norm());
  };
  take(*anchor);
  // Farthest-point sampling: each further pick is the candidate farthest from every pick.
  for (std::size_t pick = 0; pick < params.scans_per_robot; ++pick) {
    const auto far = std::max_element(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      return a.distance_m < b.distance_m || (a.distance_m == b.distance_m && a.beta > b.beta);
    });
    if (!(far->distance_m >= params.min_spacing_m)) break;
    take(*far);
  }
  for (auto* v : {&out.alpha_keyframes, &out.beta_keyframes}) {
    std::sort(v->begin(), v->end());
    v->erase(std::unique(v->begin(), v->end()), v->end());
  }
  return out;
}

}  // namespace commerge
