// SPDX-License-Identifier: BSD-3-Clause
// Multi-robot frame solver: branch and bound over spanning forests of the measurement multigraph, cycle
// consistency verdicts, then a Gauss-Newton refinement on SE(3).
#include "core/merge/frame_solver.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <sstream>
#include <string>

#include "core/common/number_text.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {
namespace {

constexpr int kMaxRobots = kFrameSolverMaxRobots;

/// Rigid transform as rotation + translation (cheaper to compose than a 4x4 matrix).
struct Pose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

Pose Compose(const Pose& a, const Pose& b) { return {a.R * b.R, a.R * b.t + a.t}; }
Pose Inverse(const Pose& a) {
  Pose out;
  out.R = a.R.transpose();
  out.t = -(out.R * a.t);
  return out;
}
// a^-1 * b
Pose Between(const Pose& a, const Pose& b) { return {a.R.transpose() * b.R, a.R.transpose() * (b.t - a.t)}; }
Pose FromIsometry(const Eigen::Isometry3d& T) { return {T.linear(), T.translation()}; }
// A measured transform, its rotation projected back onto SO(3) (measurements may carry rounding of up to
// kRigidTolerance, e.g. from single-precision sources).
Pose FromInput(const Eigen::Isometry3d& T) {
  return {Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix(), T.translation()};
}
constexpr double kRigidTolerance = 1e-5;
Eigen::Isometry3d ToIsometry(const Pose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = p.R;
  T.translation() = p.t;
  return T;
}

/// A measurement oriented from the lower robot (lo) to the higher (hi): p_lo = T_lo_hi p_hi.
struct Edge {
  int lo = 0;
  int hi = 0;
  Pose T_lo_hi;
  double weight = 0.0;
  std::size_t input_index = 0;
};

int PairId(int lo, int hi) { return lo * kMaxRobots + hi; }

struct Thresholds {
  double translation_sq = 0.0;  // [m^2]
  double min_trace = 0.0;       // 1 + 2 cos(max angle): trace(R_a^T R_b) >= this <=> angle <= max angle
};

Thresholds MakeThresholds(double translation_m, double rotation_rad) {
  Thresholds th;
  th.translation_sq = translation_m * translation_m * (1.0 + 1e-12);
  th.min_trace = 1.0 + 2.0 * std::cos(std::min(rotation_rad, kPi)) - 1e-12;
  return th;
}

// trace(A^T B) without forming the product.
double TraceAtB(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) { return A.cwiseProduct(B).sum(); }

bool Within(const Pose& a, const Pose& b, const Thresholds& th) {
  return (a.t - b.t).squaredNorm() <= th.translation_sq && TraceAtB(a.R, b.R) >= th.min_trace;
}

struct Errors {
  double translation_m = 0.0;
  double rotation_deg = 0.0;
};
Errors ErrorsOf(const Pose& implied, const Pose& measured) {
  return {(implied.t - measured.t).norm(), RotationAngleRad(measured.R.transpose() * implied.R) * kRadToDeg};
}

/// Per robot pair: the measurements on it and an upper bound on how many of them (and on how much of their
/// weight) can be consistent with one forest at the same time.
struct PairInfo {
  int lo = 0;
  int hi = 0;
  int cap_count = 0;
  double cap_weight = 0.0;
  std::vector<int> edges;  // positions in the search order
};

/// Branch-and-bound state: union-find labels (label = a robot whose label is itself) and each robot's pose in
/// its label robot's frame.
struct State {
  std::array<int, kMaxRobots> label{};
  std::array<Pose, kMaxRobots> X;
  int components = 0;
  int count = 0;        // determined consistent measurements
  double weight = 0.0;  // their weight
  std::uint64_t forest = 0;
};

class ForestSearch {
 public:
  ForestSearch(int num_robots, const std::vector<Edge>& edges, std::vector<PairInfo> pairs, int target_components,
               const Thresholds& th, std::size_t max_nodes, double weight_eps)
      : n_(num_robots),
        edges_(edges),
        pairs_(std::move(pairs)),
        target_components_(target_components),
        th_(th),
        max_nodes_(max_nodes),
        weight_eps_(weight_eps) {
    for (std::size_t p = 0; p < pairs_.size(); ++p) {
      pair_of_[PairId(pairs_[p].lo, pairs_[p].hi)] = static_cast<int>(p);
      root_bound_count_ += pairs_[p].cap_count;
      root_bound_weight_ += pairs_[p].cap_weight;
    }
  }

