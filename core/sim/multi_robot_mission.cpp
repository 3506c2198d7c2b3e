// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/multi_robot_mission.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <deque>
#include <string>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/courtyard.hpp"
#include "core/sim/sim_random.hpp"

namespace commerge {

namespace {

constexpr double kDenseStepM = 0.5;  // spacing of the dense route polyline

/// Per-world layout and vehicle constants.
struct WorldLayout {
  double block_m;        // default grid spacing
  double block_min_m;    // smallest spacing used for short routes
  double jitter_frac;    // node position jitter / block
  double curve_frac;     // lateral bulge of curved edges / block (0 = straight)
  double lane_m;         // robots drive this far right of the centre line
  double speed_m_per_s;  // nominal speed
  double sensor_height_m;
  double smooth_m;       // half window of the path smoothing (corner radius ~ this)
};

WorldLayout LayoutOf(WorldKind kind) {
  switch (kind) {
    case WorldKind::kUrban: return {80.0, 40.0, 0.06, 0.0, 1.75, 8.0, 1.8, 5.0};
    case WorldKind::kCampus: return {70.0, 35.0, 0.12, 0.10, 0.6, 1.5, 1.0, 3.0};
    case WorldKind::kIndoor: return {24.0, 12.0, 0.0, 0.0, 0.3, 1.0, 0.6, 1.5};
    case WorldKind::kCave: return {40.0, 25.0, 0.22, 0.10, 0.0, 1.0, 0.8, 3.0};
    case WorldKind::kCourtyard: break;  // no network: core/sim/courtyard.cpp
  }
  return {80.0, 40.0, 0.0, 0.0, 1.0, 1.0, 1.8, 3.0};
}

std::string Lower(const std::string& s) {
  std::string out;
  for (char c : s) out.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  return out;
}

double SharedShare(OverlapMode mode) {
  switch (mode) {
    case OverlapMode::kComplete: return 1.0;
    case OverlapMode::kModerate: return 0.5;
    case OverlapMode::kPartial: return 0.15;
  }
  return 1.0;
}

double PolylineLength(const std::vector<Eigen::Vector2d>& p) {
  double len = 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) len += (p[i] - p[i - 1]).norm();
  return len;
}

/// Grid network with its walks.
class NetworkBuilder {
 public:
  NetworkBuilder(RoadNetwork* net, SimRandom* rng) : net_(net), rng_(rng) {}

