// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/balanced_vertex_cover.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "core/solvers/min_cut.hpp"

namespace commerge {
namespace {

using Clock = std::chrono::steady_clock;
using Fix = std::int8_t;  // per vertex in a node: -1 free, 0 not sent, 1 sent
constexpr double kFracTol = 1e-6;
constexpr int kMaxFixingPasses = 8;        // re-bounds of one node after reduced-cost fixing ...
constexpr double kReboundFraction = 0.05;  // ... when at least this fraction of its free vertices got fixed
constexpr double kMaxTotalWeight = 1e100;  // keeps the flow capacities (up to 2 x total + 1) finite
constexpr std::size_t kMaxKeptFlowValues = std::size_t{1} << 22;  // edge flows kept in open nodes (32 MB)

// ---------------------------------------------------------------------------------------------------------------
// Master LP of the Dantzig-Wolfe decomposition (restricted to the columns generated so far):
//   min sum_k W_k mu_k  s.t.  sum_k mu_k = 1,  sum_k a_rk mu_k >= s_r (one row per active robot),  mu >= 0.
// Two engines: GLPK's simplex on a problem kept between solves and nodes (SolveWithGlpk; columns added with a
// basis hint - the parent's LP support - start in the basis), or our dense revised simplex with Bland's rule (no
// cycling; Solve). For the dense one, column 0 must satisfy every share row, so the basis {mu_0, slacks} is
// feasible from the start and no phase 1 is needed. Variables: slack i (i < m) then mu_k.
class MasterLp {
 public:
  void Reset(int m, const std::vector<double>& rhs) {
    m_ = m;
    rhs_ = rhs;
    cost_.clear();
    counts_.clear();
    basis_.clear();
    glpk_rows_ = false;
  }
  void AddColumn(double cost, const std::vector<double>& counts, bool basic_hint = false) {
    cost_.push_back(cost);
    counts_.insert(counts_.end(), counts.begin(), counts.end());
    hints_.resize(cost_.size());
    hints_.back() = basic_hint ? 1 : 0;
  }
  // The next SolveWithGlpk sets the rows (and its columns) again.
  void ForgetGlpkRows() { glpk_rows_ = false; }
  // GLPK on the kept problem `glpk`: the rows are set at the first solve after Reset, then only the new columns
  // are appended. *ok = false when GLPK found no optimum.
  Status SolveWithGlpk(GlpkColumnLp& glpk, bool* ok) {
    *ok = false;
    if (!glpk_rows_) {
      std::vector<LpRowBounds> rows(static_cast<std::size_t>(m_) + 1);
      rows[0] = {1.0, 1.0};
      for (int i = 0; i < m_; ++i) rows[static_cast<std::size_t>(i) + 1] = {rhs_[static_cast<std::size_t>(i)], kLpInfinity};
      Status st = glpk.Reset(rows);
      if (!st.ok()) return st;
      glpk_rows_ = true;
    }
    std::vector<LpColumnEntry> entries;
    for (int k = glpk.columns(); k < columns(); ++k) {
      entries.assign(1, LpColumnEntry{0, 1.0});
      for (int i = 0; i < m_; ++i) {
        const double a = column_count(k, i);
        if (a != 0.0) entries.push_back({i + 1, a});
      }
      Status st = glpk.AddColumn(column_cost(k), 0.0, kLpInfinity, entries, hints_[static_cast<std::size_t>(k)] != 0);
      if (!st.ok()) return st;
    }
    Result<LpSolution> sol = glpk.Solve();
    if (!sol.ok()) return sol.status();
    *ok = SetSolution(*sol);
    return Status::Ok();
  }
  int columns() const { return static_cast<int>(cost_.size()); }
  double column_cost(int k) const { return cost_[static_cast<std::size_t>(k)]; }
  double column_count(int k, int i) const { return counts_[static_cast<std::size_t>(k * m_ + i)]; }

  // Built-in simplex. Returns false when it failed numerically (then the outputs are not usable).
  bool Solve() {
    const int rows = m_ + 1;
    const auto sr = static_cast<std::size_t>(rows);
    if (basis_.empty()) {
      basis_.push_back(m_);  // mu_0
      for (int i = 0; i < m_; ++i) basis_.push_back(i);
    }
    const int vars = m_ + columns();
    double cmax = 1.0;
    for (double c : cost_) cmax = std::max(cmax, std::fabs(c));
    const double tol = 1e-10 * cmax;
    std::vector<char> in_basis(static_cast<std::size_t>(vars), 0);
    binv_.assign(sr * sr, 0.0);
    for (int iter = 0; iter < 5000; ++iter) {
      std::fill(in_basis.begin(), in_basis.end(), 0);
      for (int b : basis_) in_basis[static_cast<std::size_t>(b)] = 1;
      if (!Invert()) return false;
      // x_B = B^-1 b, y = c_B B^-1.
      xb_.assign(sr, 0.0);
      y_.assign(sr, 0.0);
      for (int i = 0; i < rows; ++i) {
        double s = binv_[static_cast<std::size_t>(i) * sr];  // b_0 = 1
        for (int j = 1; j < rows; ++j) s += binv_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(j)] * rhs_[static_cast<std::size_t>(j - 1)];
        xb_[static_cast<std::size_t>(i)] = s;
      }
      for (int j = 0; j < rows; ++j) {
        double s = 0.0;
        for (int i = 0; i < rows; ++i) s += Cost(basis_[static_cast<std::size_t>(i)]) * binv_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(j)];
        y_[static_cast<std::size_t>(j)] = s;
      }
      int enter = -1;
      for (int j = 0; j < vars && enter < 0; ++j) {
        if (in_basis[static_cast<std::size_t>(j)]) continue;
        double d = Cost(j);
        for (int i = 0; i < rows; ++i) d -= y_[static_cast<std::size_t>(i)] * Entry(i, j);
        if (d < -tol) enter = j;
      }
      if (enter < 0) {
        mu_.assign(static_cast<std::size_t>(columns()), 0.0);
        value_ = 0.0;
        for (int i = 0; i < rows; ++i) {
          const int b = basis_[static_cast<std::size_t>(i)];
          const double x = std::max(0.0, xb_[static_cast<std::size_t>(i)]);
          if (b >= m_) mu_[static_cast<std::size_t>(b - m_)] = x;
          value_ += Cost(b) * x;
        }
        t_ = y_[0];
        lambda_.assign(static_cast<std::size_t>(m_), 0.0);
        for (int i = 0; i < m_; ++i) lambda_[static_cast<std::size_t>(i)] = std::max(0.0, y_[static_cast<std::size_t>(i) + 1]);
        return true;
      }
      // Ratio test on u = B^-1 A_enter (Bland: smallest basic variable index among ties).
      int leave = -1;
      double best = 0.0;
      for (int i = 0; i < rows; ++i) {
        double u = 0.0;
        for (int j = 0; j < rows; ++j) u += binv_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(j)] * Entry(j, enter);
        if (u <= 1e-11) continue;
        const double ratio = std::max(0.0, xb_[static_cast<std::size_t>(i)]) / u;
        if (leave < 0 || ratio < best - 1e-12 ||
            (ratio <= best + 1e-12 && basis_[static_cast<std::size_t>(i)] < basis_[static_cast<std::size_t>(leave)])) {
          leave = i;
          best = ratio;
        }
      }
      if (leave < 0) return false;  // unbounded: impossible with the convexity row
      basis_[static_cast<std::size_t>(leave)] = enter;
    }
    return false;
  }

  // Outputs of the last Solve() (or of SetSolution()).
  double value() const { return value_; }
  double t() const { return t_; }
  const std::vector<double>& lambda() const { return lambda_; }
  const std::vector<double>& mu() const { return mu_; }

  // For an external LP engine: the same master as a LinearProgram, and its solution.
  LinearProgram AsLinearProgram() const {
    LinearProgram lp;
    const auto k = static_cast<std::size_t>(columns());
    lp.objective = cost_;
    lp.variable_lower.assign(k, 0.0);
    lp.variable_upper.assign(k, kLpInfinity);
    LpRow conv;
    for (int j = 0; j < columns(); ++j) conv.terms.push_back({j, 1.0});
    conv.lower = 1.0;
    conv.upper = 1.0;
    lp.rows.push_back(std::move(conv));
    for (int i = 0; i < m_; ++i) {
      LpRow row;
      for (int j = 0; j < columns(); ++j) row.terms.push_back({j, column_count(j, i)});
      row.lower = rhs_[static_cast<std::size_t>(i)];
      lp.rows.push_back(std::move(row));
    }
    return lp;
  }
  bool SetSolution(const LpSolution& sol) {
    if (sol.status != LpStatus::kOptimal || sol.values.size() != static_cast<std::size_t>(columns()) ||
        sol.row_duals.size() != static_cast<std::size_t>(m_ + 1)) {
      return false;
    }
    basis_.clear();  // the built-in simplex restarts from the slack basis next time
    mu_ = sol.values;
    for (double& x : mu_) x = std::max(0.0, x);
    value_ = sol.objective;
    t_ = sol.row_duals[0];
    lambda_.assign(static_cast<std::size_t>(m_), 0.0);
    for (int i = 0; i < m_; ++i) lambda_[static_cast<std::size_t>(i)] = std::max(0.0, sol.row_duals[static_cast<std::size_t>(i) + 1]);
    return true;
  }

 private:
  double Cost(int var) const { return var < m_ ? 0.0 : cost_[static_cast<std::size_t>(var - m_)]; }
  // Entry of row `row` (0 = convexity) in the column of variable `var`.
  double Entry(int row, int var) const {
    if (var < m_) return row == var + 1 ? -1.0 : 0.0;
    return row == 0 ? 1.0 : column_count(var - m_, row - 1);
  }
  // binv_ = B^-1 by Gauss-Jordan with partial pivoting.
  bool Invert() {
    const int rows = m_ + 1;
    const auto sr = static_cast<std::size_t>(rows);
    a_.assign(sr * sr, 0.0);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < rows; ++j) a_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(j)] = Entry(i, basis_[static_cast<std::size_t>(j)]);
    }
    std::fill(binv_.begin(), binv_.end(), 0.0);
    for (int i = 0; i < rows; ++i) binv_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(i)] = 1.0;
    for (int col = 0; col < rows; ++col) {
      int piv = col;
      for (int i = col + 1; i < rows; ++i) {
        if (std::fabs(a_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(col)]) >
            std::fabs(a_[static_cast<std::size_t>(piv) * sr + static_cast<std::size_t>(col)])) {
          piv = i;
        }
      }
      const double p = a_[static_cast<std::size_t>(piv) * sr + static_cast<std::size_t>(col)];
      if (std::fabs(p) < 1e-12) return false;
      if (piv != col) {
        for (int j = 0; j < rows; ++j) {
          std::swap(a_[static_cast<std::size_t>(piv) * sr + static_cast<std::size_t>(j)], a_[static_cast<std::size_t>(col) * sr + static_cast<std::size_t>(j)]);
          std::swap(binv_[static_cast<std::size_t>(piv) * sr + static_cast<std::size_t>(j)], binv_[static_cast<std::size_t>(col) * sr + static_cast<std::size_t>(j)]);
        }
      }
      for (int j = 0; j < rows; ++j) {
        a_[static_cast<std::size_t>(col) * sr + static_cast<std::size_t>(j)] /= p;
        binv_[static_cast<std::size_t>(col) * sr + static_cast<std::size_t>(j)] /= p;
      }
      for (int i = 0; i < rows; ++i) {
        if (i == col) continue;
        const double f = a_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(col)];
        if (f == 0.0) continue;
        for (int j = 0; j < rows; ++j) {
          a_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(j)] -= f * a_[static_cast<std::size_t>(col) * sr + static_cast<std::size_t>(j)];
          binv_[static_cast<std::size_t>(i) * sr + static_cast<std::size_t>(j)] -= f * binv_[static_cast<std::size_t>(col) * sr + static_cast<std::size_t>(j)];
        }
      }
    }
    return true;
  }

  int m_ = 0;
  bool glpk_rows_ = false;      // the GLPK problem holds this master's rows
  std::vector<std::uint8_t> hints_;  // per column: 1 = start it in GLPK's basis
  std::vector<double> rhs_;
  std::vector<double> cost_;
  std::vector<double> counts_;  // column-major: counts_[k * m_ + i]
  std::vector<int> basis_;
  std::vector<double> a_, binv_, xb_, y_;
  std::vector<double> mu_, lambda_;
  double value_ = 0.0;
  double t_ = 0.0;
};