  /// The Kruskal forest in search order (no lookahead, not counted against the budget): guarantees a complete
  /// incumbent whatever max_nodes is.
  void SeedKruskal() {
    State s = Initial();
    for (std::size_t k = 0; k < edges_.size() && s.components > target_components_; ++k) {
      if (s.label[static_cast<std::size_t>(edges_[k].lo)] != s.label[static_cast<std::size_t>(edges_[k].hi)]) {
        Join(k, &s);
      }
    }
    Offer(s);
  }

  /// Greedy forests, one per seed measurement (in search order): start with the seed, then repeatedly add the
  /// joining measurement that makes the most measurements consistent (then the most weight). The best one is
  /// the incumbent of the exact search. Each tentative join counts as a search node.
  void SeedGreedy() {
    for (std::size_t seed = 0; seed < edges_.size() && !aborted_; ++seed) {
      State s = Initial();
      Join(seed, &s);
      while (s.components > target_components_) {
        State best;
        bool found = false;
        for (std::size_t k = 0; k < edges_.size(); ++k) {
          if (s.label[static_cast<std::size_t>(edges_[k].lo)] == s.label[static_cast<std::size_t>(edges_[k].hi)]) {
            continue;
          }
          if (nodes_ >= max_nodes_) {
            aborted_ = true;
            return;
          }
          ++nodes_;
          State t = s;
          Join(k, &t);
          if (!found || t.count > best.count || (t.count == best.count && t.weight > best.weight + weight_eps_)) {
            best = t;
            found = true;
          }
        }
        s = best;
      }
      Offer(s);
      if (best_count_ >= root_bound_count_ && best_weight_ >= root_bound_weight_ - weight_eps_) return;  // optimal
    }
  }

  /// Exact branch and bound over all spanning forests (stops at max_nodes).
  void Run() { Visit(0, Initial()); }

  std::uint64_t best_forest() const { return best_forest_; }
  int best_count() const { return best_count_; }
  double best_weight() const { return best_weight_; }
  std::size_t nodes() const { return nodes_; }
  bool exhaustive() const { return !aborted_; }

 private:
  State Initial() const {
    State s;
    for (int v = 0; v < n_; ++v) s.label[static_cast<std::size_t>(v)] = v;
    s.components = n_;
    return s;
  }

  void Offer(const State& s) {
    if (s.count > best_count_ || (s.count == best_count_ && s.weight > best_weight_ + weight_eps_)) {
      best_count_ = s.count;
      best_weight_ = s.weight;
      best_forest_ = s.forest;
    }
  }

  void Visit(std::size_t i, const State& s) {
    if (aborted_) return;
    if (nodes_ >= max_nodes_) {
      aborted_ = true;
      return;
    }
    ++nodes_;
    if (s.components == target_components_) {
      Offer(s);
      return;
    }
    // Bound: measurements of pairs not yet joined may still all be consistent, up to each pair's cap.
    int bound_count = s.count;
    double bound_weight = s.weight;
    for (const PairInfo& p : pairs_) {
      if (s.label[static_cast<std::size_t>(p.lo)] != s.label[static_cast<std::size_t>(p.hi)]) {
        bound_count += p.cap_count;
        bound_weight += p.cap_weight;
      }
    }
    if (Dominated(bound_count, bound_weight)) return;
    // Next measurement that joins two components (the others close a cycle and can no longer be tree edges).
    while (i < edges_.size() && s.label[static_cast<std::size_t>(edges_[i].lo)] ==
                                    s.label[static_cast<std::size_t>(edges_[i].hi)]) {
      ++i;
    }
    if (i == edges_.size()) return;  // unreachable: exclusions keep the forest completable
    {
      State t = s;
      Join(i, &t);
      Visit(i + 1, t);
    }
    if (StillJoinableWithout(i, s)) Visit(i + 1, s);
  }

