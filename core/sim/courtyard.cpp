// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/courtyard.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/sim_random.hpp"

namespace commerge {

namespace {

constexpr double kLoopStepM = 0.1;  // spacing of the loop's polyline

/// The walking loop: a rectangle with rounded corners, inset from the facades, counter-clockwise from the
/// middle of its +x side.
class WalkLoop {
 public:
  explicit WalkLoop(const CourtyardGeometry& g) {
    const double a = 0.5 * g.width_m - g.walk_inset_m, b = 0.5 * g.length_m - g.walk_inset_m;
    const double rc = std::min({g.corner_radius_m, 0.9 * a, 0.9 * b});
    // Corner centres counter-clockwise, and the straight run before each corner.
    const double cx[4] = {a - rc, -(a - rc), -(a - rc), a - rc};
    const double cy[4] = {b - rc, b - rc, -(b - rc), -(b - rc)};
    std::vector<Eigen::Vector2d> corners;
    for (int c = 0; c < 4; ++c) {
      const double start = c * 0.5 * kPi;
      for (int i = 0; i <= 20; ++i) {
        const double t = start + 0.5 * kPi * i / 20.0;
        corners.emplace_back(cx[c] + rc * std::cos(t), cy[c] + rc * std::sin(t));
      }
    }
    // Densify, starting at (a, 0).
    points_.emplace_back(a, 0.0);
    auto add_segment = [&](const Eigen::Vector2d p, const Eigen::Vector2d q) {  // copies: points_ grows
      const double len = (q - p).norm();
      const int n = std::max(1, static_cast<int>(std::ceil(len / kLoopStepM)));
      for (int i = 1; i <= n; ++i) points_.push_back(p + (q - p) * (static_cast<double>(i) / n));
    };
    add_segment(points_.back(), corners.front());
    for (std::size_t i = 1; i < corners.size(); ++i) add_segment(corners[i - 1], corners[i]);
    add_segment(corners.back(), Eigen::Vector2d(a, 0.0));  // the last corner ends at (a, -(b - rc))
    arc_.assign(points_.size(), 0.0);
    for (std::size_t i = 1; i < points_.size(); ++i) arc_[i] = arc_[i - 1] + (points_[i] - points_[i - 1]).norm();
  }

  double length() const { return arc_.back(); }

  /// Point and unit tangent at arc length s (any real s: wraps around the loop).
  void At(double s, Eigen::Vector2d* p, Eigen::Vector2d* tangent) const {
    const double L = length();
    s = std::fmod(s, L);
    if (s < 0) s += L;
    const std::size_t i = static_cast<std::size_t>(
        std::clamp<std::ptrdiff_t>(std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin(), 1,
                                   static_cast<std::ptrdiff_t>(arc_.size()) - 1));
    const double span = arc_[i] - arc_[i - 1];
    const double u = span > 0 ? (s - arc_[i - 1]) / span : 0.0;
    *p = points_[i - 1] + u * (points_[i] - points_[i - 1]);
    *tangent = span > 0 ? Eigen::Vector2d((points_[i] - points_[i - 1]) / span) : Eigen::Vector2d(0.0, 1.0);
  }