// ---------------------------------------------------------------------------------------------------------------
// The model over the candidate (non-isolated) vertices, renumbered 0..n-1 in global id order (so each robot's
// candidates stay a contiguous block).
struct Model {
  int n = 0;
  int robots = 0;
  std::vector<int> global_id;
  std::vector<int> robot;           // per vertex
  std::vector<int> robot_first;     // robots + 1 entries: block of robot r = [robot_first[r], robot_first[r+1])
  std::vector<double> weight;
  std::vector<int> adj_first;       // CSR adjacency
  std::vector<int> adj;
  std::vector<int> share;           // per robot
  double total_weight = 0.0;
  bool integral = true;             // every weight is an integer: objectives are integers
  bool unit = true;                 // every weight is 1
  int max_matching = 0;             // N_MM: a lower bound on the number of selected scans
  double abs_tol = 1e-9;            // comparison tolerance in objective units
  int Degree(int v) const { return adj_first[static_cast<std::size_t>(v) + 1] - adj_first[static_cast<std::size_t>(v)]; }
};

// An open node: the fixings that define it (branching decisions and reduced-cost fixings, each re-propagated from
// the root fixings when the node is evaluated, so open nodes stay small), a lower bound and warm-start multipliers.
struct Node {
  std::vector<std::pair<int, Fix>> decisions;
  double bound = 0.0;           // lower bound on the best objective in this subtree
  std::vector<double> lambda;   // per robot: warm start of the Lagrange multipliers
  std::uint64_t seq = 0;        // creation order: among equal bounds the newest node is explored first
  std::uint64_t parent = 0;     // seq of the parent node
  std::shared_ptr<const std::vector<double>> flow;  // edge flows of the parent's last pricing (or null)
};

// Best-first order: smallest bound, then newest (a dive among ties). std heap functions keep the "largest" on top.
struct NodeOrder {
  bool operator()(const Node& a, const Node& b) const {
    if (a.bound != b.bound) return a.bound > b.bound;
    return a.seq < b.seq;
  }
};

class BvcSolver {
 public:
  BvcSolver(const Model& md, const BalancedCoverParams& params, LpSolver* external_lp)
      : md_(md), params_(params), external_lp_(external_lp) {}

  Status Run(MultiRobotCoverResult* res);

 private:
  // Node-independent helpers.
  double RoundBound(double x) const {
    if (!md_.integral) return x;
    return std::ceil(x - std::min(0.25, md_.abs_tol));
  }
  bool Prunable(double bound) const {
    if (best_obj_ == std::numeric_limits<double>::infinity()) return false;
    return md_.integral ? bound > best_obj_ - 0.5 : bound >= best_obj_ - md_.abs_tol;
  }
  bool FixAndPropagate(std::vector<Fix>& fix, std::vector<int>& avail, int v, Fix value);
  // Incumbent from in_, a full 0/1 assignment that covers every edge: repaired to meet the shares, pruned of
  // redundant scans and improved by swaps.
  void OfferCover();
  void SetIn(int v, bool value);  // updates in_ with its counts missing_ and count_
  bool Droppable(int x) const;     // x is selected, all its neighbours too, and its robot is above its share
  bool RepairShares();
  void PruneRedundant();
  void AddDropSearch();

  // Node evaluation.
  Status Evaluate(Node& node, MultiRobotCoverResult* res);
  // Bounds the node (column generation); *done when it needs no branching (pruned or solved).
  Status Bound(Node& node, MultiRobotCoverResult* res, bool* done, std::vector<double>* xbar,
               std::vector<double>* lambda, double* lagrangian);
  int ReducedCostFixing(Node& node, const std::vector<double>& lambda, double lagrangian, bool* infeasible);
  Status BuildNetwork();
  void BuildResidual(const std::vector<Fix>& fix);
  Status Price(const std::vector<double>& lambda, MultiRobotCoverResult* res, double* pricing_value);
  Status SolveMaster(MultiRobotCoverResult* res, bool* ok);
  void OfferColumn(const std::vector<Fix>& fix, const std::vector<std::uint8_t>& x2);
  // Pushes the two children of the node; keep_flow: hand them the current flow for warm starts.
  void Branch(Node& node, const std::vector<double>& xbar, bool keep_flow);
  void Push(Node node);
  // Sets fix_ / avail_ to the node's fixings; false when they contradict each other.
  bool Materialize(const Node& node);

  const Model& md_;
  const BalancedCoverParams& params_;
  LpSolver* external_lp_;

  std::vector<char> best_;
  // Scratch of the incumbent heuristics: the assignment being improved, per vertex the number of unselected
  // neighbours, per robot the number of selected vertices.
  std::vector<char> in_;
  std::vector<int> missing_;
  std::vector<int> count_;
  std::vector<int> prune_order_;   // all vertices, heaviest first, then fewest neighbours
  std::vector<std::pair<double, int>> repair_heap_;
  std::vector<int> swap_cand_;
  std::vector<int> swap_dropped_;
  double best_obj_ = std::numeric_limits<double>::infinity();
  std::vector<Node> open_;         // heap in NodeOrder
  Clock::time_point deadline_;
  bool interrupted_ = false;       // the time limit struck inside a node
  std::uint64_t next_seq_ = 0;
  std::vector<Fix> root_fix_;      // fixings valid for the whole search
  std::vector<Fix> fix_;           // fixings of the node being evaluated
  std::vector<int> avail_;         // per robot: vertices of the evaluated node not fixed to 0