  bool Dominated(int bound_count, double bound_weight) const {
    return bound_count < best_count_ || (bound_count == best_count_ && bound_weight <= best_weight_ + weight_eps_);
  }

  // Adds edge i to the forest: moves the hi side's component into the lo side's frame and evaluates every
  // measurement between the two components.
  void Join(std::size_t i, State* s) const {
    const Edge& e = edges_[i];
    const int a = s->label[static_cast<std::size_t>(e.lo)];
    const int b = s->label[static_cast<std::size_t>(e.hi)];
    std::array<bool, kMaxRobots> in_a{}, in_b{};
    for (int v = 0; v < n_; ++v) {
      in_a[static_cast<std::size_t>(v)] = s->label[static_cast<std::size_t>(v)] == a;
      in_b[static_cast<std::size_t>(v)] = s->label[static_cast<std::size_t>(v)] == b;
    }
    // X_a_lo * T_lo_hi * X_b_hi^-1 maps b's frame into a's frame.
    const Pose T_a_b = Compose(Compose(s->X[static_cast<std::size_t>(e.lo)], e.T_lo_hi),
                               Inverse(s->X[static_cast<std::size_t>(e.hi)]));
    for (int v = 0; v < n_; ++v) {
      if (!in_b[static_cast<std::size_t>(v)]) continue;
      s->X[static_cast<std::size_t>(v)] = Compose(T_a_b, s->X[static_cast<std::size_t>(v)]);
      s->label[static_cast<std::size_t>(v)] = a;
    }
    --s->components;
    s->forest |= std::uint64_t{1} << i;
    for (int u = 0; u < n_; ++u) {
      if (!in_a[static_cast<std::size_t>(u)] && !in_b[static_cast<std::size_t>(u)]) continue;
      for (int v = u + 1; v < n_; ++v) {
        const bool crossing = (in_a[static_cast<std::size_t>(u)] && in_b[static_cast<std::size_t>(v)]) ||
                              (in_b[static_cast<std::size_t>(u)] && in_a[static_cast<std::size_t>(v)]);
        if (!crossing) continue;
        const int p = pair_of_[PairId(u, v)];
        if (p < 0) continue;
        const Pose implied = Between(s->X[static_cast<std::size_t>(u)], s->X[static_cast<std::size_t>(v)]);
        for (int k : pairs_[static_cast<std::size_t>(p)].edges) {
          if (static_cast<std::size_t>(k) == i || Within(implied, edges_[static_cast<std::size_t>(k)].T_lo_hi, th_)) {
            ++s->count;
            s->weight += edges_[static_cast<std::size_t>(k)].weight;
          }
        }
      }
    }
  }

  // Whether edge i's robots can still be joined by the edges after i (so excluding i keeps the forest
  // spanning).
  bool StillJoinableWithout(std::size_t i, const State& s) const {
    std::array<int, kMaxRobots> parent{};
    for (int v = 0; v < n_; ++v) parent[static_cast<std::size_t>(v)] = s.label[static_cast<std::size_t>(v)];
    auto find = [&parent](int v) {
      while (parent[static_cast<std::size_t>(v)] != v) v = parent[static_cast<std::size_t>(v)];
      return v;
    };
    const int target_a = s.label[static_cast<std::size_t>(edges_[i].lo)];
    const int target_b = s.label[static_cast<std::size_t>(edges_[i].hi)];
    for (std::size_t j = i + 1; j < edges_.size(); ++j) {
      const int ra = find(edges_[j].lo);
      const int rb = find(edges_[j].hi);
      if (ra == rb) continue;
      parent[static_cast<std::size_t>(std::max(ra, rb))] = std::min(ra, rb);
      if (find(target_a) == find(target_b)) return true;
    }
    return false;
  }