 private:
  std::vector<Eigen::Vector2d> points_;
  std::vector<double> arc_;
};

/// Where robot r starts on the loop [m of arc] and which way it walks (+1 / -1).
void WalkStart(const MissionParams& params, int r, double walk_m, double* start_s, double* direction) {
  *direction = 1.0;
  switch (params.overlap) {
    case OverlapMode::kPartial: *start_s = r * walk_m; break;
    case OverlapMode::kModerate: *start_s = 0.5 * r * walk_m; break;
    case OverlapMode::kComplete:
      if (!params.same_direction && r % 2 == 1) {
        *start_s = walk_m;
        *direction = -1.0;
      } else {
        *start_s = 1.5 * (r / 2);
      }
      break;
  }
}

}  // namespace

CourtyardGeometry CourtyardOf(const MissionParams& params) {
  SimRandom rng(MixSeed(params.seed, 0xC0A7ull, 1));
  CourtyardGeometry g;
  g.width_m = rng.Uniform(18.0, 26.0);
  g.length_m = rng.Uniform(36.0, 50.0);
  g.walk_inset_m = rng.Uniform(3.5, 5.0);
  return g;
}

double CourtyardLoopDistance(const CourtyardGeometry& g, double x, double y) {
  const double a = 0.5 * g.width_m - g.walk_inset_m, b = 0.5 * g.length_m - g.walk_inset_m;
  const double rc = std::min({g.corner_radius_m, 0.9 * a, 0.9 * b});
  // Signed distance to the rounded rectangle's boundary.
  const double qx = std::abs(x) - (a - rc), qy = std::abs(y) - (b - rc);
  const double outside = std::hypot(std::max(qx, 0.0), std::max(qy, 0.0));
  const double inside = std::min(std::max(qx, qy), 0.0);
  return std::abs(outside + inside - rc);
}

Result<MissionPlan> PlanCourtyardMission(const MissionParams& params) {
  if (Status st = ValidateMissionParams(params); !st.ok()) return st;
  if (params.world != WorldKind::kCourtyard) return InvalidArgument("courtyard mission: world must be courtyard");
  const CourtyardGeometry g = CourtyardOf(params);
  const WalkLoop loop(g);
  MissionPlan plan;
  plan.params = params;
  plan.sensor_height_m = kHandheldSensorHeightM;
  plan.lane_offset_m = 0.0;
  plan.speed_m_per_s = kHandheldSpeedMPerS;
  const double walk_m = (params.keyframes_per_robot - 1) * params.keyframe_spacing_m;
  const double tilt = (kHandheldTiltDeg + params.roll_pitch_wobble_deg) * kDegToRad;
  const double sway = kHandheldYawSwayDeg * kDegToRad;

  std::vector<double> starts(static_cast<std::size_t>(params.robots)), directions(starts.size());
  for (int r = 0; r < params.robots; ++r) WalkStart(params, r, walk_m, &starts[static_cast<std::size_t>(r)], &directions[static_cast<std::size_t>(r)]);
  // Keyframe k of robot r is on the shared tour when another robot walks within 1 m of arc of it.
  auto shared = [&](int r, double s) {
    const double L = loop.length();
    for (int q = 0; q < params.robots; ++q) {
      if (q == r) continue;
      const double lo = std::min(starts[static_cast<std::size_t>(q)], starts[static_cast<std::size_t>(q)] + directions[static_cast<std::size_t>(q)] * walk_m);
      double d = std::fmod(s - lo + 1.0, L);
      if (d < 0) d += L;
      if (d <= walk_m + 2.0 || walk_m + 2.0 >= L) return true;
    }
    return false;
  };

  for (int r = 0; r < params.robots; ++r) {
    SimRandom rng(MixSeed(params.seed, 0xC0A8ull, static_cast<std::uint64_t>(r)));
    double ph[6];
    for (double& v : ph) v = rng.Uniform(0.0, 2.0 * kPi);
    const double wander_m = rng.Uniform(0.3, 0.7);
    // How the carrier holds the sensor: pitched down by up to kHandheldHoldPitchDeg, rolled a little.
    const double hold_pitch = rng.Uniform(-kHandheldHoldPitchDeg, 0.3 * kHandheldHoldPitchDeg) * kDegToRad;
    const double hold_roll = rng.Uniform(-0.3, 0.3) * kHandheldHoldPitchDeg * kDegToRad;
    RobotMission robot;
    robot.id = r;
    std::vector<Eigen::Isometry3d> gt_poses;
    for (int k = 0; k < params.keyframes_per_robot; ++k) {
      const double walked = k * params.keyframe_spacing_m;
      const double s = starts[static_cast<std::size_t>(r)] + directions[static_cast<std::size_t>(r)] * walked;
      Eigen::Vector2d p, t;
      loop.At(s, &p, &t);
      t *= directions[static_cast<std::size_t>(r)];
      const Eigen::Vector2d left(-t.y(), t.x());
      p += wander_m * std::sin(2.0 * kPi * walked / 13.0 + ph[0]) * left;
      const double yaw = std::atan2(t.y(), t.x()) + sway * std::sin(2.0 * kPi * walked / 3.7 + ph[1]);
      const double roll = tilt * (0.6 * std::sin(2.0 * kPi * walked / 2.9 + ph[2]) + 0.4 * std::sin(2.0 * kPi * walked / 7.3 + ph[3]));
      const double pitch = tilt * (0.6 * std::sin(2.0 * kPi * walked / 3.3 + ph[4]) + 0.4 * std::sin(2.0 * kPi * walked / 8.9 + ph[5]));
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = RotationFromYawPitchRoll(yaw, pitch + hold_pitch, roll + hold_roll);
      T.translation() = Eigen::Vector3d(p.x(), p.y(), kHandheldSensorHeightM + 0.04 * std::sin(2.0 * kPi * walked / 1.7 + ph[1]));
      gt_poses.push_back(T);
      robot.times_s.push_back(walked / kHandheldSpeedMPerS);
      robot.on_shared_tour.push_back(shared(r, s) ? 1 : 0);
    }
    robot.T_gt_robotstart = gt_poses.front();
    const Eigen::Isometry3d T_start_gt = robot.T_gt_robotstart.inverse();
    for (std::size_t k = 0; k < gt_poses.size(); ++k) {
      robot.gt.push_back(k == 0 ? Eigen::Isometry3d::Identity() : Eigen::Isometry3d(T_start_gt * gt_poses[k]));
    }
    AddDriftingOdometry(params, r, &robot);
    plan.robots.push_back(std::move(robot));
  }
  return plan;
}

}  // namespace commerge