  void MakeGrid(int nx, int ny, double block_m, const WorldLayout& layout) {
    net_->nx = nx;
    net_->ny = ny;
    net_->block_m = block_m;
    net_->node_xy.resize(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
    const double cx = 0.5 * (nx - 1) * block_m, cy = 0.5 * (ny - 1) * block_m;
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const double jx = layout.jitter_frac * block_m * rng_->Uniform(-1.0, 1.0);
        const double jy = layout.jitter_frac * block_m * rng_->Uniform(-1.0, 1.0);
        net_->node_xy[Node(i, j)] = Eigen::Vector2d(i * block_m - cx + jx, j * block_m - cy + jy);
      }
    }
    net_->edges.clear();
    edge_of_.assign(net_->node_xy.size() * 4, -1);
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        if (i + 1 < nx) AddEdge(Node(i, j), Node(i + 1, j), 0, layout);
        if (j + 1 < ny) AddEdge(Node(i, j), Node(i, j + 1), 1, layout);
      }
    }
    edge_len_.resize(net_->edges.size());
    for (std::size_t e = 0; e < net_->edges.size(); ++e) edge_len_[e] = PolylineLength(net_->edges[e].polyline);
  }

  std::size_t Node(int i, int j) const { return static_cast<std::size_t>(j) * net_->nx + i; }
  int I(int n) const { return n % net_->nx; }
  int J(int n) const { return n / net_->nx; }
  /// Neighbour of n in direction d (0 +x, 1 +y, 2 -x, 3 -y), or -1.
  int Neighbour(int n, int d) const {
    const int i = I(n) + (d == 0) - (d == 2), j = J(n) + (d == 1) - (d == 3);
    if (i < 0 || j < 0 || i >= net_->nx || j >= net_->ny) return -1;
    return static_cast<int>(Node(i, j));
  }
  int EdgeId(int n, int d) const { return edge_of_[static_cast<std::size_t>(n) * 4 + d]; }
  double EdgeLength(int a, int b) const { return edge_len_[static_cast<std::size_t>(net_->EdgeBetween(a, b))]; }

  /// Shortest path (in edges) from `from` to the nearest node satisfying goal, through allowed nodes.
  template <class Allowed, class Goal>
  std::vector<int> Bfs(int from, Allowed&& allowed, Goal&& goal) const {
    std::vector<int> parent(net_->node_xy.size(), -2);
    std::deque<int> queue{from};
    parent[static_cast<std::size_t>(from)] = -1;
    while (!queue.empty()) {
      const int n = queue.front();
      queue.pop_front();
      if (n != from && goal(n)) {
        std::vector<int> path;
        for (int v = n; v != -1; v = parent[static_cast<std::size_t>(v)]) path.push_back(v);
        std::reverse(path.begin(), path.end());
        return path;
      }
      for (int d = 0; d < 4; ++d) {
        const int m = Neighbour(n, d);
        if (m < 0 || parent[static_cast<std::size_t>(m)] != -2 || !allowed(m)) continue;
        parent[static_cast<std::size_t>(m)] = n;
        queue.push_back(m);
      }
    }
    return {};
  }

  /// Extends `walk` (non-empty) through allowed nodes by about `target_m`: prefers edges not driven yet
  /// (going straight on with probability 0.6), heads for the nearest undriven edge when all around are
  /// driven, never turns back unless at a dead end. `visits` counts edge traversals (shared across calls).
  template <class Allowed>
  void Explore(std::vector<int>* walk, Allowed&& allowed, double target_m, std::vector<int>* visits) {
    double len = 0.0;
    while (len < target_m) {
      const int cur = walk->back();
      const int prev = walk->size() >= 2 ? (*walk)[walk->size() - 2] : -1;
      int options[4], n_options = 0, fresh[4], n_fresh = 0, straight = -1;
      for (int d = 0; d < 4; ++d) {
        const int m = Neighbour(cur, d);
        if (m < 0 || !allowed(m)) continue;
        options[n_options++] = m;
        if (m != prev && (*visits)[static_cast<std::size_t>(EdgeId(cur, d))] == 0) {
          fresh[n_fresh++] = m;
          if (prev >= 0 && m - cur == cur - prev) straight = m;
        }
      }
      if (n_options == 0) return;
      int next = -1;
      if (n_fresh > 0) {
        next = (straight >= 0 && rng_->Uniform() < 0.6) ? straight : fresh[rng_->Below(static_cast<std::uint64_t>(n_fresh))];
      } else {
        const std::vector<int> path = Bfs(cur, allowed, [&](int n) {
          for (int d = 0; d < 4; ++d) {
            const int m = Neighbour(n, d);
            if (m >= 0 && allowed(m) && (*visits)[static_cast<std::size_t>(EdgeId(n, d))] == 0) return true;
          }
          return false;
        });
        if (path.size() >= 2) {
          for (std::size_t k = 1; k < path.size() && len < target_m; ++k) Step(walk, path[k], visits, &len);
          continue;
        }
        // Everything reachable is driven: wander on (no U-turn unless forced).
        int others[4], n_others = 0;
        for (int k = 0; k < n_options; ++k)
          if (options[k] != prev) others[n_others++] = options[k];
        next = n_others > 0 ? others[rng_->Below(static_cast<std::uint64_t>(n_others))] : options[0];
      }
      Step(walk, next, visits, &len);
    }
  }

  void Step(std::vector<int>* walk, int next, std::vector<int>* visits, double* len) {
    const int cur = walk->back();
    const int e = net_->EdgeBetween(cur, next);
    ++(*visits)[static_cast<std::size_t>(e)];
    *len += edge_len_[static_cast<std::size_t>(e)];
    walk->push_back(next);
  }

  double Length(const std::vector<int>& walk) const {
    double len = 0.0;
    for (std::size_t k = 1; k < walk.size(); ++k) len += EdgeLength(walk[k - 1], walk[k]);
    return len;
  }

 private:
  void AddEdge(std::size_t a, std::size_t b, int axis, const WorldLayout& layout) {
    RoadNetwork::Edge e;
    e.a = static_cast<int>(a);
    e.b = static_cast<int>(b);
    const Eigen::Vector2d pa = net_->node_xy[a], pb = net_->node_xy[b];
    if (layout.curve_frac <= 0.0) {
      e.polyline = {pa, pb};
    } else {
      const Eigen::Vector2d dir = (pb - pa).normalized();
      const Eigen::Vector2d normal(-dir.y(), dir.x());
      const double amp1 = layout.curve_frac * net_->block_m * rng_->Uniform(-1.0, 1.0);
      const double amp2 = 0.4 * layout.curve_frac * net_->block_m * rng_->Uniform(-1.0, 1.0);
      const double len = (pb - pa).norm();
      const int pieces = std::max(2, static_cast<int>(std::ceil(len / 2.0)));
      for (int k = 0; k <= pieces; ++k) {
        const double s = static_cast<double>(k) / pieces;
        e.polyline.push_back(pa + s * (pb - pa) + normal * (amp1 * std::sin(kPi * s) + amp2 * std::sin(2 * kPi * s)));
      }
    }
    const int id = static_cast<int>(net_->edges.size());
    net_->edges.push_back(std::move(e));
    edge_of_[a * 4 + (axis == 0 ? 0 : 1)] = id;
    edge_of_[b * 4 + (axis == 0 ? 2 : 3)] = id;
  }

  RoadNetwork* net_;
  SimRandom* rng_;
  std::vector<int> edge_of_;  // [node * 4 + direction]
  std::vector<double> edge_len_;
};

/// One sample of the dense route.
struct DensePoint {
  Eigen::Vector2d xy;
  bool shared;
};