  // The flow network, built once per solve (nodes only change its capacities).
  std::vector<int> colour_;         // per vertex: 0/1 side, 2 = doubled (non-bipartite component), -1 = fixed at the root
  std::vector<int> net_vertices_;   // the vertices in the network (free at the root)
  std::vector<int> node_left_;      // per vertex: network node of the left copy (or -1)
  std::vector<int> node_right_;     // per vertex: network node of the right copy (or -1), offset by left count
  double big_capacity_ = 0.0;       // capacity of vertices fixed to 0
  int net_left_ = 0;
  int net_right_ = 0;
  BipartiteCoverFlow flow_;
  std::size_t net_edge_count_ = 0;
  std::shared_ptr<const std::vector<double>> warm_flow_;  // start of the next pricing instead of the current flow
  std::uint64_t last_evaluated_ = 0;                     // seq of the last node evaluated
  std::vector<double> net_weight_;
  std::vector<char> net_cover_;

  // Residual of the current node.
  std::vector<int> free_;           // free vertices
  std::vector<int> local_;          // vertex -> index in free_ or -1
  std::vector<int> ones_;           // per robot: vertices fixed to 1
  std::vector<int> residual_share_; // per robot
  std::vector<int> active_;         // robots with residual share > 0
  std::vector<int> active_slot_;    // per robot: its index in active_, or -1
  double fixed_weight_ = 0.0;

  // Column generation of the current node.
  MasterLp master_;
  GlpkColumnLp glpk_;               // the master's GLPK problem (MasterLpEngine::kGlpk), kept between nodes
  std::vector<std::vector<std::uint8_t>> columns_;  // 2 * x per free index
  std::vector<std::uint8_t> x2_;                     // last priced column
  std::vector<std::vector<std::uint8_t>> pool_;      // LP support of the last bound, as 2x over all vertices
  double x2_weight_ = 0.0;
  std::vector<double> x2_count_;                     // per active robot
};

bool BvcSolver::FixAndPropagate(std::vector<Fix>& fix, std::vector<int>& avail, int v0, Fix value0) {
  std::vector<std::pair<int, Fix>> queue{{v0, value0}};
  for (std::size_t h = 0; h < queue.size(); ++h) {
    const int v = queue[h].first;
    const Fix value = queue[h].second;
    Fix& fv = fix[static_cast<std::size_t>(v)];
    if (fv == value) continue;
    if (fv >= 0) return false;
    fv = value;
    if (value == 1) continue;
    const int r = md_.robot[static_cast<std::size_t>(v)];
    if (--avail[static_cast<std::size_t>(r)] < md_.share[static_cast<std::size_t>(r)]) return false;
    for (int k = md_.adj_first[static_cast<std::size_t>(v)]; k < md_.adj_first[static_cast<std::size_t>(v) + 1]; ++k) {
      const int w = md_.adj[static_cast<std::size_t>(k)];
      if (fix[static_cast<std::size_t>(w)] == 0) return false;
      if (fix[static_cast<std::size_t>(w)] < 0) queue.push_back({w, 1});
    }
    if (avail[static_cast<std::size_t>(r)] == md_.share[static_cast<std::size_t>(r)]) {
      for (int u = md_.robot_first[static_cast<std::size_t>(r)]; u < md_.robot_first[static_cast<std::size_t>(r) + 1]; ++u) {
        if (fix[static_cast<std::size_t>(u)] < 0) queue.push_back({u, 1});
      }
    }
  }
  return true;
}

void BvcSolver::SetIn(int v, bool value) {
  const auto sv = static_cast<std::size_t>(v);
  in_[sv] = value ? 1 : 0;
  count_[static_cast<std::size_t>(md_.robot[sv])] += value ? 1 : -1;
  for (int k = md_.adj_first[sv]; k < md_.adj_first[sv + 1]; ++k) {
    missing_[static_cast<std::size_t>(md_.adj[static_cast<std::size_t>(k)])] += value ? -1 : 1;
  }
}

bool BvcSolver::Droppable(int x) const {
  const auto sx = static_cast<std::size_t>(x);
  const auto rx = static_cast<std::size_t>(md_.robot[sx]);
  return in_[sx] && missing_[sx] == 0 && count_[rx] > md_.share[rx];
}

bool BvcSolver::RepairShares() {
  // Adds, for each robot short of its share, the vertex with the smallest weight minus the weight of the selected
  // neighbours it makes redundant (lazy greedy), dropping those neighbours while their robot stays at its share.
  using Entry = std::pair<double, int>;
  auto score = [&](int u) {
    double gain = 0.0;
    for (int k = md_.adj_first[static_cast<std::size_t>(u)]; k < md_.adj_first[static_cast<std::size_t>(u) + 1]; ++k) {
      const auto x = static_cast<std::size_t>(md_.adj[static_cast<std::size_t>(k)]);
      const auto rx = static_cast<std::size_t>(md_.robot[x]);
      if (in_[x] && missing_[x] == 1 && count_[rx] > md_.share[rx]) gain += md_.weight[x];
    }
    return md_.weight[static_cast<std::size_t>(u)] - gain;
  };
  std::vector<Entry>& heap = repair_heap_;
  for (int r = 0; r < md_.robots; ++r) {
    const int s = md_.share[static_cast<std::size_t>(r)];
    if (count_[static_cast<std::size_t>(r)] >= s) continue;
    heap.clear();
    for (int u = md_.robot_first[static_cast<std::size_t>(r)]; u < md_.robot_first[static_cast<std::size_t>(r) + 1]; ++u) {
      if (!in_[static_cast<std::size_t>(u)]) heap.emplace_back(score(u), u);
    }
    std::make_heap(heap.begin(), heap.end(), std::greater<Entry>());
    while (count_[static_cast<std::size_t>(r)] < s) {
      if (heap.empty()) return false;
      std::pop_heap(heap.begin(), heap.end(), std::greater<Entry>());
      const int u = heap.back().second;
      const double now = score(u);
      if (heap.size() > 1 && now > heap.front().first + 1e-12) {  // stale score: re-queue
        heap.back().first = now;
        std::push_heap(heap.begin(), heap.end(), std::greater<Entry>());
        continue;
      }
      heap.pop_back();
      SetIn(u, true);
      for (int k = md_.adj_first[static_cast<std::size_t>(u)]; k < md_.adj_first[static_cast<std::size_t>(u) + 1]; ++k) {
        const int x = md_.adj[static_cast<std::size_t>(k)];
        if (Droppable(x)) SetIn(x, false);
      }
    }
  }
  return true;
}

void BvcSolver::PruneRedundant() {
  // Heaviest first (then fewest neighbours, which keeps the most other vertices droppable).
  for (int v : prune_order_) {
    if (Droppable(v)) SetIn(v, false);
  }
}

void BvcSolver::AddDropSearch() {
  // (1, k)-swaps: send one more scan u and stop sending the neighbours it makes redundant (heaviest first, while
  // their robots keep their shares) when that lowers the total weight.
  std::vector<int>& cand = swap_cand_;
  std::vector<int>& dropped = swap_dropped_;
  for (int pass = 0; pass < 6; ++pass) {
    bool improved = false;
    for (int u = 0; u < md_.n; ++u) {
      if (in_[static_cast<std::size_t>(u)]) continue;
      cand.clear();
      double upper = 0.0;
      for (int k = md_.adj_first[static_cast<std::size_t>(u)]; k < md_.adj_first[static_cast<std::size_t>(u) + 1]; ++k) {
        const int x = md_.adj[static_cast<std::size_t>(k)];
        if (in_[static_cast<std::size_t>(x)] && missing_[static_cast<std::size_t>(x)] == 1) {
          cand.push_back(x);
          upper += md_.weight[static_cast<std::size_t>(x)];
        }
      }
      const double wu = md_.weight[static_cast<std::size_t>(u)];
      if (upper <= wu + md_.abs_tol) continue;
      std::sort(cand.begin(), cand.end(), [&](int a, int b) {
        return md_.weight[static_cast<std::size_t>(a)] > md_.weight[static_cast<std::size_t>(b)];
      });
      SetIn(u, true);
      dropped.clear();
      double gain = -wu;
      for (int x : cand) {
        if (Droppable(x)) {
          SetIn(x, false);
          dropped.push_back(x);
          gain += md_.weight[static_cast<std::size_t>(x)];
        }
      }
      if (gain > md_.abs_tol) {
        improved = true;
      } else {
        for (int x : dropped) SetIn(x, true);
        SetIn(u, false);
      }
    }
    if (!improved) break;
  }
}