  int n_;
  const std::vector<Edge>& edges_;
  std::vector<PairInfo> pairs_;
  std::array<int, kMaxRobots * kMaxRobots> pair_of_ = MinusOnes();
  int target_components_;
  Thresholds th_;
  std::size_t max_nodes_;
  double weight_eps_;

  int root_bound_count_ = 0;
  double root_bound_weight_ = 0.0;
  std::size_t nodes_ = 0;
  bool aborted_ = false;
  int best_count_ = -1;
  double best_weight_ = 0.0;
  std::uint64_t best_forest_ = 0;

  static std::array<int, kMaxRobots * kMaxRobots> MinusOnes() {
    std::array<int, kMaxRobots * kMaxRobots> a{};
    a.fill(-1);
    return a;
  }
};

Status ValidateMeasurements(int num_robots, Span<const FrameMeasurement> measurements) {
  if (num_robots < kFrameSolverMinRobots || num_robots > kFrameSolverMaxRobots) {
    return InvalidArgument("frame solver: num_robots must be in [" + std::to_string(kFrameSolverMinRobots) + ", " +
                           std::to_string(kFrameSolverMaxRobots) + "], got " + std::to_string(num_robots));
  }
  if (measurements.size() > kFrameSolverMaxMeasurements) {
    return InvalidArgument("frame solver: at most " + std::to_string(kFrameSolverMaxMeasurements) +
                           " measurements, got " + std::to_string(measurements.size()));
  }
  const std::string range = " is out of range [0, " + std::to_string(num_robots) + ")";
  for (std::size_t k = 0; k < measurements.size(); ++k) {
    const FrameMeasurement& m = measurements[k];
    const std::string what = "frame solver: measurement " + std::to_string(k) + " ";
    if (m.robot_a < 0 || m.robot_a >= num_robots) {
      return InvalidArgument(what + "robot_a = " + std::to_string(m.robot_a) + range);
    }
    if (m.robot_b < 0 || m.robot_b >= num_robots) {
      return InvalidArgument(what + "robot_b = " + std::to_string(m.robot_b) + range);
    }
    if (m.robot_a == m.robot_b) {
      return InvalidArgument(what + "is a self-loop (robot_a = robot_b = " + std::to_string(m.robot_a) + ")");
    }
    if (!m.T_a_b.matrix().topRows<3>().allFinite()) {
      return InvalidArgument(what + "T_a_b has a non-finite entry");
    }
    if (!IsValidRigidTransform(m.T_a_b, kRigidTolerance)) {
      return InvalidArgument(what + "T_a_b is not a rigid transform (rotation not orthonormal with det +1 within " +
                             FormatNumber(kRigidTolerance, 6) + ")");
    }
    if (!(m.weight > 0.0 && std::isfinite(m.weight))) {
      return InvalidArgument(what + "weight = " + FormatNumber(m.weight, 6) + " must be finite and > 0");
    }
  }
  return Status::Ok();
}

// Union-find over at most kMaxRobots robots.
struct SmallUnionFind {
  std::array<int, kMaxRobots> parent{};
  explicit SmallUnionFind(int n) {
    for (int v = 0; v < n; ++v) parent[static_cast<std::size_t>(v)] = v;
  }
  int Find(int v) const {
    while (parent[static_cast<std::size_t>(v)] != v) v = parent[static_cast<std::size_t>(v)];
    return v;
  }
  bool Unite(int a, int b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return false;
    parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);  // root = lowest index
    return true;
  }
};