/// Node walk -> dense offset polyline (lane offset to the right of the edge direction), then a moving average
/// over +-smooth_m rounds corners and U-turns.
std::vector<DensePoint> DenseRoute(const RoadNetwork& net, const std::vector<int>& walk,
                                   const std::vector<std::uint8_t>& step_shared, double lane_m, double smooth_m) {
  std::vector<DensePoint> raw;
  for (std::size_t k = 1; k < walk.size(); ++k) {
    const int e = net.EdgeBetween(walk[k - 1], walk[k]);
    const auto& poly = net.edges[static_cast<std::size_t>(e)].polyline;
    const bool forward = net.edges[static_cast<std::size_t>(e)].a == walk[k - 1];
    const std::size_t n = poly.size();
    for (std::size_t q = 0; q + 1 < n; ++q) {
      const Eigen::Vector2d a = forward ? poly[q] : poly[n - 1 - q];
      const Eigen::Vector2d b = forward ? poly[q + 1] : poly[n - 2 - q];
      const double len = (b - a).norm();
      if (len <= 1e-9) continue;
      const Eigen::Vector2d dir = (b - a) / len;
      const Eigen::Vector2d right(dir.y(), -dir.x());
      const int pieces = std::max(1, static_cast<int>(std::ceil(len / kDenseStepM)));
      for (int s = 0; s < pieces; ++s) {
        const double u = static_cast<double>(s) / pieces;
        raw.push_back({a + u * (b - a) + lane_m * right, step_shared[k - 1] != 0});
      }
    }
  }
  if (raw.empty()) return raw;
  const int half = std::max(1, static_cast<int>(std::lround(smooth_m / kDenseStepM)));
  std::vector<Eigen::Vector2d> prefix(raw.size() + 1, Eigen::Vector2d::Zero());
  for (std::size_t i = 0; i < raw.size(); ++i) prefix[i + 1] = prefix[i] + raw[i].xy;
  std::vector<DensePoint> out(raw.size());
  const int n = static_cast<int>(raw.size());
  for (int i = 0; i < n; ++i) {
    const int w = std::min({half, i, n - 1 - i});  // symmetric window, shrinking at the ends
    out[static_cast<std::size_t>(i)].xy =
        (prefix[static_cast<std::size_t>(i + w + 1)] - prefix[static_cast<std::size_t>(i - w)]) / (2 * w + 1);
    out[static_cast<std::size_t>(i)].shared = raw[static_cast<std::size_t>(i)].shared;
  }
  return out;
}

}  // namespace

const char* WorldKindName(WorldKind kind) noexcept {
  switch (kind) {
    case WorldKind::kUrban: return "urban";
    case WorldKind::kCampus: return "campus";
    case WorldKind::kIndoor: return "indoor";
    case WorldKind::kCave: return "cave";
    case WorldKind::kCourtyard: return "courtyard";
  }
  return "?";
}

const char* OverlapModeName(OverlapMode mode) noexcept {
  switch (mode) {
    case OverlapMode::kComplete: return "complete";
    case OverlapMode::kModerate: return "moderate";
    case OverlapMode::kPartial: return "partial";
  }
  return "?";
}

Result<WorldKind> WorldKindFromName(const std::string& name) {
  const std::string n = Lower(name);
  if (n == "urban") return WorldKind::kUrban;
  if (n == "campus") return WorldKind::kCampus;
  if (n == "indoor") return WorldKind::kIndoor;
  if (n == "cave" || n == "tunnel") return WorldKind::kCave;
  if (n == "courtyard") return WorldKind::kCourtyard;
  return InvalidArgument("unknown world '" + name + "' (known: urban, campus, indoor, cave, courtyard)");
}

Result<OverlapMode> OverlapModeFromName(const std::string& name) {
  const std::string n = Lower(name);
  if (n == "complete") return OverlapMode::kComplete;
  if (n == "moderate") return OverlapMode::kModerate;
  if (n == "partial") return OverlapMode::kPartial;
  return InvalidArgument("unknown overlap '" + name + "' (known: complete, moderate, partial)");
}

int RoadNetwork::EdgeBetween(int a, int b) const {
  if (a < 0 || b < 0 || nx <= 0) return -1;
  const int lo = std::min(a, b), hi = std::max(a, b);
  const int i = lo % nx, j = lo / nx;
  // Edges were added per node in order (+x edge, then +y edge): find by scanning the two candidates.
  // Index arithmetic: nodes before (i, j) contributed their edges; compute the count directly.
  auto edges_before = [&](int ii, int jj) {
    // full rows: each row has (nx - 1) +x edges and, except the last row, nx +y edges
    const int full_rows = jj;
    int count = full_rows * (nx - 1) + std::min(full_rows, ny - 1) * nx;
    // nodes of row jj before ii
    count += ii * ((jj + 1 < ny) ? 2 : 1);
    return count;
  };
  const int base = edges_before(i, j);
  if (hi == lo + 1 && (hi % nx) == i + 1) return base;                           // +x edge
  if (hi == lo + nx) return base + ((i + 1 < nx) ? 1 : 0);                       // +y edge
  return -1;
}