void BvcSolver::OfferCover() {
  missing_.assign(static_cast<std::size_t>(md_.n), 0);
  count_.assign(static_cast<std::size_t>(md_.robots), 0);
  for (int v = 0; v < md_.n; ++v) {
    if (!in_[static_cast<std::size_t>(v)]) continue;
    ++count_[static_cast<std::size_t>(md_.robot[static_cast<std::size_t>(v)])];
  }
  for (int v = 0; v < md_.n; ++v) {
    if (in_[static_cast<std::size_t>(v)]) continue;  // v is missing for each of its neighbours
    for (int k = md_.adj_first[static_cast<std::size_t>(v)]; k < md_.adj_first[static_cast<std::size_t>(v) + 1]; ++k) {
      ++missing_[static_cast<std::size_t>(md_.adj[static_cast<std::size_t>(k)])];
    }
  }
  if (!RepairShares()) return;
  PruneRedundant();
  AddDropSearch();
  double obj = 0.0;
  for (int v = 0; v < md_.n; ++v) {
    if (in_[static_cast<std::size_t>(v)]) obj += md_.weight[static_cast<std::size_t>(v)];
  }
  if (md_.integral) obj = std::round(obj);
  if (obj < best_obj_ - (md_.integral ? 0.5 : md_.abs_tol)) {
    best_obj_ = obj;
    best_ = in_;
  }
}

Status BvcSolver::BuildNetwork() {
  // 2-colour the graph of the vertices free at the root (the others and their edges never enter a pricing);
  // components with an odd cycle use the bipartite double cover (two copies of each vertex, half its cost each:
  // the min-cut then solves the half-integral vertex-cover LP). Nodes only change capacities (fixed to 1: free,
  // 0; fixed to 0: "infinite"), so flows carry over from one pricing to the next.
  const auto n = static_cast<std::size_t>(md_.n);
  colour_.assign(n, -1);
  net_vertices_.clear();
  std::vector<int> comp;
  for (std::size_t s = 0; s < n; ++s) {
    if (colour_[s] >= 0 || root_fix_[s] >= 0) continue;
    comp.assign(1, static_cast<int>(s));
    colour_[s] = md_.robots == 2 ? md_.robot[s] : 0;  // two robots: the robot is the side
    bool odd = false;
    for (std::size_t h = 0; h < comp.size(); ++h) {
      const int v = comp[h];
      for (int k = md_.adj_first[static_cast<std::size_t>(v)]; k < md_.adj_first[static_cast<std::size_t>(v) + 1]; ++k) {
        const auto w = static_cast<std::size_t>(md_.adj[static_cast<std::size_t>(k)]);
        if (root_fix_[w] >= 0) continue;
        if (colour_[w] < 0) {
          colour_[w] = 1 - colour_[static_cast<std::size_t>(v)];
          comp.push_back(static_cast<int>(w));
        } else if (colour_[w] == colour_[static_cast<std::size_t>(v)]) {
          odd = true;
        }
      }
    }
    if (odd) {
      for (int v : comp) colour_[static_cast<std::size_t>(v)] = 2;
    }
  }
  node_left_.assign(n, -1);
  node_right_.assign(n, -1);
  net_left_ = 0;
  net_right_ = 0;
  for (std::size_t v = 0; v < n; ++v) {
    if (colour_[v] < 0) continue;
    net_vertices_.push_back(static_cast<int>(v));
    if (colour_[v] != 1) node_left_[v] = net_left_++;
    if (colour_[v] != 0) node_right_[v] = net_right_++;
  }
  std::vector<std::pair<int, int>> net_edges;
  for (int v : net_vertices_) {
    if (colour_[static_cast<std::size_t>(v)] == 1) continue;  // every edge once, from its left end (both directions for doubled edges)
    for (int k = md_.adj_first[static_cast<std::size_t>(v)]; k < md_.adj_first[static_cast<std::size_t>(v) + 1]; ++k) {
      const auto w = static_cast<std::size_t>(md_.adj[static_cast<std::size_t>(k)]);
      if (colour_[w] >= 0) net_edges.emplace_back(node_left_[static_cast<std::size_t>(v)], node_right_[w]);
    }
  }
  big_capacity_ = 2.0 * md_.total_weight + 1.0;
  net_edge_count_ = net_edges.size();
  return flow_.Assign(net_left_, net_right_, net_edges);
}

void BvcSolver::BuildResidual(const std::vector<Fix>& fix) {
  const auto n = static_cast<std::size_t>(md_.n);
  free_.clear();
  local_.assign(n, -1);
  ones_.assign(static_cast<std::size_t>(md_.robots), 0);
  fixed_weight_ = 0.0;
  for (int v = 0; v < md_.n; ++v) {
    const Fix f = fix[static_cast<std::size_t>(v)];
    if (f == 1) {
      ++ones_[static_cast<std::size_t>(md_.robot[static_cast<std::size_t>(v)])];
      fixed_weight_ += md_.weight[static_cast<std::size_t>(v)];
    } else if (f < 0) {
      local_[static_cast<std::size_t>(v)] = static_cast<int>(free_.size());
      free_.push_back(v);
    }
  }
  residual_share_.assign(static_cast<std::size_t>(md_.robots), 0);
  active_.clear();
  active_slot_.assign(static_cast<std::size_t>(md_.robots), -1);
  for (int r = 0; r < md_.robots; ++r) {
    residual_share_[static_cast<std::size_t>(r)] = std::max(0, md_.share[static_cast<std::size_t>(r)] - ones_[static_cast<std::size_t>(r)]);
    if (residual_share_[static_cast<std::size_t>(r)] == 0) continue;
    active_slot_[static_cast<std::size_t>(r)] = static_cast<int>(active_.size());
    active_.push_back(r);
  }
}

Status BvcSolver::Price(const std::vector<double>& lambda, MultiRobotCoverResult* res, double* pricing_value) {
  const std::size_t nf = free_.size();
  net_weight_.resize(static_cast<std::size_t>(net_left_ + net_right_));  // every node is set below
  double negative = 0.0;
  for (int v : net_vertices_) {
    const Fix f = fix_[static_cast<std::size_t>(v)];
    double cap = 0.0;  // fixed to 1: already paid for, covers its edges for free
    if (f == 0) {
      cap = big_capacity_;  // never in a minimum cut
    } else if (f < 0) {
      const double c = md_.weight[static_cast<std::size_t>(v)] - lambda[static_cast<std::size_t>(md_.robot[static_cast<std::size_t>(v)])];
      if (c < 0.0) negative += c;  // sent in every Lagrangian optimum
      cap = std::max(0.0, c);
    }
    const int colour = colour_[static_cast<std::size_t>(v)];
    if (colour == 2) {
      net_weight_[static_cast<std::size_t>(node_left_[static_cast<std::size_t>(v)])] = 0.5 * cap;
      net_weight_[static_cast<std::size_t>(net_left_ + node_right_[static_cast<std::size_t>(v)])] = 0.5 * cap;
    } else if (colour == 0) {
      net_weight_[static_cast<std::size_t>(node_left_[static_cast<std::size_t>(v)])] = cap;
    } else {
      net_weight_[static_cast<std::size_t>(net_left_ + node_right_[static_cast<std::size_t>(v)])] = cap;
    }
  }
  // Warm start from the previous flow (any start is exact; a close one saves most augmentations).
  Result<double> flow = warm_flow_ != nullptr ? flow_.Solve(net_weight_, &net_cover_, warm_flow_.get())
                                               : flow_.Resolve(net_weight_, &net_cover_);
  warm_flow_.reset();
  ++res->min_cut_solves;
  if (!flow.ok()) return flow.status();
  *pricing_value = *flow + negative;
  x2_.assign(nf, 0);
  x2_weight_ = 0.0;
  x2_count_.assign(active_.size(), 0.0);
  for (std::size_t i = 0; i < nf; ++i) {
    const auto v = static_cast<std::size_t>(free_[i]);
    const int r = md_.robot[v];
    const double c = md_.weight[v] - lambda[static_cast<std::size_t>(r)];
    std::uint8_t x2 = 0;
    if (c < 0.0) {
      x2 = 2;
    } else if (colour_[v] == 2) {
      x2 = static_cast<std::uint8_t>(net_cover_[static_cast<std::size_t>(node_left_[v])] +
                                     net_cover_[static_cast<std::size_t>(net_left_ + node_right_[v])]);
    } else if (colour_[v] == 0) {
      x2 = static_cast<std::uint8_t>(2 * net_cover_[static_cast<std::size_t>(node_left_[v])]);
    } else {
      x2 = static_cast<std::uint8_t>(2 * net_cover_[static_cast<std::size_t>(net_left_ + node_right_[v])]);
    }
    x2_[i] = x2;
    x2_weight_ += 0.5 * x2 * md_.weight[v];
    const int slot = active_slot_[static_cast<std::size_t>(r)];
    if (slot >= 0) x2_count_[static_cast<std::size_t>(slot)] += 0.5 * x2;
  }
  return Status::Ok();
}