// Heuristic search order: measurements confirmed by parallel measurements and closed triangles first, then by
// weight, so that the first forest tried is usually the optimum.
std::vector<std::size_t> SearchOrder(int n, const std::vector<Edge>& edges, const Thresholds& th) {
  std::vector<int> support(edges.size(), 0);
  std::vector<std::vector<std::size_t>> by_pair(static_cast<std::size_t>(kMaxRobots * kMaxRobots));
  for (std::size_t k = 0; k < edges.size(); ++k) {
    by_pair[static_cast<std::size_t>(PairId(edges[k].lo, edges[k].hi))].push_back(k);
  }
  for (const auto& list : by_pair) {
    for (std::size_t x = 0; x < list.size(); ++x) {
      for (std::size_t y = x + 1; y < list.size(); ++y) {
        if (Within(edges[list[x]].T_lo_hi, edges[list[y]].T_lo_hi, th)) {
          ++support[list[x]];
          ++support[list[y]];
        }
      }
    }
  }
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const auto& ab = by_pair[static_cast<std::size_t>(PairId(a, b))];
      if (ab.empty()) continue;
      for (int c = b + 1; c < n; ++c) {
        const auto& bc = by_pair[static_cast<std::size_t>(PairId(b, c))];
        const auto& ac = by_pair[static_cast<std::size_t>(PairId(a, c))];
        if (bc.empty() || ac.empty()) continue;
        for (std::size_t x : ab) {
          for (std::size_t y : bc) {
            const Pose T_a_c = Compose(edges[x].T_lo_hi, edges[y].T_lo_hi);
            for (std::size_t z : ac) {
              if (Within(T_a_c, edges[z].T_lo_hi, th)) {
                ++support[x];
                ++support[y];
                ++support[z];
              }
            }
          }
        }
      }
    }
  }
  std::vector<std::size_t> order(edges.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    if (support[x] != support[y]) return support[x] > support[y];
    return edges[x].weight > edges[y].weight;
  });
  return order;
}

// Pair caps: measurements consistent with one implied transform are pairwise within twice the thresholds
// (both errors are metrics), so at most the largest such neighbourhood of one measurement is consistent.
std::vector<PairInfo> MakePairs(int n, const std::vector<Edge>& edges, double max_translation_m,
                                double max_rotation_rad) {
  const Thresholds twice = MakeThresholds(2.0 * max_translation_m, 2.0 * max_rotation_rad);
  std::vector<PairInfo> pairs;
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      PairInfo p;
      p.lo = a;
      p.hi = b;
      for (std::size_t k = 0; k < edges.size(); ++k) {
        if (edges[k].lo == a && edges[k].hi == b) p.edges.push_back(static_cast<int>(k));
      }
      if (p.edges.empty()) continue;
      for (int x : p.edges) {
        int count = 0;
        double weight = 0.0;
        for (int y : p.edges) {
          if (Within(edges[static_cast<std::size_t>(x)].T_lo_hi, edges[static_cast<std::size_t>(y)].T_lo_hi, twice)) {
            ++count;
            weight += edges[static_cast<std::size_t>(y)].weight;
          }
        }
        p.cap_count = std::max(p.cap_count, count);
        p.cap_weight = std::max(p.cap_weight, weight);
      }
      pairs.push_back(std::move(p));
    }
  }
  return pairs;
}