Status ValidateMissionParams(const MissionParams& p) {
  if (p.robots < 2 || p.robots > 5) return InvalidArgument("mission: robots must be in 2..5, got " + std::to_string(p.robots));
  if (p.keyframes_per_robot < 2 || p.keyframes_per_robot > 1000000) {
    return InvalidArgument("mission: keyframes_per_robot must be in 2..1000000, got " +
                           std::to_string(p.keyframes_per_robot));
  }
  if (!(p.keyframe_spacing_m >= 0.1 && p.keyframe_spacing_m <= 20.0)) {
    return InvalidArgument("mission: keyframe_spacing_m must be in [0.1, 20] m");
  }
  if (!(p.block_size_m == 0.0 || (p.block_size_m >= 8.0 && p.block_size_m <= 1000.0))) {
    return InvalidArgument("mission: block_size_m must be 0 (default) or in [8, 1000] m");
  }
  const DriftParams& d = p.drift;
  for (double v : {d.scale, d.translation_noise_frac, d.z_noise_frac, d.scale_bias_std, d.yaw_noise_deg_per_sqrt_m,
                   d.yaw_bias_std_deg_per_m, d.roll_pitch_noise_deg_per_sqrt_m}) {
    if (!std::isfinite(v) || v < 0.0) return InvalidArgument("mission: drift parameters must be finite and >= 0");
  }
  if (d.scale > 100.0) return InvalidArgument("mission: drift scale must be <= 100");
  if (!(p.roll_pitch_wobble_deg >= 0.0 && p.roll_pitch_wobble_deg <= 10.0)) {
    return InvalidArgument("mission: roll_pitch_wobble_deg must be in [0, 10]");
  }
  return Status::Ok();
}

std::uint64_t ScanNoiseSeed(const MissionParams& params, int robot, std::size_t k) {
  return MixSeed(params.seed ^ 0x5CA9ull, static_cast<std::uint64_t>(robot) + 1, static_cast<std::uint64_t>(k));
}

void AddDriftingOdometry(const MissionParams& params, int robot_index, RobotMission* robot) {
  robot->odometry.clear();
  const DriftParams& d = params.drift;
  SimRandom drift_rng(MixSeed(params.seed, 0x33ull + static_cast<std::uint64_t>(robot_index), 7));
  robot->scale_bias = d.scale * d.scale_bias_std * drift_rng.Gaussian();
  robot->yaw_bias_rad_per_m = d.scale * d.yaw_bias_std_deg_per_m * kDegToRad * drift_rng.Gaussian();
  robot->odometry.push_back(Eigen::Isometry3d::Identity());
  for (std::size_t k = 1; k < robot->gt.size(); ++k) {
    const Eigen::Isometry3d dT = robot->gt[k - 1].inverse() * robot->gt[k];
    const double step = dT.translation().norm();
    const double rs = std::sqrt(step);
    Eigen::Vector3d e_t(d.scale * d.translation_noise_frac * step * drift_rng.Gaussian(),
                        d.scale * d.translation_noise_frac * step * drift_rng.Gaussian(),
                        d.scale * d.z_noise_frac * step * drift_rng.Gaussian());
    const double rp = d.scale * d.roll_pitch_noise_deg_per_sqrt_m * kDegToRad * rs;
    const Eigen::Vector3d e_r(rp * drift_rng.Gaussian(), rp * drift_rng.Gaussian(),
                              robot->yaw_bias_rad_per_m * step +
                                  d.scale * d.yaw_noise_deg_per_sqrt_m * kDegToRad * rs * drift_rng.Gaussian());
    Eigen::Isometry3d reported = Eigen::Isometry3d::Identity();
    reported.linear() = dT.linear() * ExpSO3(e_r);
    reported.translation() = (1.0 + robot->scale_bias) * dT.translation() + e_t;
    Eigen::Isometry3d next = robot->odometry.back() * reported;
    // Keep the rotation orthonormal over long chains.
    const Eigen::Quaterniond q(next.linear());
    next.linear() = q.normalized().toRotationMatrix();
    robot->odometry.push_back(next);
  }
}