Status BvcSolver::SolveMaster(MultiRobotCoverResult* res, bool* ok) {
  ++res->lp_solves;
  if (external_lp_ == nullptr && params_.master_lp == MasterLpEngine::kGlpk) {
    const std::int64_t it0 = glpk_.simplex_iterations();
    const std::int64_t rebuilds0 = glpk_.basis_rebuilds();
    Status st = master_.SolveWithGlpk(glpk_, ok);
    res->simplex_iterations += glpk_.simplex_iterations() - it0;
    res->lp_basis_rebuilds += glpk_.basis_rebuilds() - rebuilds0;
    if (st.ok() && *ok) return Status::Ok();
    // GLPK failed or found no optimum (neither happens for a feasible master): the dense simplex gets one try,
    // and the next GLPK solve starts from a fresh problem.
    ++res->lp_basis_rebuilds;
    master_.ForgetGlpkRows();
  }
  if (external_lp_ == nullptr) {
    *ok = master_.Solve();
    if (*ok) return Status::Ok();
    // The dense simplex gave up (iteration cap or a near-singular basis): let GLPK solve this master once.
    GlpkSimplexSolver fallback;
    Result<LpSolution> sol = fallback.Minimize(master_.AsLinearProgram());
    if (!sol.ok()) return sol.status();
    *ok = master_.SetSolution(*sol);
    return Status::Ok();
  }
  Result<LpSolution> sol = external_lp_->Minimize(master_.AsLinearProgram());
  if (!sol.ok()) return sol.status();
  *ok = master_.SetSolution(*sol);
  return Status::Ok();
}

void BvcSolver::OfferColumn(const std::vector<Fix>& fix, const std::vector<std::uint8_t>& x2) {
  in_.assign(static_cast<std::size_t>(md_.n), 0);
  for (int v = 0; v < md_.n; ++v) {
    const Fix f = fix[static_cast<std::size_t>(v)];
    if (f == 1) {
      in_[static_cast<std::size_t>(v)] = 1;
    } else if (f < 0) {
      in_[static_cast<std::size_t>(v)] = x2[static_cast<std::size_t>(local_[static_cast<std::size_t>(v)])] > 0 ? 1 : 0;
    }
  }
  OfferCover();
}

void BvcSolver::Push(Node node) {
  node.seq = next_seq_++;
  open_.push_back(std::move(node));
  std::push_heap(open_.begin(), open_.end(), NodeOrder());
}

bool BvcSolver::Materialize(const Node& node) {
  fix_ = root_fix_;
  avail_.assign(static_cast<std::size_t>(md_.robots), 0);
  for (int u = 0; u < md_.n; ++u) {
    if (fix_[static_cast<std::size_t>(u)] != 0) ++avail_[static_cast<std::size_t>(md_.robot[static_cast<std::size_t>(u)])];
  }
  for (const auto& d : node.decisions) {
    if (!FixAndPropagate(fix_, avail_, d.first, d.second)) return false;
  }
  return true;
}

void BvcSolver::Branch(Node& node, const std::vector<double>& xbar, bool keep_flow) {
  // The fractional free vertex whose two branches both promise a large change, from rough estimates of the cost
  // increase of each branch (up: raising x_v to 1; down: raising its free neighbours to 1, minus x_v). Preferring
  // vertices that are expensive both ways (e.g. in a dense block whose sides the LP mixes) closes the gap in far
  // fewer nodes than the fractionality alone. With real weights the smaller estimate ranks best; with unit weights
  // the estimates are little more than degrees, and their product ranks better (both measured on the benchmarks).
  // Ties (frequent with unit weights, e.g. an LP at 1/2 everywhere) go to a pseudo-random vertex: branching in
  // index order would walk along one corner of a regular graph, and spreading the decisions prunes much earlier.
  auto tie_key = [](int v) { return static_cast<std::uint32_t>(v) * 2654435761U; };
  int best = -1;
  double best_score = -1.0;
  for (std::size_t i = 0; i < free_.size(); ++i) {
    const double x = xbar[i];
    if (std::min(x, 1.0 - x) <= kFracTol || fix_[static_cast<std::size_t>(free_[i])] >= 0) continue;
    const auto v = static_cast<std::size_t>(free_[i]);
    const double wv = md_.weight[v];
    double down = -wv * x;
    for (int k = md_.adj_first[v]; k < md_.adj_first[v + 1]; ++k) {
      const auto u = static_cast<std::size_t>(md_.adj[static_cast<std::size_t>(k)]);
      if (fix_[u] < 0) down += md_.weight[u] * (1.0 - xbar[static_cast<std::size_t>(local_[u])]);
    }
    const double up = wv * (1.0 - x);
    const double tiny = 1e-6 * wv;  // keeps a zero estimate from hiding the other one
    const double score = md_.unit ? std::max(down, tiny) * std::max(up, tiny) : std::max(std::min(down, up), tiny);
    const bool tie = best >= 0 && std::fabs(score - best_score) <= 1e-9 * best_score;
    if (tie ? tie_key(free_[i]) > tie_key(free_[static_cast<std::size_t>(best)]) : score > best_score) {
      best_score = tie ? std::max(score, best_score) : score;
      best = static_cast<int>(i);
    }
  }
  if (best < 0) {
    // No fractional vertex (the column generation stopped at its limit): branch on the largest degree.
    for (std::size_t i = 0; i < free_.size(); ++i) {
      if (best < 0 || md_.Degree(free_[i]) > md_.Degree(free_[static_cast<std::size_t>(best)])) best = static_cast<int>(i);
    }
    if (best < 0) return;
  }
  const int v = free_[static_cast<std::size_t>(best)];
  const Fix preferred = xbar[static_cast<std::size_t>(best)] >= 0.5 ? 1 : 0;
  // The children keep this node's final flow, to warm-start their first pricing when they are not evaluated
  // right after it (within a memory budget).
  std::shared_ptr<const std::vector<double>> flow;
  if (keep_flow && net_edge_count_ * (open_.size() + 2) <= kMaxKeptFlowValues) {
    auto edge_flows = std::make_shared<std::vector<double>>();
    flow_.EdgeFlows(edge_flows.get());
    flow = std::move(edge_flows);
  }
  // Children whose fixings are already contradictory are dropped here.
  for (const Fix value : {static_cast<Fix>(1 - preferred), preferred}) {
    std::vector<Fix> fix = fix_;
    std::vector<int> avail = avail_;
    if (!FixAndPropagate(fix, avail, v, value)) continue;
    Node child{node.decisions, node.bound, node.lambda, 0, node.seq, flow};
    child.decisions.emplace_back(v, value);
    Push(std::move(child));  // the preferred child is pushed last: explored first among equal bounds
  }
}

int BvcSolver::ReducedCostFixing(Node& node, const std::vector<double>& lambda, double lagrangian, bool* infeasible) {
  // Lagrangian/LP reduced costs of the last pricing (see BipartiteCoverFlow::TerminalResidual): any solution of
  // this node that sends free vertex v weighs at least fixed + lagrangian + d_v, and any that does not send a
  // vertex of negative Lagrangian cost c_v weighs at least fixed + lagrangian - c_v. Vertices whose forced value
  // cannot beat the incumbent are fixed the other way.
  *infeasible = false;
  if (best_obj_ == std::numeric_limits<double>::infinity()) return 0;
  const double base = fixed_weight_ + lagrangian;
  std::vector<std::pair<int, Fix>> fixes;
  for (std::size_t i = 0; i < free_.size(); ++i) {
    const int v = free_[i];
    const double c = md_.weight[static_cast<std::size_t>(v)] - lambda[static_cast<std::size_t>(md_.robot[static_cast<std::size_t>(v)])];
    if (c < 0.0) {
      if (Prunable(RoundBound(base - c))) fixes.emplace_back(v, Fix{1});
      continue;
    }
    double d = 0.0;
    if (node_left_[static_cast<std::size_t>(v)] >= 0) d += flow_.TerminalResidual(node_left_[static_cast<std::size_t>(v)]);
    if (node_right_[static_cast<std::size_t>(v)] >= 0) d += flow_.TerminalResidual(net_left_ + node_right_[static_cast<std::size_t>(v)]);
    if (d > 0.0 && Prunable(RoundBound(base + d))) fixes.emplace_back(v, Fix{0});
  }
  for (const auto& f : fixes) {
    node.decisions.push_back(f);
    if (!FixAndPropagate(fix_, avail_, f.first, f.second)) {
      *infeasible = true;
      break;
    }
  }
  return static_cast<int>(fixes.size());
}