// Gauss-Newton over the non-anchor robots. Returns the iterations run.
int Refine(int n, const std::vector<Edge>& edges, const std::vector<bool>& use, const std::vector<bool>& is_anchor,
           double sigma_translation_m, double sigma_rotation_rad, int iterations, std::vector<Pose>* X) {
  std::array<int, kMaxRobots> var{};
  int num_vars = 0;
  for (int v = 0; v < n; ++v) var[static_cast<std::size_t>(v)] = is_anchor[static_cast<std::size_t>(v)] ? -1 : num_vars++;
  if (num_vars == 0 || iterations <= 0) return 0;
  Vector6d info_diag;
  const double it = 1.0 / (sigma_translation_m * sigma_translation_m);
  const double ir = 1.0 / (sigma_rotation_rad * sigma_rotation_rad);
  info_diag << it, it, it, ir, ir, ir;

  auto cost_of = [&](const std::vector<Pose>& poses) {
    double cost = 0.0;
    for (std::size_t k = 0; k < edges.size(); ++k) {
      if (!use[k]) continue;
      const Pose Z = Between(poses[static_cast<std::size_t>(edges[k].lo)], poses[static_cast<std::size_t>(edges[k].hi)]);
      const Vector6d e = LogSE3(ToIsometry(Between(edges[k].T_lo_hi, Z)));
      cost += edges[k].weight * e.dot(info_diag.cwiseProduct(e));
    }
    return cost;
  };

  const int dim = 6 * num_vars;
  double cost = cost_of(*X);
  int run = 0;
  for (int iter = 0; iter < iterations; ++iter) {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(dim, dim);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(dim);
    for (std::size_t k = 0; k < edges.size(); ++k) {
      if (!use[k]) continue;
      const int a = edges[k].lo;
      const int b = edges[k].hi;
      const Pose Z = Between((*X)[static_cast<std::size_t>(a)], (*X)[static_cast<std::size_t>(b)]);
      const Vector6d e = LogSE3(ToIsometry(Between(edges[k].T_lo_hi, Z)));
      const Matrix6d Jr_inv = RightJacobianInverseSE3(e);
      const Matrix6d J_b = Jr_inv;
      const Matrix6d J_a = -Jr_inv * AdjointSE3(ToIsometry(Inverse(Z)));
      const Matrix6d W = (edges[k].weight * info_diag).asDiagonal();
      const int va = var[static_cast<std::size_t>(a)];
      const int vb = var[static_cast<std::size_t>(b)];
      if (va >= 0) {
        H.block<6, 6>(6 * va, 6 * va) += J_a.transpose() * W * J_a;
        g.segment<6>(6 * va) += J_a.transpose() * W * e;
      }
      if (vb >= 0) {
        H.block<6, 6>(6 * vb, 6 * vb) += J_b.transpose() * W * J_b;
        g.segment<6>(6 * vb) += J_b.transpose() * W * e;
      }
      if (va >= 0 && vb >= 0) {
        const Matrix6d H_ab = J_a.transpose() * W * J_b;
        H.block<6, 6>(6 * va, 6 * vb) += H_ab;
        H.block<6, 6>(6 * vb, 6 * va) += H_ab.transpose();
      }
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    const Eigen::VectorXd delta = ldlt.solve(-g);
    if (!delta.allFinite()) break;
    std::vector<Pose> next = *X;
    for (int v = 0; v < n; ++v) {
      const int vv = var[static_cast<std::size_t>(v)];
      if (vv < 0) continue;
      const Eigen::Isometry3d T = ExpSE3(delta.segment<6>(6 * vv));
      next[static_cast<std::size_t>(v)] = Compose(next[static_cast<std::size_t>(v)], FromIsometry(T));
    }
    const double next_cost = cost_of(next);
    ++run;
    if (!(next_cost <= cost)) break;  // no improvement (already at the optimum up to rounding)
    *X = std::move(next);
    cost = next_cost;
    if (delta.lpNorm<Eigen::Infinity>() < 1e-10) break;
  }
  return run;
}

}  // namespace

const char* MeasurementVerdictName(MeasurementVerdict verdict) noexcept {
  switch (verdict) {
    case MeasurementVerdict::kAccepted: return "accepted";
    case MeasurementVerdict::kRejected: return "rejected";
    case MeasurementVerdict::kUnverified: return "unverified";
  }
  return "invalid";
}

Status ValidateFrameSolverParams(const FrameSolverParams& params) {
  if (!(params.max_translation_m > 0.0 && std::isfinite(params.max_translation_m))) {
    return InvalidArgument("frame solver: max_translation_m must be finite and > 0, got " +
                           FormatNumber(params.max_translation_m, 6));
  }
  if (!(params.max_rotation_deg > 0.0 && params.max_rotation_deg <= 180.0)) {
    return InvalidArgument("frame solver: max_rotation_deg must be in (0, 180], got " +
                           FormatNumber(params.max_rotation_deg, 6));
  }
  if (params.refine_iterations < 0 || params.refine_iterations > 100) {
    return InvalidArgument("frame solver: refine_iterations must be in [0, 100], got " +
                           std::to_string(params.refine_iterations));
  }
  if (params.max_search_nodes < 1) {
    return InvalidArgument("frame solver: max_search_nodes must be >= 1, got 0");
  }
  return Status::Ok();
}