Result<MissionPlan> PlanMission(const MissionParams& params) {
  if (Status st = ValidateMissionParams(params); !st.ok()) return st;
  if (params.world == WorldKind::kCourtyard) return PlanCourtyardMission(params);
  const WorldLayout layout = LayoutOf(params.world);
  SimRandom rng(MixSeed(params.seed, 0x11ull, static_cast<std::uint64_t>(params.world)));
  MissionPlan plan;
  plan.params = params;
  plan.sensor_height_m = layout.sensor_height_m;
  plan.lane_offset_m = layout.lane_m;
  plan.speed_m_per_s = layout.speed_m_per_s;

  const int R = params.robots;
  const double route_m = params.keyframes_per_robot * params.keyframe_spacing_m;
  const double f = SharedShare(params.overlap);
  const bool complete = params.overlap == OverlapMode::kComplete;
  const int laps = complete ? 2 : 1;
  const double shared_target_m = 0.8 * f * route_m / laps;
  const double block_m = params.block_size_m > 0.0
                             ? params.block_size_m
                             : std::clamp(shared_target_m / (4.0 * 1.3), layout.block_min_m, layout.block_m);

  // Shared area: a x b blocks whose streets add up to about the shared tour.
  const double blocks = std::max(1.0, shared_target_m / (2.0 * block_m));
  const int a = std::max(1, static_cast<int>(std::lround(std::sqrt(blocks))));
  const int b = std::max(1, static_cast<int>(std::lround(blocks / a)));
  int nx = a + 1, ny = b + 1, si = 0, sj = 0;
  if (!complete) {
    const double private_nodes = std::max(8.0, (1.0 - f) * route_m / (2.0 * block_m) / 0.45);
    const double need = (a + 5.0) * (b + 5.0) + R * private_nodes;
    const int n = std::max(std::max(a, b) + 7, static_cast<int>(std::ceil(std::sqrt(need))));
    nx = ny = n;
    si = (n - 1 - a) / 2;
    sj = (n - 1 - b) / 2;
  }
  RoadNetwork& net = plan.network;
  NetworkBuilder builder(&net, &rng);
  builder.MakeGrid(nx, ny, block_m, layout);
  auto in_shared = [&](int n) {
    const int i = builder.I(n), j = builder.J(n);
    return i >= si && i <= si + a && j >= sj && j <= sj + b;
  };

  // Regions: shared area, then angular sectors around it separated by gap nodes.
  net.node_region.assign(net.node_xy.size(), -1);
  if (!complete) {
    const double theta0 = rng.Uniform(0.0, 2.0 * kPi);
    const double ci = si + 0.5 * a, cj = sj + 0.5 * b;
    auto sector = [&](int n) {
      double ang = std::atan2(builder.J(n) - cj, builder.I(n) - ci) - theta0;
      ang = std::fmod(ang + 4.0 * kPi, 2.0 * kPi);
      return std::min(R - 1, static_cast<int>(ang / (2.0 * kPi / R)));
    };
    for (int n = 0; n < static_cast<int>(net.node_xy.size()); ++n) {
      if (in_shared(n)) continue;
      int region = sector(n);
      for (int d = 0; d < 4; ++d) {
        const int m = builder.Neighbour(n, d);
        if (m >= 0 && (in_shared(m) || sector(m) != region)) region = -2;
      }
      net.node_region[static_cast<std::size_t>(n)] = region;
    }
    // Keep the largest connected piece of each region (sector borders can cut off small islands).
    std::vector<int> component(net.node_xy.size(), -1), best_component(static_cast<std::size_t>(R), -1);
    std::vector<std::size_t> best_size(static_cast<std::size_t>(R), 0);
    int components = 0;
    for (int n = 0; n < static_cast<int>(net.node_xy.size()); ++n) {
      const int region = net.node_region[static_cast<std::size_t>(n)];
      if (region < 0 || component[static_cast<std::size_t>(n)] >= 0) continue;
      const int id = components++;
      std::vector<int> stack{n};
      component[static_cast<std::size_t>(n)] = id;
      std::size_t size = 0;
      while (!stack.empty()) {
        const int v = stack.back();
        stack.pop_back();
        ++size;
        for (int d = 0; d < 4; ++d) {
          const int m = builder.Neighbour(v, d);
          if (m < 0 || component[static_cast<std::size_t>(m)] >= 0 || net.node_region[static_cast<std::size_t>(m)] != region) continue;
          component[static_cast<std::size_t>(m)] = id;
          stack.push_back(m);
        }
      }
      if (size > best_size[static_cast<std::size_t>(region)]) {
        best_size[static_cast<std::size_t>(region)] = size;
        best_component[static_cast<std::size_t>(region)] = id;
      }
    }
    for (int n = 0; n < static_cast<int>(net.node_xy.size()); ++n) {
      const int region = net.node_region[static_cast<std::size_t>(n)];
      if (region >= 0 && component[static_cast<std::size_t>(n)] != best_component[static_cast<std::size_t>(region)]) {
        net.node_region[static_cast<std::size_t>(n)] = -2;
      }
    }
  }

  // Connectors: shortest gap-node paths from the shared area's border to each private region.
  std::vector<std::vector<int>> connector(static_cast<std::size_t>(R));
  if (!complete) {
    std::vector<std::uint8_t> taken(net.node_xy.size(), 0);
    for (int r = 0; r < R; ++r) {
      std::vector<int> best;
      // Multi-source BFS over gap nodes from every shared node; the goal is a gap node next to region r.
      std::vector<int> parent(net.node_xy.size(), -2);
      std::deque<int> queue;
      for (int n = 0; n < static_cast<int>(net.node_xy.size()); ++n) {
        if (in_shared(n)) {
          parent[static_cast<std::size_t>(n)] = -1;
          queue.push_back(n);
        }
      }
      int goal = -1;
      while (!queue.empty() && goal < 0) {
        const int n = queue.front();
        queue.pop_front();
        for (int d = 0; d < 4 && goal < 0; ++d) {
          const int m = builder.Neighbour(n, d);
          if (m < 0 || parent[static_cast<std::size_t>(m)] != -2) continue;
          const int region = net.node_region[static_cast<std::size_t>(m)];
          if (region == r && !in_shared(n)) {
            parent[static_cast<std::size_t>(m)] = n;
            goal = m;
          } else if (region == -2 && !taken[static_cast<std::size_t>(m)]) {
            parent[static_cast<std::size_t>(m)] = n;
            queue.push_back(m);
          }
        }
      }
      if (goal < 0) {
        return Status(StatusCode::kInternal, "mission: no connector to the private region of robot " +
                                                 std::to_string(r) + " (grid " + std::to_string(nx) + " x " +
                                                 std::to_string(ny) + ")");
      }
      for (int v = goal; v != -1; v = parent[static_cast<std::size_t>(v)]) best.push_back(v);
      std::reverse(best.begin(), best.end());  // shared node, gap nodes..., region node
      for (int v : best)
        if (net.node_region[static_cast<std::size_t>(v)] == -2) taken[static_cast<std::size_t>(v)] = 1;
      connector[static_cast<std::size_t>(r)] = best;
    }
  }

  // Shared tour: a closed walk through the shared area passing every connector's end, explored in legs.
  std::vector<int> visits(net.edges.size(), 0);
  auto shared_ok = [&](int n) { return in_shared(n); };
  std::vector<int> waypoints;
  if (complete) {
    waypoints.push_back(static_cast<int>(builder.Node(si, sj)));
  } else {
    for (const auto& c : connector) waypoints.push_back(c.front());
    // Visit them in angular order around the shared area's centre, each once.
    const double ci = si + 0.5 * a, cj = sj + 0.5 * b;
    std::sort(waypoints.begin(), waypoints.end(), [&](int p, int q) {
      return std::atan2(builder.J(p) - cj, builder.I(p) - ci) < std::atan2(builder.J(q) - cj, builder.I(q) - ci);
    });
    waypoints.erase(std::unique(waypoints.begin(), waypoints.end()), waypoints.end());
  }
  // Length of the plain cycle through the waypoints; the rest of the target is explored in legs between them.
  double base_m = 0.0;
  for (std::size_t w = 0; w < waypoints.size() && waypoints.size() > 1; ++w) {
    const int from = waypoints[w], to = waypoints[(w + 1) % waypoints.size()];
    base_m += builder.Length(builder.Bfs(from, shared_ok, [&](int n) { return n == to; }));
  }
  std::vector<int> tour{waypoints.front()};
  const double leg_m = std::max(0.0, shared_target_m - base_m) / static_cast<double>(waypoints.size());
  for (std::size_t w = 1; w <= waypoints.size(); ++w) {
    if (leg_m > 0.0) builder.Explore(&tour, shared_ok, leg_m, &visits);
    const int target = waypoints[w % waypoints.size()];
    if (tour.back() != target) {
      const std::vector<int> path = builder.Bfs(tour.back(), shared_ok, [&](int n) { return n == target; });
      for (std::size_t k = 1; k < path.size(); ++k) tour.push_back(path[k]);
    }
  }
  if (tour.size() < 3) {  // degenerate (a single block explored back and forth): go round the block
    tour = {static_cast<int>(builder.Node(si, sj)), static_cast<int>(builder.Node(si + 1, sj)),
            static_cast<int>(builder.Node(si + 1, sj + 1)), static_cast<int>(builder.Node(si, sj + 1)),
            static_cast<int>(builder.Node(si, sj))};
  }
  plan.shared_tour = tour;
  const double tour_m = builder.Length(tour);

  // Routes.
  const double want_m = route_m * 1.08 + 40.0;  // smoothing shortens corners; keep a margin
  for (int r = 0; r < R; ++r) {
    SimRandom robot_rng(MixSeed(params.seed, 0x22ull + static_cast<std::uint64_t>(r), static_cast<std::uint64_t>(params.world)));
    std::vector<int> walk;
    std::vector<std::uint8_t> step_shared;
    auto push = [&](int node, bool shared) {
      if (!walk.empty() && walk.back() == node) return;
      if (!walk.empty()) step_shared.push_back(shared ? 1 : 0);
      walk.push_back(node);
    };
    const bool reversed = !params.same_direction && (r % 2) == 1;
    // The tour as a cyclic sequence starting at `start` (first occurrence), in this robot's direction.
    auto tour_from = [&](int start) {
      std::vector<int> cyc(tour.begin(), tour.end() - 1);  // closed: last == first
      if (reversed) std::reverse(cyc.begin(), cyc.end());
      std::size_t at = 0;
      for (std::size_t k = 0; k < cyc.size(); ++k)
        if (cyc[k] == start) {
          at = k;
          break;
        }
      std::rotate(cyc.begin(), cyc.begin() + static_cast<std::ptrdiff_t>(at), cyc.end());
      return cyc;
    };
    // Drives the tour from `start`: exactly `whole_laps` laps when > 0, else until the walk is until_m long.
    auto drive_laps = [&](int start, double until_m, int whole_laps) {
      const std::vector<int> cyc = tour_from(start);
      double len = builder.Length(walk);
      push(start, true);
      for (int lap = 0; whole_laps <= 0 || lap < whole_laps; ++lap) {
        for (std::size_t k = 1; k <= cyc.size(); ++k) {
          const int node = cyc[k % cyc.size()];
          len += builder.EdgeLength(walk.back(), node);
          push(node, true);
          if (whole_laps <= 0 && len >= until_m) return;
        }
      }
    };
    if (complete) {
      // Start spread along the tour, odd robots in the opposite direction.
      const std::vector<int> cyc = tour_from(tour.front());
      const int start = cyc[(static_cast<std::size_t>(r) * cyc.size()) / static_cast<std::size_t>(R)];
      drive_laps(start, want_m, 0);
    } else {
      const std::vector<int>& conn = connector[static_cast<std::size_t>(r)];
      const int entry = conn.front(), home = conn.back();
      auto region_ok = [&](int n) { return net.node_region[static_cast<std::size_t>(n)] == r; };
      std::vector<int> private_visits(net.edges.size(), 0);
      const double conn_m = builder.Length(conn);
      if (r % 2 == 0) {
        // Shared laps first, then out to the private region.
        const int laps_here = std::max(1, static_cast<int>(std::lround(f * route_m / std::max(tour_m, 1.0))));
        drive_laps(entry, 0.0, laps_here);
        for (std::size_t k = 1; k < conn.size(); ++k) push(conn[k], false);
        std::vector<int> priv{home};
        builder.Explore(&priv, region_ok, std::max(0.0, want_m - builder.Length(walk)), &private_visits);
        for (std::size_t k = 1; k < priv.size(); ++k) push(priv[k], false);
      } else {
        // Private region first (explored from home and driven backwards so that it ends at home), then in.
        std::vector<int> priv{home};
        builder.Explore(&priv, region_ok, std::max(0.0, (1.0 - f) * route_m - conn_m), &private_visits);
        std::reverse(priv.begin(), priv.end());
        for (int node : priv) push(node, false);
        for (std::size_t k = conn.size() - 1; k-- > 0;) push(conn[k], false);
        drive_laps(entry, want_m, 0);
      }
      if (builder.Length(walk) < want_m) {  // a region without exits: back to the shared tour and round it
        const std::vector<int> back = builder.Bfs(walk.back(), [](int) { return true; }, [&](int n) { return n == entry; });
        for (std::size_t k = 1; k < back.size(); ++k) push(back[k], false);
        drive_laps(entry, want_m, 0);
      }
    }
    for (std::size_t k = 1; k < walk.size(); ++k) {
      net.edges[static_cast<std::size_t>(net.EdgeBetween(walk[k - 1], walk[k]))].driven = true;
    }

    // Dense smoothed path, keyframes every spacing along it.
    const double lane_bias = 0.15 * robot_rng.Uniform(-1.0, 1.0);
    const std::vector<DensePoint> dense =
        DenseRoute(net, walk, step_shared, layout.lane_m + lane_bias, layout.smooth_m);
    std::vector<double> arc(dense.size(), 0.0);
    for (std::size_t i = 1; i < dense.size(); ++i) arc[i] = arc[i - 1] + (dense[i].xy - dense[i - 1].xy).norm();
    const double needed = (params.keyframes_per_robot - 1) * params.keyframe_spacing_m + 1.0;
    if (dense.size() < 2 || arc.back() < needed) {
      return Status(StatusCode::kInternal, "mission: route of robot " + std::to_string(r) + " is too short (" +
                                               std::to_string(dense.empty() ? 0.0 : arc.back()) + " m)");
    }
    auto sample = [&](double s, std::size_t* hint) {
      while (*hint + 2 < arc.size() && arc[*hint + 1] < s) ++*hint;
      const std::size_t i = *hint;
      const double span = arc[i + 1] - arc[i];
      const double u = span > 1e-12 ? std::clamp((s - arc[i]) / span, 0.0, 1.0) : 0.0;
      return Eigen::Vector2d(dense[i].xy + u * (dense[i + 1].xy - dense[i].xy));
    };
    const double speed = layout.speed_m_per_s * (1.0 + 0.1 * robot_rng.Uniform(-1.0, 1.0));
    const double wobble = params.roll_pitch_wobble_deg * kDegToRad;
    const double ph[4] = {robot_rng.Uniform(0, 2 * kPi), robot_rng.Uniform(0, 2 * kPi), robot_rng.Uniform(0, 2 * kPi),
                          robot_rng.Uniform(0, 2 * kPi)};
    RobotMission robot;
    robot.id = r;
    std::vector<Eigen::Isometry3d> gt_poses;
    gt_poses.reserve(static_cast<std::size_t>(params.keyframes_per_robot));
    std::size_t hint = 0, hint_a = 0, hint_b = 0;
    for (int k = 0; k < params.keyframes_per_robot; ++k) {
      const double s = k * params.keyframe_spacing_m + 0.5;
      const Eigen::Vector2d p = sample(s, &hint);
      const Eigen::Vector2d ahead = sample(std::min(s + 0.5, arc.back()), &hint_b);
      const Eigen::Vector2d behind = sample(std::max(s - 0.5, 0.0), &hint_a);
      Eigen::Vector2d tangent = ahead - behind;
      if (tangent.norm() < 1e-6) tangent = Eigen::Vector2d(1.0, 0.0);
      const double yaw = std::atan2(tangent.y(), tangent.x());
      const double roll = wobble * (0.6 * std::sin(2 * kPi * s / 17.0 + ph[0]) + 0.4 * std::sin(2 * kPi * s / 5.3 + ph[1]));
      const double pitch = wobble * (0.6 * std::sin(2 * kPi * s / 23.0 + ph[2]) + 0.4 * std::sin(2 * kPi * s / 7.1 + ph[3]));
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = RotationFromYawPitchRoll(yaw, pitch, roll);
      T.translation() = Eigen::Vector3d(p.x(), p.y(), layout.sensor_height_m);
      gt_poses.push_back(T);
      robot.times_s.push_back(k * params.keyframe_spacing_m / speed);
      robot.on_shared_tour.push_back(dense[hint].shared ? 1 : 0);
    }
    robot.T_gt_robotstart = gt_poses.front();
    const Eigen::Isometry3d T_start_gt = robot.T_gt_robotstart.inverse();
    for (const Eigen::Isometry3d& T : gt_poses) {
      Eigen::Isometry3d g = T_start_gt * T;
      if (robot.gt.empty()) g = Eigen::Isometry3d::Identity();
      robot.gt.push_back(g);
    }

    AddDriftingOdometry(params, r, &robot);
    robot.route_nodes = std::move(walk);
    plan.robots.push_back(std::move(robot));
  }
  return plan;
}