Status BvcSolver::Evaluate(Node& node, MultiRobotCoverResult* res) {
  if (!Materialize(node)) return Status::Ok();
  // A node evaluated right after its parent continues from the parent's flow anyway; any other node starts from
  // the flow its parent left, when kept, rather than from an unrelated node's.
  warm_flow_ = node.parent != last_evaluated_ ? node.flow : nullptr;
  last_evaluated_ = node.seq;
  bool fresh_network = false;  // the network was rebuilt after the last pricing (it holds no flow)
  for (int pass = 0;; ++pass) {
    bool done = false;
    std::vector<double> xbar;
    std::vector<double> lambda(static_cast<std::size_t>(md_.robots), 0.0);
    double lagrangian = 0.0;
    Status st = Bound(node, res, &done, &xbar, &lambda, &lagrangian);
    if (!st.ok()) return st;
    fresh_network = false;
    if (interrupted_) {  // time limit inside the node: it stays open with the bound reached so far
      Push(std::move(node));
      return Status::Ok();
    }
    if (done) return Status::Ok();
    bool rebound = false;
    if (pass < kMaxFixingPasses) {
      bool infeasible = false;
      const int fixed = ReducedCostFixing(node, lambda, lagrangian, &infeasible);
      if (infeasible) return Status::Ok();
      // Re-bound the node when the fixings are substantial; otherwise they only take effect in the children.
      rebound = fixed > 0 && fixed >= kReboundFraction * static_cast<double>(free_.size());
    }
    // The root's reduced-cost fixings hold in the whole tree: they become root fixings, so that nodes neither
    // re-propagate them nor carry their vertices in the network. Before a re-bound of the root this pays (the
    // rebuilt network starts without a flow) only when the network at least halves.
    if (res->nodes_explored == 1 && !node.decisions.empty() &&
        (!rebound || static_cast<double>(std::count(fix_.begin(), fix_.end(), Fix{-1})) <=
                         0.5 * static_cast<double>(net_vertices_.size()))) {
      root_fix_ = fix_;
      node.decisions.clear();
      Status built = BuildNetwork();
      if (!built.ok()) return built;
      fresh_network = true;
    }
    if (rebound) continue;
    Branch(node, xbar, !fresh_network);
    return Status::Ok();
  }
}

Status BvcSolver::Bound(Node& node, MultiRobotCoverResult* res, bool* done, std::vector<double>* xbar_out,
                        std::vector<double>* lambda_out, double* lagrangian_out) {
  *done = false;
  BuildResidual(fix_);
  const std::size_t nf = free_.size();
  std::vector<double>& lambda = *lambda_out;
  std::vector<double>& xbar = *xbar_out;
  xbar.assign(nf, 0.0);

  if (active_.empty()) {
    // No balance row left: a pure weighted vertex cover of the residual graph, solved by one min-cut (exact when
    // the residual is bipartite; the half-integral LP otherwise).
    std::fill(lambda.begin(), lambda.end(), 0.0);
    double p = 0.0;
    Status st = Price(lambda, res, &p);
    if (!st.ok()) return st;
    ++res->lp_solves;
    *lagrangian_out = p;
    node.bound = std::max(node.bound, RoundBound(fixed_weight_ + p));
    OfferColumn(fix_, x2_);
    const bool integral = std::all_of(x2_.begin(), x2_.end(), [](std::uint8_t x) { return x != 1; });
    if (integral || Prunable(node.bound)) {  // an integral LP optimum solves the node
      *done = true;
      return Status::Ok();
    }
    for (std::size_t i = 0; i < nf; ++i) xbar[i] = 0.5 * x2_[i];
    return Status::Ok();
  }

  // Column generation for the LP bound with the balance rows.
  const std::size_t m = active_.size();
  std::vector<double> rhs(m);
  for (std::size_t a = 0; a < m; ++a) rhs[a] = residual_share_[static_cast<std::size_t>(active_[a])];
  master_.Reset(static_cast<int>(m), rhs);
  columns_.clear();
  {
    // Column 0: every free vertex (meets every residual share after propagation).
    std::vector<double> counts(m, 0.0);
    double w = 0.0;
    for (std::size_t i = 0; i < nf; ++i) w += md_.weight[static_cast<std::size_t>(free_[i])];
    for (std::size_t a = 0; a < m; ++a) {
      const int r = active_[a];
      for (int v = md_.robot_first[static_cast<std::size_t>(r)]; v < md_.robot_first[static_cast<std::size_t>(r) + 1]; ++v) {
        if (local_[static_cast<std::size_t>(v)] >= 0) counts[a] += 1.0;
      }
    }
    master_.AddColumn(w, counts);
    columns_.emplace_back(nf, 2);
  }
  // Covers of the previous bound (full-graph covers, so their restriction to this node's free vertices covers its
  // residual graph): in a dive they are the parent's LP support and give near-optimal multipliers at once.
  for (const auto& full : pool_) {
    std::vector<std::uint8_t> col(nf, 0);
    std::vector<double> counts(m, 0.0);
    double w = 0.0;
    for (std::size_t i = 0; i < nf; ++i) {
      const auto v = static_cast<std::size_t>(free_[i]);
      col[i] = full[v];
      w += 0.5 * col[i] * md_.weight[v];
      const int slot = active_slot_[static_cast<std::size_t>(md_.robot[v])];
      if (slot >= 0) counts[static_cast<std::size_t>(slot)] += 0.5 * col[i];
    }
    master_.AddColumn(w, counts, /*basic_hint=*/true);  // basic in the parent's optimum (mu > 0)
    columns_.push_back(std::move(col));
  }
  // Stabilised column generation (Wentges smoothing): the pricing multipliers are a convex combination of the
  // master duals and the stability centre, the multipliers of the best Lagrangian bound so far. The first pricing
  // is at the centre inherited from the parent (see below for unit weights), which often prunes the node at once
  // or lands close to the new optimum, and smoothing damps the oscillation of pure master duals. A pricing whose
  // cover does not improve the master still closes the gap between the bound and the master value by the
  // smoothing factor; it is followed by a pricing at the master duals, so the loop ends exactly as unstabilised
  // column generation does.
  constexpr double kSmoothing = 0.7;
  double lb = -std::numeric_limits<double>::infinity();
  std::vector<double>& center = node.lambda;
  center.resize(static_cast<std::size_t>(md_.robots), 0.0);
  for (int r = 0; r < md_.robots; ++r) {
    if (residual_share_[static_cast<std::size_t>(r)] == 0) center[static_cast<std::size_t>(r)] = 0.0;
  }
  lambda = center;
  std::vector<double> dual(static_cast<std::size_t>(md_.robots), 0.0);  // master duals per robot
  auto read_duals = [&]() {
    for (std::size_t a = 0; a < m; ++a) dual[static_cast<std::size_t>(active_[a])] = master_.lambda()[a];
  };
  bool have_master = false;
  bool converged = false;
  bool at_duals = false;  // the last pricing was at the master duals
  if (!pool_.empty()) {
    bool ok = false;
    Status st = SolveMaster(res, &ok);
    if (!st.ok()) return st;
    if (!ok) return Status(StatusCode::kInternal, "balanced vertex cover: the master LP could not be solved");
    have_master = true;
    read_duals();
    if (md_.unit) {
      // With unit weights the multipliers are small and a single fixing moves them a lot, so the parent's are a
      // poor guess: start half-way towards the duals of the master over the parent's columns (fewer pricings).
      for (std::size_t a = 0; a < m; ++a) {
        const auto r = static_cast<std::size_t>(active_[a]);
        lambda[r] = kSmoothing * center[r] + (1.0 - kSmoothing) * dual[r];
      }
    }
  }
  const int kMaxColumns = 500;
  for (int iter = 0;; ++iter) {
    if (iter > 0 && Clock::now() > deadline_) {  // a huge node must not overrun the time limit
      interrupted_ = true;
      return Status::Ok();
    }
    double p = 0.0;
    Status st = Price(lambda, res, &p);
    if (!st.ok()) return st;
    double lag = p;
    for (std::size_t a = 0; a < m; ++a) lag += lambda[static_cast<std::size_t>(active_[a])] * rhs[a];
    *lagrangian_out = lag;
    if (lag > lb) {
      lb = lag;
      center = lambda;
    }
    {
      // A priced cover that already meets the residual shares is a feasible solution.
      bool feasible = std::all_of(x2_.begin(), x2_.end(), [](std::uint8_t x) { return x != 1; });
      for (std::size_t a = 0; a < m && feasible; ++a) feasible = x2_count_[a] >= rhs[a] - 1e-9;
      // Repairing infeasible covers is costly: only at the root, where it seeds the incumbent, and only for
      // pricings that raised the bound (elsewhere the rounded LP point of every node is repaired).
      const bool repair = res->nodes_explored <= 1 && lag >= lb;
      if (feasible ? !Prunable(RoundBound(fixed_weight_ + x2_weight_ - md_.abs_tol)) : repair) OfferColumn(fix_, x2_);
    }
    node.bound = std::max(node.bound, RoundBound(fixed_weight_ + lb));
    if (Prunable(node.bound)) {
      *done = true;
      return Status::Ok();
    }
    bool improving = true;
    if (have_master) {
      const double tol = 1e-9 * std::max(1.0, std::fabs(master_.value()));
      // The bound meets the restricted master value: the LP bound is reached.
      if (lb >= master_.value() - tol) {
        converged = true;
        break;
      }
      // No better integer bound is possible from this LP.
      if (md_.integral && RoundBound(fixed_weight_ + master_.value()) <= node.bound) {
        converged = true;
        break;
      }
      double reduced = x2_weight_ - master_.t();
      for (std::size_t a = 0; a < m; ++a) reduced -= master_.lambda()[a] * x2_count_[a];
      improving = reduced < -tol;
      if (!improving && at_duals) {  // cannot happen in exact arithmetic (the bound would meet the master value)
        converged = true;
        break;
      }
    }
    if (iter >= kMaxColumns) break;
    if (improving) {
      master_.AddColumn(x2_weight_, x2_count_);
      columns_.push_back(x2_);
      bool ok = false;
      st = SolveMaster(res, &ok);
      if (!st.ok()) return st;
      if (!ok) return Status(StatusCode::kInternal, "balanced vertex cover: the master LP could not be solved");
      have_master = true;
      read_duals();
    }
    at_duals = !improving;
    for (std::size_t a = 0; a < m; ++a) {
      const auto r = static_cast<std::size_t>(active_[a]);
      lambda[r] = at_duals ? dual[r] : kSmoothing * center[r] + (1.0 - kSmoothing) * dual[r];
    }
  }
  // Fractional LP point and its rounding. (lambda is the multiplier vector of the last pricing.) The LP support
  // becomes the column pool of the next bound.
  pool_.clear();
  for (int k = 0; k < master_.columns(); ++k) {
    const double mu = master_.mu()[static_cast<std::size_t>(k)];
    if (mu <= 0.0) continue;
    const auto& col = columns_[static_cast<std::size_t>(k)];
    for (std::size_t i = 0; i < nf; ++i) xbar[i] += 0.5 * mu * col[i];
    if (k == 0) continue;  // the all-free column is rebuilt anyway
    std::vector<std::uint8_t> full(static_cast<std::size_t>(md_.n), 0);
    for (int v = 0; v < md_.n; ++v) {
      const Fix f = fix_[static_cast<std::size_t>(v)];
      full[static_cast<std::size_t>(v)] = f == 1 ? 2 : (f == 0 ? 0 : col[static_cast<std::size_t>(local_[static_cast<std::size_t>(v)])]);
    }
    pool_.push_back(std::move(full));
  }
  bool integral = true;
  std::vector<std::uint8_t> rounded(nf, 0);
  for (std::size_t i = 0; i < nf; ++i) {
    if (std::min(xbar[i], 1.0 - xbar[i]) > kFracTol) integral = false;
    rounded[i] = xbar[i] >= 0.5 - kFracTol ? 2 : 0;
  }
  OfferColumn(fix_, rounded);
  if ((integral && converged) || Prunable(node.bound)) *done = true;
  return Status::Ok();
}