Result<FrameSolution> SolveRobotFrames(int num_robots, Span<const FrameMeasurement> measurements,
                                       const FrameSolverParams& params) {
  if (Status s = ValidateFrameSolverParams(params); !s.ok()) return s;
  if (Status s = ValidateMeasurements(num_robots, measurements); !s.ok()) return s;
  const int n = num_robots;
  const double max_rotation_rad = params.max_rotation_deg * kDegToRad;
  const Thresholds th = MakeThresholds(params.max_translation_m, max_rotation_rad);

  // Oriented measurements, in search order.
  std::vector<Edge> input(measurements.size());
  double total_weight = 0.0;
  for (std::size_t k = 0; k < measurements.size(); ++k) {
    const FrameMeasurement& m = measurements[k];
    Edge& e = input[k];
    e.lo = std::min(m.robot_a, m.robot_b);
    e.hi = std::max(m.robot_a, m.robot_b);
    e.T_lo_hi = m.robot_a < m.robot_b ? FromInput(m.T_a_b) : Inverse(FromInput(m.T_a_b));
    e.weight = m.weight;
    e.input_index = k;
    total_weight += m.weight;
  }
  std::vector<Edge> edges;
  edges.reserve(input.size());
  for (std::size_t k : SearchOrder(n, input, th)) edges.push_back(input[k]);

  // Connected components of the whole graph (root = lowest index).
  SmallUnionFind components(n);
  for (const Edge& e : edges) components.Unite(e.lo, e.hi);
  int target_components = 0;
  for (int v = 0; v < n; ++v) target_components += components.Find(v) == v ? 1 : 0;

  ForestSearch search(n, edges, MakePairs(n, edges, params.max_translation_m, max_rotation_rad), target_components,
                      th, params.max_search_nodes, 1e-9 * total_weight);
  search.SeedKruskal();
  search.SeedGreedy();
  search.Run();
  const std::uint64_t forest = search.best_forest();

  FrameSolution out;
  out.search_exhaustive = search.exhaustive();
  out.search_nodes = search.nodes();
  out.num_components = target_components;

  // Poses from the forest: walk each tree from its anchor.
  std::vector<Pose> X(static_cast<std::size_t>(n));
  std::array<int, kMaxRobots> parent_edge{};
  std::array<int, kMaxRobots> depth{};
  std::array<bool, kMaxRobots> placed{};
  parent_edge.fill(-1);
  std::vector<bool> is_anchor(static_cast<std::size_t>(n), false);
  for (int v = 0; v < n; ++v) {
    if (components.Find(v) != v) continue;
    is_anchor[static_cast<std::size_t>(v)] = true;
    placed[static_cast<std::size_t>(v)] = true;
    bool grew = true;
    while (grew) {
      grew = false;
      for (std::size_t k = 0; k < edges.size(); ++k) {
        if (!((forest >> k) & 1U)) continue;
        const Edge& e = edges[k];
        const bool lo_in = placed[static_cast<std::size_t>(e.lo)];
        const bool hi_in = placed[static_cast<std::size_t>(e.hi)];
        if (lo_in == hi_in || components.Find(e.lo) != v) continue;
        const int from = lo_in ? e.lo : e.hi;
        const int to = lo_in ? e.hi : e.lo;
        const Pose step = lo_in ? e.T_lo_hi : Inverse(e.T_lo_hi);
        X[static_cast<std::size_t>(to)] = Compose(X[static_cast<std::size_t>(from)], step);
        placed[static_cast<std::size_t>(to)] = true;
        parent_edge[static_cast<std::size_t>(to)] = static_cast<int>(k);
        depth[static_cast<std::size_t>(to)] = depth[static_cast<std::size_t>(from)] + 1;
        grew = true;
      }
    }
  }
  auto parent_of = [&](int v) {
    const Edge& e = edges[static_cast<std::size_t>(parent_edge[static_cast<std::size_t>(v)])];
    return e.lo == v ? e.hi : e.lo;
  };

  // Verdicts, in search order.
  std::vector<MeasurementOutcome> outcome(edges.size());
  std::vector<bool> consistent(edges.size(), false);
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = edges[k];
    MeasurementOutcome& o = outcome[k];
    o.in_forest = ((forest >> k) & 1U) != 0;
    const Pose implied = Between(X[static_cast<std::size_t>(e.lo)], X[static_cast<std::size_t>(e.hi)]);
    if (!o.in_forest) {
      const Errors err = ErrorsOf(implied, e.T_lo_hi);
      o.cycle_translation_m = err.translation_m;
      o.cycle_rotation_deg = err.rotation_deg;
    }
    consistent[k] = o.in_forest || Within(implied, e.T_lo_hi, th);
    if (!consistent[k]) {
      o.verdict = MeasurementVerdict::kRejected;
      continue;
    }
    out.consistent_count += 1;
    out.consistent_weight += e.weight;
    // A bridge: without it, its two robots are disconnected.
    SmallUnionFind without(n);
    for (std::size_t j = 0; j < edges.size(); ++j) {
      if (j != k) without.Unite(edges[j].lo, edges[j].hi);
    }
    o.verdict = without.Find(e.lo) == without.Find(e.hi) ? MeasurementVerdict::kAccepted
                                                         : MeasurementVerdict::kUnverified;
    if (!o.in_forest) {
      // Credit the forest edges on the cycle this measurement closed.
      int u = e.lo;
      int v = e.hi;
      while (u != v) {
        int& deeper = depth[static_cast<std::size_t>(u)] >= depth[static_cast<std::size_t>(v)] ? u : v;
        ++outcome[static_cast<std::size_t>(parent_edge[static_cast<std::size_t>(deeper)])].support;
        deeper = parent_of(deeper);
      }
    }
  }

  out.refine_iterations_run = Refine(n, edges, consistent, is_anchor, params.max_translation_m, max_rotation_rad,
                                     params.refine_iterations, &X);

  out.measurements.resize(edges.size());
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const Edge& e = edges[k];
    MeasurementOutcome& o = outcome[k];
    const Errors res = ErrorsOf(Between(X[static_cast<std::size_t>(e.lo)], X[static_cast<std::size_t>(e.hi)]), e.T_lo_hi);
    o.residual_translation_m = res.translation_m;
    o.residual_rotation_deg = res.rotation_deg;
    switch (o.verdict) {
      case MeasurementVerdict::kAccepted: ++out.accepted; break;
      case MeasurementVerdict::kRejected: ++out.rejected; break;
      case MeasurementVerdict::kUnverified: ++out.unverified; break;
    }
    out.measurements[e.input_index] = o;
  }

  out.robots.resize(static_cast<std::size_t>(n));
  int next_component = 0;
  std::array<int, kMaxRobots> component_of_anchor{};
  for (int v = 0; v < n; ++v) {
    if (is_anchor[static_cast<std::size_t>(v)]) component_of_anchor[static_cast<std::size_t>(v)] = next_component++;
  }
  for (int v = 0; v < n; ++v) {
    RobotFrame& r = out.robots[static_cast<std::size_t>(v)];
    r.anchor_robot = components.Find(v);
    r.component = component_of_anchor[static_cast<std::size_t>(r.anchor_robot)];
    r.connected_to_robot0 = r.anchor_robot == 0;
    r.T_world_map = ToIsometry(X[static_cast<std::size_t>(v)]);
  }
  return out;
}

}  // namespace commerge