OverlapReport MeasureOverlap(const MissionPlan& plan, double radius_m) {
  OverlapReport rep;
  rep.radius_m = radius_m;
  const std::size_t R = plan.robots.size();
  rep.fraction.assign(R, std::vector<double>(R, 0.0));
  rep.any.assign(R, 0.0);
  if (R == 0 || !(radius_m > 0.0)) return rep;
  // Hash grid of every robot's keyframe positions (cell = radius).
  struct Cell {
    long long key;
    std::uint32_t robot;
    float x, y;
  };
  std::vector<Cell> cells;
  auto key_of = [&](double x, double y) {
    const long long cx = static_cast<long long>(std::floor(x / radius_m));
    const long long cy = static_cast<long long>(std::floor(y / radius_m));
    return static_cast<long long>((static_cast<unsigned long long>(cx) << 32) ^ (static_cast<unsigned long long>(cy) & 0xFFFFFFFFull));
  };
  for (std::size_t r = 0; r < R; ++r) {
    for (std::size_t k = 0; k < plan.robots[r].gt.size(); ++k) {
      const Eigen::Vector3d p = plan.robots[r].T_gt_sensor(k).translation();
      cells.push_back({key_of(p.x(), p.y()), static_cast<std::uint32_t>(r), static_cast<float>(p.x()),
                       static_cast<float>(p.y())});
    }
  }
  std::sort(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) { return a.key < b.key; });
  const double r2 = radius_m * radius_m;
  for (std::size_t i = 0; i < R; ++i) {
    std::vector<std::size_t> hits(R, 0);
    std::size_t any = 0;
    const auto& robot = plan.robots[i];
    for (std::size_t k = 0; k < robot.gt.size(); ++k) {
      const Eigen::Vector3d p = robot.T_gt_sensor(k).translation();
      std::vector<std::uint8_t> near(R, 0);
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          const long long key = key_of(p.x() + dx * radius_m, p.y() + dy * radius_m);
          auto it = std::lower_bound(cells.begin(), cells.end(), key, [](const Cell& c, long long v) { return c.key < v; });
          for (; it != cells.end() && it->key == key; ++it) {
            if (it->robot == i || near[it->robot]) continue;
            const double ex = static_cast<double>(it->x) - p.x(), ey = static_cast<double>(it->y) - p.y();
            if (ex * ex + ey * ey <= r2) near[it->robot] = 1;
          }
        }
      }
      bool any_near = false;
      for (std::size_t j = 0; j < R; ++j) {
        hits[j] += near[j];
        any_near |= near[j] != 0;
      }
      any += any_near;
    }
    const double n = static_cast<double>(std::max<std::size_t>(1, robot.gt.size()));
    for (std::size_t j = 0; j < R; ++j) rep.fraction[i][j] = j == i ? 1.0 : static_cast<double>(hits[j]) / n;
    rep.any[i] = static_cast<double>(any) / n;
  }
  return rep;
}

}  // namespace commerge