Status BvcSolver::Run(MultiRobotCoverResult* res) {
  const Clock::time_point start = Clock::now();
  deadline_ = start + std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(std::min(params_.time_limit_s, 1e9)));
  // A robot whose share equals its candidate count sends all of them.
  root_fix_.assign(static_cast<std::size_t>(md_.n), -1);
  for (int r = 0; r < md_.robots; ++r) {
    const int first = md_.robot_first[static_cast<std::size_t>(r)];
    const int last = md_.robot_first[static_cast<std::size_t>(r) + 1];
    if (md_.share[static_cast<std::size_t>(r)] == last - first) {
      std::fill(root_fix_.begin() + first, root_fix_.begin() + last, Fix{1});
    }
  }
  Status built = BuildNetwork();
  if (!built.ok()) return built;
  // Initial incumbent: every candidate, pruned.
  prune_order_.resize(static_cast<std::size_t>(md_.n));
  for (int v = 0; v < md_.n; ++v) prune_order_[static_cast<std::size_t>(v)] = v;
  std::sort(prune_order_.begin(), prune_order_.end(), [&](int a, int b) {
    const double wa = md_.weight[static_cast<std::size_t>(a)];
    const double wb = md_.weight[static_cast<std::size_t>(b)];
    if (wa != wb) return wa > wb;
    return md_.Degree(a) < md_.Degree(b);
  });
  in_.assign(static_cast<std::size_t>(md_.n), 1);
  OfferCover();

  Node root;
  root.lambda.assign(static_cast<std::size_t>(md_.robots), 0.0);
  // Trivial bound: each robot sends at least its share of its cheapest scans; with unit weights every cover
  // has at least N_MM scans (a matching needs one endpoint per matched edge).
  double trivial = 0.0;
  for (int r = 0; r < md_.robots; ++r) {
    std::vector<double> ws(md_.weight.begin() + md_.robot_first[static_cast<std::size_t>(r)],
                           md_.weight.begin() + md_.robot_first[static_cast<std::size_t>(r) + 1]);
    std::sort(ws.begin(), ws.end());
    for (int k = 0; k < md_.share[static_cast<std::size_t>(r)] && k < static_cast<int>(ws.size()); ++k) {
      trivial += ws[static_cast<std::size_t>(k)];
    }
  }
  if (md_.unit) trivial = std::max(trivial, static_cast<double>(md_.max_matching));
  root.bound = RoundBound(trivial);
  const double root_bound = root.bound;
  Push(std::move(root));
  bool limit_hit = false;
  double open_bound = std::numeric_limits<double>::infinity();
  while (!open_.empty()) {
    // The top has the smallest bound: once it cannot improve the incumbent, no open node can.
    if (Prunable(open_.front().bound)) {
      open_.clear();
      break;
    }
    if (res->nodes_explored >= params_.max_nodes || interrupted_ || Clock::now() > deadline_) {
      limit_hit = true;
      open_bound = open_.front().bound;
      break;
    }
    std::pop_heap(open_.begin(), open_.end(), NodeOrder());
    Node node = std::move(open_.back());
    open_.pop_back();
    ++res->nodes_explored;
    Status st = Evaluate(node, res);
    if (!st.ok()) return st;
  }
  if (best_obj_ == std::numeric_limits<double>::infinity()) {
    res->status = limit_hit ? BalancedCoverStatus::kLimitWithoutSolution : BalancedCoverStatus::kInfeasible;
    res->lower_bound_weight = limit_hit ? std::min(open_bound, root_bound) : 0.0;
    return Status::Ok();
  }
  res->selected_per_robot.assign(static_cast<std::size_t>(md_.robots), 0);
  double obj = 0.0;
  for (int v = 0; v < md_.n; ++v) {
    if (!best_[static_cast<std::size_t>(v)]) continue;
    res->selected.push_back(md_.global_id[static_cast<std::size_t>(v)]);
    ++res->selected_per_robot[static_cast<std::size_t>(md_.robot[static_cast<std::size_t>(v)])];
    obj += md_.weight[static_cast<std::size_t>(v)];
  }
  res->objective_scans = static_cast<int>(res->selected.size());
  res->objective_weight = md_.integral ? std::round(obj) : obj;
  const double lower = limit_hit ? std::min(open_bound, best_obj_) : best_obj_;
  res->lower_bound_weight = std::min(lower, res->objective_weight);
  const bool gap = md_.integral ? res->lower_bound_weight < res->objective_weight - 0.5
                                : res->lower_bound_weight < res->objective_weight - md_.abs_tol;
  res->status = gap ? BalancedCoverStatus::kFeasibleWithGap : BalancedCoverStatus::kOptimal;
  if (!gap) res->lower_bound_weight = res->objective_weight;
  return Status::Ok();
}

Status ValidateCommon(const BalancedCoverParams& params, int vertex_count) {
  if (params.max_nodes < 1) return InvalidArgument("balanced vertex cover: max_nodes must be >= 1");
  if (!(params.time_limit_s > 0.0)) return InvalidArgument("balanced vertex cover: time_limit_s must be > 0");
  if (params.master_lp != MasterLpEngine::kGlpk && params.master_lp != MasterLpEngine::kDense) {
    return InvalidArgument("balanced vertex cover: master_lp is not an engine");
  }
  if (!params.vertex_weights.empty()) {
    if (params.vertex_weights.size() != static_cast<std::size_t>(vertex_count)) {
      return InvalidArgument("balanced vertex cover: " + std::to_string(params.vertex_weights.size()) +
                             " vertex weights for " + std::to_string(vertex_count) + " vertices");
    }
    double total = 0.0;
    for (std::size_t v = 0; v < params.vertex_weights.size(); ++v) {
      const double w = params.vertex_weights[v];
      if (!std::isfinite(w) || !(w > 0.0)) {
        return InvalidArgument("balanced vertex cover: weight of vertex " + std::to_string(v) +
                               " must be finite and > 0, got " + std::to_string(w));
      }
      total += w;
    }
    if (!(total <= kMaxTotalWeight)) {
      return InvalidArgument("balanced vertex cover: the vertex weights sum to more than 1e100");
    }
  }
  return Status::Ok();
}

}  // namespace

const char* BalancedCoverStatusName(BalancedCoverStatus status) noexcept {
  switch (status) {
    case BalancedCoverStatus::kOptimal: return "optimal";
    case BalancedCoverStatus::kFeasibleWithGap: return "feasible with gap";
    case BalancedCoverStatus::kInfeasible: return "infeasible";
    case BalancedCoverStatus::kLimitWithoutSolution: return "limit without solution";
    case BalancedCoverStatus::kNoCandidates: return "no candidates";
  }
  return "unknown";
}

const char* MasterLpEngineName(MasterLpEngine engine) noexcept {
  switch (engine) {
    case MasterLpEngine::kGlpk: return "glpk";
    case MasterLpEngine::kDense: return "dense";
  }
  return "invalid";
}

Result<int> BalancedShare(int max_matching_size, const std::vector<double>& participation) {
  if (max_matching_size < 0) return InvalidArgument("balanced share: negative matching size");
  std::vector<double> p = participation;
  if (p.empty()) p = {0.5, 0.5};
  double sum = 0.0;
  double entropy_bits = 0.0;
  for (double pr : p) {
    if (!std::isfinite(pr) || pr < 0.0) return InvalidArgument("balanced share: participation ratios must be finite and >= 0");
    sum += pr;
    if (pr > 0.0) entropy_bits -= pr * std::log2(pr);
  }
  if (std::fabs(sum - 1.0) > 1e-9) {
    return InvalidArgument("balanced share: participation ratios sum to " + std::to_string(sum) + ", not 1");
  }
  const double effective_robots = std::exp2(std::max(0.0, entropy_bits));
  const double raw = static_cast<double>(max_matching_size) / effective_robots;
  return static_cast<int>(std::ceil(raw - 1e-9));
}

Result<MultiRobotCoverResult> SolveMultiRobotBalancedCover(const ExchangeGraph& graph,
                                                           const BalancedCoverParams& params,
                                                           LpSolver* lp_solver) {
  const int robots = graph.robot_count();
  if (!params.participation.empty() && params.participation.size() != static_cast<std::size_t>(robots)) {
    return InvalidArgument("balanced vertex cover: participation must have one entry per robot (" +
                           std::to_string(robots) + "), got " + std::to_string(params.participation.size()));
  }
  Status valid = ValidateCommon(params, graph.vertex_count());
  if (!valid.ok()) return valid;

  MultiRobotCoverResult res;
  res.max_matching_size = MaximumMatchingSize(graph);
  if (params.min_share_per_robot_override >= 0) {
    res.min_share_per_robot = params.min_share_per_robot_override;
  } else {
    std::vector<double> p = params.participation;
    if (p.empty() && robots > 0) p.assign(static_cast<std::size_t>(robots), 1.0 / robots);
    if (p.empty()) p = {1.0};
    Result<int> share = BalancedShare(res.max_matching_size, p);
    if (!share.ok()) return share.status();
    res.min_share_per_robot = *share;
  }

  // Candidate model.
  Model md;
  md.robots = robots;
  const auto& adj = graph.adjacency();
  std::vector<int> compact(static_cast<std::size_t>(graph.vertex_count()), -1);
  md.robot_first.assign(static_cast<std::size_t>(robots) + 1, 0);
  res.candidates_per_robot.assign(static_cast<std::size_t>(robots), 0);
  for (int v = 0; v < graph.vertex_count(); ++v) {
    if (adj[static_cast<std::size_t>(v)].empty()) continue;
    compact[static_cast<std::size_t>(v)] = md.n++;
    md.global_id.push_back(v);
    md.robot.push_back(graph.robot_of(v));
    md.weight.push_back(params.vertex_weights.empty() ? 1.0 : params.vertex_weights[static_cast<std::size_t>(v)]);
    ++res.candidates_per_robot[static_cast<std::size_t>(graph.robot_of(v))];
  }
  for (int r = 0; r < robots; ++r) {
    md.robot_first[static_cast<std::size_t>(r) + 1] = md.robot_first[static_cast<std::size_t>(r)] + res.candidates_per_robot[static_cast<std::size_t>(r)];
  }
  res.share_per_robot.assign(static_cast<std::size_t>(robots), 0);
  bool infeasible = false;
  for (int r = 0; r < robots; ++r) {
    const int cand = res.candidates_per_robot[static_cast<std::size_t>(r)];
    int s = 0;
    if (cand > 0) s = params.min_share_per_robot_override >= 0 ? res.min_share_per_robot : std::min(res.min_share_per_robot, cand);
    if (s > cand) infeasible = true;
    res.share_per_robot[static_cast<std::size_t>(r)] = s;
  }
  res.selected_per_robot.assign(static_cast<std::size_t>(robots), 0);
  if (md.n == 0) {
    res.status = BalancedCoverStatus::kNoCandidates;
    return res;
  }
  if (infeasible) {
    res.status = BalancedCoverStatus::kInfeasible;
    return res;
  }
  md.share = res.share_per_robot;
  md.adj_first.assign(static_cast<std::size_t>(md.n) + 1, 0);
  for (int i = 0; i < md.n; ++i) {
    const int v = md.global_id[static_cast<std::size_t>(i)];
    for (int w : adj[static_cast<std::size_t>(v)]) {
      const int j = compact[static_cast<std::size_t>(w)];
      md.adj.push_back(j);
    }
    md.adj_first[static_cast<std::size_t>(i) + 1] = static_cast<int>(md.adj.size());
  }
  for (double w : md.weight) {
    md.total_weight += w;
    if (w != std::floor(w)) md.integral = false;
    if (w != 1.0) md.unit = false;
  }
  md.max_matching = res.max_matching_size;
  if (md.total_weight > 1e15) md.integral = false;
  md.abs_tol = 1e-9 * std::max(1.0, md.total_weight);

  BvcSolver solver(md, params, lp_solver);
  Status st = solver.Run(&res);
  if (!st.ok()) return st;
  return res;
}

Result<BalancedCoverResult> SolveBalancedVertexCover(const BipartiteGraph& graph, const BalancedCoverParams& params,
                                                     LpSolver* lp_solver) {
  if (!params.participation.empty() && params.participation.size() != 2) {
    return InvalidArgument("balanced vertex cover: participation must have 2 entries (one per robot), got " +
                           std::to_string(params.participation.size()));
  }
  Result<ExchangeGraph> eg = ExchangeGraph::FromBipartite(graph);
  if (!eg.ok()) return eg.status();
  Result<MultiRobotCoverResult> mr = SolveMultiRobotBalancedCover(*eg, params, lp_solver);
  if (!mr.ok()) return mr.status();
  BalancedCoverResult res;
  res.status = mr->status;
  const int left = graph.left_count();
  for (int v : mr->selected) {
    if (v < left) {
      res.selected_left.push_back(v);
    } else {
      res.selected_right.push_back(v - left);
    }
  }
  res.objective_scans = mr->objective_scans;
  res.objective_weight = mr->objective_weight;
  res.lower_bound_weight = mr->lower_bound_weight;
  const bool unit = params.vertex_weights.empty();
  if (unit) {
    res.lower_bound_scans = static_cast<int>(std::lround(mr->lower_bound_weight));
  } else {
    res.lower_bound_scans = mr->status == BalancedCoverStatus::kOptimal ? mr->objective_scans : 0;
  }
  res.max_matching_size = mr->max_matching_size;
  res.min_share_per_robot = mr->min_share_per_robot;
  res.nodes_explored = mr->nodes_explored;
  res.lp_solves = mr->lp_solves;
  res.min_cut_solves = mr->min_cut_solves;
  res.simplex_iterations = mr->simplex_iterations;
  res.lp_basis_rebuilds = mr->lp_basis_rebuilds;
  return res;
}

}  // namespace commerge
