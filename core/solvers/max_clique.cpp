// SPDX-License-Identifier: BSD-3-Clause
// Maximum clique by bitset branch-and-bound in the MCS/BBMC family (Tomita et al.; San Segundo et al.):
//   1. renumber the vertices by a smallest-last (degeneracy) ordering and copy the adjacency as bitset rows;
//   2. greedy incumbent (several starts, bounded work);
//   3. depth-first search over candidate bitsets P (one preallocated frame per depth). Each node colours P
//      greedily into independent sets ("colour classes"), turns the colouring into a bound per branching
//      position, and branches on the candidates from the highest bound down, pruning as soon as
//      value(C) + bound <= best.
// The bound per objective (S_1..S_k are the colour classes of P in colouring order; a clique K of P takes at most
// one vertex from each class):
//   * cardinality: |K| <= number of classes (BBMC: vertices of colour < kmin = best - |C| + 1 are never branched
//     on), tightened by an infra-chromatic test on the vertices of colour kmin (BBMCX; InfraChromatic below).
//     MCS-style re-colouring (Re-NUMBER) was measured too: fewer nodes, but more time on the DIMACS set than the
//     infra-chromatic test alone, so it is not used;
//   * vertex weights: sum over classes of the class's largest weight;
//   * edge weights: orientation of the clique's edges by colour class (validity argument below), and once, when
//     the search has not finished after params.lp_after_nodes nodes, the LP relaxation of clique_lp_bound.hpp over
//     the whole graph with the root's colour classes (GLPK's simplex): it caps the root's branch bounds and the
//     upper bound reported at a limit (RootLpBound below); a node limit that stops the search earlier solves it
//     then, as the certificate of the gap it reports.
// The hot loop allocates nothing once each depth's buffers have grown to their working size.
#include "core/solvers/max_clique.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <new>
#include <string>
#include <utility>

#include "core/solvers/clique_lp_bound.hpp"
#include "core/solvers/lp_relaxation.hpp"

namespace commerge {
namespace {

using Word = std::uint64_t;

inline int LowestBit(Word w) { return __builtin_ctzll(w); }
// The x86-64 baseline has no POPCNT instruction (GCC then calls a libgcc routine); a SWAR count is faster there.
inline int PopCount(Word w) {
#if defined(__POPCNT__) || defined(__aarch64__)
  return __builtin_popcountll(w);
#else
  w = w - ((w >> 1) & 0x5555555555555555ULL);
  w = (w & 0x3333333333333333ULL) + ((w >> 2) & 0x3333333333333333ULL);
  w = (w + (w >> 4)) & 0x0f0f0f0f0f0f0f0fULL;
  return static_cast<int>((w * 0x0101010101010101ULL) >> 56);
#endif
}
inline bool TestBit(const Word* row, int v) { return ((row[v >> 6] >> (v & 63)) & 1U) != 0U; }
inline void SetBit(Word* row, int v) { row[v >> 6] |= Word{1} << (v & 63); }
inline void ClearBit(Word* row, int v) { row[v >> 6] &= ~(Word{1} << (v & 63)); }
inline std::size_t Idx(int i) { return static_cast<std::size_t>(i); }

std::size_t WordsFor(int n) { return (static_cast<std::size_t>(n) + 63) / 64; }

// Validity of the edge-weight bound (the argument the search relies on).
//
// At a node, C is the current clique with value f(C), P the candidates (each adjacent to all of C), and
// wc(v) = sum_{c in C} w(c, v). For a clique K of P,
//     f(C u K) = f(C) + sum_{v in K} wc(v) + sum_{{u,v} in K} w(u, v).
// Colour P greedily into independent sets S_1, ..., S_k and orient every edge {u, v} of K towards the vertex
// of the LATER class (u in S_a, v in S_b, a < b; a != b since a class is independent). Then
//     sum_{{u,v} in K} w(u,v) = sum_{v in K} sum_{u in K, class(u) < class(v)} w(u,v)
//                            <= sum_{v in K} sum_{a < class(v)} m_a(v),   m_a(v) = max_{u in S_a, u ~ v} w(u,v)
// because K has at most one vertex in each S_a and that vertex is a neighbour of v (0 when S_a has none).
// With y(v) = wc(v) + sum_{a < class(v)} m_a(v) (weights are >= 0, so y >= 0):
//     f(C u K) - f(C) <= sum_{v in K} y(v) <= sum_{b} max_{v in S_b} y(v)   (again at most one v per class).
// y(v) depends only on the classes before v's own, so for the candidates listed in colouring order the bound
// of any prefix "S_1..S_{b-1} plus the part of S_b up to position i" is
//     bound(i) = sum_{a < b} max_{S_a} y + max_{u in S_b, pos(u) <= i} y(u),
// which is exactly what the branch at position i (cliques of positions <= i) needs. Sorting each class by y
// makes the last term y(v_i) itself, and bound(i) is non-decreasing in i, so one test prunes a whole prefix.
// The vertex-weight bound is the same with y(v) = w(v); the cardinality bound with y(v) = 1.

class CliqueSearch {
 public:
  CliqueSearch(const CliqueGraph& graph, const CliqueSearchParams& params,
               std::chrono::steady_clock::time_point deadline)
      : g_(graph),
        params_(params),
        deadline_(deadline),
        n_(graph.num_vertices()),
        words_(graph.words_per_row()),
        edge_(params.objective == CliqueObjective::kEdgeWeight),
        cardinality_(params.objective == CliqueObjective::kCardinality) {}

  void Run(CliqueSearchResult* out);

 private:
  struct Frame {
    std::vector<Word> p;        // candidate set; only words [lo, hi] are meaningful
    int lo = 0;
    int hi = -1;
    std::vector<int> list;      // branching candidates in colouring order
    std::vector<double> bound;  // bound[i]: gain bound of any clique of positions <= i (non-decreasing)
    int cursor = -1;            // next position to branch on (descending), -1 when the frame is done
    double value = 0.0;         // objective of the current clique C at this depth
    std::size_t save_mark = 0;  // edge objective: size of the wc save stack when this frame was entered
  };

  const Word* Row(int v) const { return adj_.data() + Idx(v) * words_; }
  double Gain(int v) const { return cardinality_ ? 1.0 : (edge_ ? wc_[Idx(v)] : vw_[Idx(v)]); }
  float EdgeW(int u, int v) const { return g_.edge_weight_row(orig_[Idx(u)])[orig_[Idx(v)]]; }

  void BuildOrder();
  void Greedy();
  void Colour(Frame* f);
  void ColourCardinality(Frame* f);
  bool InfraChromatic(const Frame* f, int v, int classes);
  void Grow(Frame* f, int size);
  void ColourWeighted(Frame* f);
  // Removes one colour class from u_[ulo..hi]: a maximal independent set taken greedily in index order. Calls
  // visit(v) for each of its vertices in that order and, when `s` is not null, stores the class in s[ulo..hi].
  template <class Visit>
  void TakeClass(int ulo, int hi, Word* s, Visit&& visit) {
    Word* u = u_.data();
    Word* q = q_.data();
    for (int w = ulo; w <= hi; ++w) q[w] = u[w];
    for (int w = ulo; w <= hi; ++w) {
      Word x = q[w];
      Word taken = 0U;
      while (x != 0U) {
        const int b = LowestBit(x);
        const Word bit = Word{1} << b;
        taken |= bit;
        const int v = w * 64 + b;
        const Word* nv = Row(v);
        x &= ~(nv[w] | bit);
        for (int t = w + 1; t <= hi; ++t) q[t] &= ~nv[t];
        visit(v);
      }
      u[w] &= ~taken;
      if (s != nullptr) s[w] = taken;
    }
  }
  void Search();
  void SaveRootColouring();
  void RootLpBound();
  Word* ClassBits(int k) { return class_bits_.data() + Idx(k) * words_; }
  bool TimeUp() {
    if (work_ < kClockWork) return false;
    work_ = 0;
    return std::chrono::steady_clock::now() >= deadline_;
  }
  void Record(int size, double value) {
    best_ = value;
    best_clique_.assign(clique_.begin(), clique_.begin() + size);
  }

  static constexpr std::int64_t kClockWork = 1 << 14;  // candidates coloured between two clock reads

  const CliqueGraph& g_;
  const CliqueSearchParams params_;
  const std::chrono::steady_clock::time_point deadline_;
  const int n_;
  const std::size_t words_;
  const bool edge_;
  const bool cardinality_;

  std::vector<int> orig_;  // search index -> graph vertex
  std::vector<Word> adj_;  // adjacency in search indices
  std::vector<double> vw_;
  std::vector<double> wc_;  // edge objective: weight from each candidate to the current clique
  std::vector<int> saved_index_;
  std::vector<double> saved_value_;

  std::vector<Frame> frames_;
  std::vector<int> clique_;
  std::vector<int> best_clique_;
  double best_ = 0.0;
  std::int64_t nodes_ = 0;
  std::int64_t work_ = 0;
  bool stopped_ = false;
  int stop_depth_ = 0;
  CliqueLpBoundResult lp_;  // root LP bound (edge objective with params.lp_bound)
  double lp_cap_ = std::numeric_limits<double>::infinity();  // lp_.upper_bound once valid
  int lp_solves_ = 0;

  // Colouring scratch (one node at a time).
  std::vector<Word> u_, q_, class_bits_;
  std::vector<int> ord_, ord_orig_, class_start_;
  int classes_ = 0;  // colour classes of the last ColourWeighted call (ord_ / class_start_ hold them)
  CliqueColouring root_colouring_;  // graph vertex ids, for the LP
  bool lp_pending_ = false;         // the LP is still to be computed (after params.lp_after_nodes nodes)
  std::vector<double> y_, prefix_;
  std::vector<std::pair<double, int>> sort_buf_;
};

// Smallest-last ordering (Batagelj-Zaversnik bucket queue): the vertex removed last (deepest core) gets search
// index 0, so greedy colouring in index order gives the dense core the low colours and the branching, which
// starts from the highest colours, begins with vertices of small neighbourhoods.
void CliqueSearch::BuildOrder() {
  const int n = n_;
  std::vector<int> deg(Idx(n)), pos(Idx(n)), vert(Idx(n));
  int max_deg = 0;
  for (int v = 0; v < n; ++v) {
    const std::uint64_t* row = g_.adjacency_row(v);
    int d = 0;
    for (std::size_t w = 0; w < words_; ++w) d += PopCount(row[w]);
    deg[Idx(v)] = d;
    max_deg = std::max(max_deg, d);
  }
  std::vector<int> bin(Idx(max_deg) + 2, 0);
  for (int v = 0; v < n; ++v) ++bin[Idx(deg[Idx(v)])];
  int start = 0;
  for (int d = 0; d <= max_deg; ++d) {
    const int count = bin[Idx(d)];
    bin[Idx(d)] = start;
    start += count;
  }
  for (int v = 0; v < n; ++v) {
    pos[Idx(v)] = bin[Idx(deg[Idx(v)])]++;
    vert[Idx(pos[Idx(v)])] = v;
  }
  for (int d = max_deg; d > 0; --d) bin[Idx(d)] = bin[Idx(d) - 1];
  bin[0] = 0;
  for (int i = 0; i < n; ++i) {
    const int v = vert[Idx(i)];
    const std::uint64_t* row = g_.adjacency_row(v);
    for (std::size_t w = 0; w < words_; ++w) {
      for (Word x = row[w]; x != 0U; x &= x - 1) {
        const int u = static_cast<int>(w * 64) + LowestBit(x);
        if (deg[Idx(u)] > deg[Idx(v)]) {
          const int du = deg[Idx(u)];
          const int pu = pos[Idx(u)];
          const int pw = bin[Idx(du)];
          const int wv = vert[Idx(pw)];
          if (u != wv) {
            pos[Idx(u)] = pw;
            vert[Idx(pu)] = wv;
            pos[Idx(wv)] = pu;
            vert[Idx(pw)] = u;
          }
          ++bin[Idx(du)];
          --deg[Idx(u)];
        }
      }
    }
  }
  orig_.resize(Idx(n));
  std::vector<int> inv(Idx(n));
  for (int i = 0; i < n; ++i) {
    orig_[Idx(n - 1 - i)] = vert[Idx(i)];
    inv[Idx(vert[Idx(i)])] = n - 1 - i;
  }
  if (!cardinality_ && !edge_) {
    // Vertex weights: re-sort stably by increasing weight (ties keep the degeneracy order). Light vertices then
    // fill the first colour classes and each class holds similar weights, which lowers the sum of class maxima;
    // over the 15 MWC benchmarks this took 40 % less time than the plain degeneracy order (more on C125.9,
    // MANN_a9 and p_hat300-2, much less on hamming8-4 and brock200_*). For edge weights the degeneracy order
    // was clearly better (brock200_1: 3x fewer nodes than sorting by incident weight).
    std::stable_sort(orig_.begin(), orig_.end(),
                     [&](int a, int b) { return g_.vertex_weight(a) < g_.vertex_weight(b); });
    for (int i = 0; i < n; ++i) inv[Idx(orig_[Idx(i)])] = i;
  }
  adj_.assign(Idx(n) * words_, 0U);
  vw_.resize(Idx(n));
  for (int a = 0; a < n; ++a) {
    const std::uint64_t* row = g_.adjacency_row(orig_[Idx(a)]);
    Word* out = adj_.data() + Idx(a) * words_;
    for (std::size_t w = 0; w < words_; ++w) {
      for (Word x = row[w]; x != 0U; x &= x - 1) SetBit(out, inv[Idx(static_cast<int>(w * 64) + LowestBit(x))]);
    }
    vw_[Idx(a)] = g_.vertex_weight(orig_[Idx(a)]);
  }
}

// Greedy incumbent: from each start vertex (in search order, as long as a work budget lasts), repeatedly add the
// candidate of largest immediate gain (cardinality: most neighbours among the candidates, or the largest degree
// once the budget is spent; vertex weights: largest weight; edge weights: largest weight to the clique so far).
// Ties go to the lowest search index. The first start always completes, so the incumbent is a maximal clique.
void CliqueSearch::Greedy() {
  const int n = n_;
  std::vector<int> deg(Idx(n));
  for (int v = 0; v < n; ++v) {
    int d = 0;
    for (std::size_t w = 0; w < words_; ++w) d += PopCount(Row(v)[w]);
    deg[Idx(v)] = d;
  }
  std::vector<int> starts(Idx(n));
  for (int v = 0; v < n; ++v) starts[Idx(v)] = v;
  if (edge_) {
    std::vector<double> incident(Idx(n), 0.0);
    for (int v = 0; v < n; ++v) {
      const Word* row = Row(v);
      for (std::size_t w = 0; w < words_; ++w) {
        for (Word x = row[w]; x != 0U; x &= x - 1) {
          incident[Idx(v)] += static_cast<double>(EdgeW(v, static_cast<int>(w * 64) + LowestBit(x)));
        }
      }
    }
    std::stable_sort(starts.begin(), starts.end(),
                     [&](int a, int b) { return incident[Idx(a)] > incident[Idx(b)]; });
  } else if (!cardinality_) {
    std::stable_sort(starts.begin(), starts.end(), [&](int a, int b) { return vw_[Idx(a)] > vw_[Idx(b)]; });
  }
  std::vector<Word> cand(words_);
  std::vector<double> to_clique(edge_ ? Idx(n) : 0, 0.0);
  std::vector<int> clique;
  std::int64_t budget = 20'000'000;
  // Edge objective: a single vertex (value 0) is the incumbent to beat strictly, so a graph without a positive
  // edge gives one vertex, as documented.
  best_ = edge_ ? 0.0 : -1.0;
  if (edge_) best_clique_.assign(1, starts[0]);
  for (const int s : starts) {
    clique.assign(1, s);
    double value = cardinality_ ? 1.0 : (edge_ ? 0.0 : vw_[Idx(s)]);
    std::copy(Row(s), Row(s) + words_, cand.begin());
    if (edge_) {
      for (std::size_t w = 0; w < words_; ++w) {
        for (Word x = cand[w]; x != 0U; x &= x - 1) {
          const int u = static_cast<int>(w * 64) + LowestBit(x);
          to_clique[Idx(u)] = static_cast<double>(EdgeW(s, u));
        }
      }
    }
    std::int64_t cost = static_cast<std::int64_t>(words_);
    for (;;) {
      int pick = -1;
      double pick_key = -1.0;
      for (std::size_t w = 0; w < words_; ++w) {
        for (Word x = cand[w]; x != 0U; x &= x - 1) {
          const int u = static_cast<int>(w * 64) + LowestBit(x);
          double key = 0.0;
          if (cardinality_ && cost < budget) {  // degree inside the candidates while the budget lasts
            const Word* nu = Row(u);
            int inside = 0;
            for (std::size_t t = 0; t < words_; ++t) inside += PopCount(nu[t] & cand[t]);
            key = static_cast<double>(inside);
            cost += static_cast<std::int64_t>(words_);
          } else if (cardinality_) {
            key = static_cast<double>(deg[Idx(u)]);  // static degree
          } else {
            key = edge_ ? to_clique[Idx(u)] : vw_[Idx(u)];
          }
          if (key > pick_key) {
            pick_key = key;
            pick = u;
          }
          ++cost;
        }
      }
      if (pick < 0) break;
      clique.push_back(pick);
      value += cardinality_ ? 1.0 : pick_key;
      const Word* row = Row(pick);
      for (std::size_t w = 0; w < words_; ++w) cand[w] &= row[w];
      cost += static_cast<std::int64_t>(words_);
      if (edge_) {
        for (std::size_t w = 0; w < words_; ++w) {
          for (Word x = cand[w]; x != 0U; x &= x - 1) {
            const int u = static_cast<int>(w * 64) + LowestBit(x);
            to_clique[Idx(u)] += static_cast<double>(EdgeW(pick, u));
          }
        }
      }
    }
    if (value > best_) {
      best_ = value;
      best_clique_ = clique;
    }
    budget -= cost;
    if (budget < 0) break;
  }
}

void CliqueSearch::Colour(Frame* f) {
  if (cardinality_) {
    ColourCardinality(f);
  } else {
    ColourWeighted(f);
  }
  work_ += 16 + (f->hi - f->lo) + f->cursor;
}

// Lists grow to the largest size a depth has needed (amortised: no allocation in the steady state).
void CliqueSearch::Grow(Frame* f, int size) {
  const std::size_t want = std::max<std::size_t>(Idx(size) + 1, 2 * f->list.size());
  f->list.resize(std::min(want, Idx(n_)));
  f->bound.resize(f->list.size());
}

// BBMC colouring: class by class, each class a maximal independent set taken greedily in index order. Classes
// below kmin (colour + |C| <= best) are not listed; they are kept as bitsets for the infra-chromatic test.
void CliqueSearch::ColourCardinality(Frame* f) {
  const int lo = f->lo;
  const int hi = f->hi;
  Word* u = u_.data();
  for (int w = lo; w <= hi; ++w) u[w] = f->p[Idx(w)];
  const int kmin = static_cast<int>(best_ - f->value) + 1;
  int k = 0;
  int ulo = lo;
  while (k < kmin - 1) {
    while (ulo <= hi && u[ulo] == 0U) ++ulo;
    if (ulo > hi) break;
    ++k;
    if (class_bits_.size() < Idx(k + 1) * words_) class_bits_.resize(Idx(k + 1) * words_);
    Word* s = ClassBits(k);
    for (int w = lo; w < ulo; ++w) s[w] = 0U;
    TakeClass(ulo, hi, s, [](int) {});
  }
  int size = 0;
  while (ulo <= hi && u[ulo] == 0U) ++ulo;
  const int below = k;  // classes 1..below are stored (below == kmin - 1 when vertices are left)
  const bool reduce = below >= 2;
  while (ulo <= hi) {
    ++k;
    const double colour = static_cast<double>(k);
    if (reduce && k == below + 1) {
      // Class kmin: drop what the infra-chromatic test proves useless (decided once the class is complete).
      int pending = 0;
      TakeClass(ulo, hi, nullptr, [&](int v) { ord_[Idx(pending++)] = v; });
      for (int t = 0; t < pending; ++t) {
        const int v = ord_[Idx(t)];
        if (InfraChromatic(f, v, below)) continue;
        if (Idx(size) == f->list.size()) Grow(f, size);
        f->list[Idx(size)] = v;
        f->bound[Idx(size)] = colour;
        ++size;
      }
    } else {
      TakeClass(ulo, hi, nullptr, [&](int v) {
        if (Idx(size) == f->list.size()) Grow(f, size);
        f->list[Idx(size)] = v;
        f->bound[Idx(size)] = colour;
        ++size;
      });
    }
    while (ulo <= hi && u[ulo] == 0U) ++ulo;
  }
  f->cursor = size - 1;
}

// Infra-chromatic test (after San Segundo, Nikolaev, Batsyn 2015) for a vertex v of class kmin = classes + 1.
// If v has no neighbour in some class C_i, or exactly one neighbour w in C_i and no common neighbour with w in
// another class C_j, then a clique K of C_1..C_classes plus v cannot use both C_i and C_j (nor C_i at all), so
// |K| <= classes: v cannot improve the incumbent and need not be branched on. The vertices dropped this way all
// lie in class kmin (an independent set), so a clique holds at most one of them and the bound kmin + t of every
// later listed vertex stays valid: a clique of positions <= i splits into its part in C_1..C_kmin (at most kmin)
// and at most one vertex per later class.
bool CliqueSearch::InfraChromatic(const Frame* f, int v, int classes) {
  const int lo = f->lo;
  const int hi = f->hi;
  const Word* nv = Row(v);
  for (int i = 1; i <= classes; ++i) {
    const Word* si = ClassBits(i);
    int conflicts = 0;
    int cw = -1;
    for (int w = lo; w <= hi; ++w) {
      const Word c = nv[w] & si[w];
      if (c != 0U) {
        conflicts += (c & (c - 1)) != 0U ? 2 : 1;
        if (conflicts > 1) break;
        cw = w;
      }
    }
    if (conflicts == 0) return true;
    if (conflicts > 1) continue;
    const Word* nw = Row(cw * 64 + LowestBit(nv[cw] & si[cw]));
    for (int j = 1; j <= classes; ++j) {
      if (j == i) continue;
      const Word* sj = ClassBits(j);
      bool empty = true;
      for (int w = lo; w <= hi; ++w) {
        if ((nv[w] & nw[w] & sj[w]) != 0U) {
          empty = false;
          break;
        }
      }
      if (empty) return true;
    }
  }
  return false;
}

// Weighted colouring: the same classes, every candidate listed, bound from y (see the validity note above).
void CliqueSearch::ColourWeighted(Frame* f) {
  const int lo = f->lo;
  const int hi = f->hi;
  Word* u = u_.data();
  for (int w = lo; w <= hi; ++w) u[w] = f->p[Idx(w)];
  int count = 0;
  int classes = 0;
  int ulo = lo;
  for (;;) {
    while (ulo <= hi && u[ulo] == 0U) ++ulo;
    if (ulo > hi) break;
    class_start_[Idx(classes++)] = count;
    TakeClass(ulo, hi, nullptr, [&](int v) { ord_[Idx(count++)] = v; });
  }
  class_start_[Idx(classes)] = count;
  classes_ = classes;

  if (edge_) {
    for (int p = 0; p < count; ++p) ord_orig_[Idx(p)] = orig_[Idx(ord_[Idx(p)])];
    for (int c = 0; c < classes; ++c) {
      for (int p = class_start_[Idx(c)]; p < class_start_[Idx(c) + 1]; ++p) {
        const int v = ord_[Idx(p)];
        const Word* nv = Row(v);
        const float* wrow = g_.edge_weight_row(orig_[Idx(v)]);
        double acc = wc_[Idx(v)];
        for (int a = 0; a < c; ++a) {
          float best_w = 0.0f;
          for (int t = class_start_[Idx(a)]; t < class_start_[Idx(a) + 1]; ++t) {
            if (TestBit(nv, ord_[Idx(t)])) best_w = std::max(best_w, wrow[ord_orig_[Idx(t)]]);
          }
          acc += static_cast<double>(best_w);
        }
        y_[Idx(p)] = acc;
      }
    }
  } else {
    for (int p = 0; p < count; ++p) y_[Idx(p)] = vw_[Idx(ord_[Idx(p)])];
  }

  // Sort each class by (y, index): the running class maximum is then y itself.
  double base = 0.0;
  for (int c = 0; c < classes; ++c) {
    const int b = class_start_[Idx(c)];
    const int e = class_start_[Idx(c) + 1];
    for (int p = b; p < e; ++p) sort_buf_[Idx(p - b)] = {y_[Idx(p)], ord_[Idx(p)]};
    std::sort(sort_buf_.begin(), sort_buf_.begin() + (e - b));
    for (int p = b; p < e; ++p) {
      ord_[Idx(p)] = sort_buf_[Idx(p - b)].second;
      prefix_[Idx(p)] = base + sort_buf_[Idx(p - b)].first;
    }
    base += sort_buf_[Idx(e - b - 1)].first;
  }
  int first = 0;
  while (first < count && f->value + prefix_[Idx(first)] <= best_) ++first;
  if (f->list.size() < Idx(count - first)) Grow(f, count - first);
  int size = 0;
  for (int p = first; p < count; ++p, ++size) {
    f->list[Idx(size)] = ord_[Idx(p)];
    f->bound[Idx(size)] = prefix_[Idx(p)];
  }
  f->cursor = size - 1;
}

// The root's colour classes (ord_ / class_start_ right after the root's colouring; sorted by y inside each class,
// which does not matter to the LP), kept in graph ids for the LP, which may come later.
void CliqueSearch::SaveRootColouring() {
  const int count = class_start_[Idx(classes_)];
  root_colouring_.vertices.resize(Idx(count));
  for (int p = 0; p < count; ++p) root_colouring_.vertices[Idx(p)] = orig_[Idx(ord_[Idx(p)])];
  root_colouring_.class_start.assign(class_start_.begin(), class_start_.begin() + classes_ + 1);
}

// Root LP bound (clique_lp_bound.hpp) with the root's colour classes. The LP bounds every clique of the graph, so
// capping the root's remaining (non-decreasing) branch bounds with it keeps them valid and non-decreasing: the
// root then stops branching once the incumbent reaches the LP bound, and the search ends at once when the incumbent
// already does (Search). Only branches that cannot beat the incumbent strictly are cut, so the cliques recorded,
// and the result, are the same with or without it. Too many coefficients: retried without the non-edge rows. An
// engine failure leaves the search without the bound. Not started past the deadline; a solve is not interruptible.
void CliqueSearch::RootLpBound() {
  lp_pending_ = false;
  if (std::chrono::steady_clock::now() >= deadline_) return;
  std::vector<int> vertices(Idx(n_));
  for (int v = 0; v < n_; ++v) vertices[Idx(v)] = v;
  CliqueLpBoundParams lp_params;
  lp_params.max_nonzeros = params_.lp_max_nonzeros;
  GlpkSimplexSolver glpk;
  for (const bool non_edge_rows : {true, false}) {
    lp_params.non_edge_rows = non_edge_rows;
    Result<CliqueLpBoundResult> r = ComputeCliqueLpBound(g_, vertices, {}, &root_colouring_, &glpk, lp_params);
    if (!r.ok()) {
      lp_.status = CliqueLpStatus::kFailed;
      return;
    }
    lp_solves_ += r->simplex_solves;
    lp_ = *r;
    if (lp_.status != CliqueLpStatus::kTooLarge) break;
  }
  if (lp_.status != CliqueLpStatus::kOptimal && lp_.status != CliqueLpStatus::kTrivial) return;
  lp_cap_ = lp_.upper_bound;
  Frame& root = frames_[0];
  for (int i = 0; i <= root.cursor; ++i) root.bound[Idx(i)] = std::min(root.bound[Idx(i)], lp_cap_);
}

void CliqueSearch::Search() {
  Frame& root = frames_[0];
  root.p.assign(words_, ~Word{0});
  if (n_ % 64 != 0) root.p[words_ - 1] = (Word{1} << (n_ % 64)) - 1;
  root.lo = 0;
  root.hi = static_cast<int>(words_) - 1;
  root.value = 0.0;
  Colour(&root);
  nodes_ = 1;
  if (edge_ && params_.lp_bound) {
    SaveRootColouring();
    lp_pending_ = true;
    if (params_.lp_after_nodes <= nodes_) RootLpBound();
  }
  int d = 0;
  for (;;) {
    Frame& f = frames_[Idx(d)];
    if (f.cursor < 0) {
      if (d == 0) break;
      if (edge_) {
        const std::size_t mark = f.save_mark;
        while (saved_index_.size() > mark) {
          wc_[Idx(saved_index_.back())] = saved_value_.back();
          saved_index_.pop_back();
          saved_value_.pop_back();
        }
      }
      --d;
      continue;
    }
    const int i = f.cursor;
    if (f.value + f.bound[Idx(i)] <= best_) {
      f.cursor = -1;
      continue;
    }
    const int v = f.list[Idx(i)];
    if (frames_.size() < Idx(d) + 2) {
      frames_.emplace_back();  // capacity reserved: `f` stays valid
      frames_.back().p.resize(words_);
    }
    Frame& c = frames_[Idx(d) + 1];
    const Word* nv = Row(v);
    int lo = -1;
    int hi = -1;
    for (int w = f.lo; w <= f.hi; ++w) {
      const Word x = f.p[Idx(w)] & nv[w];
      c.p[Idx(w)] = x;
      if (x != 0U) {
        if (lo < 0) lo = w;
        hi = w;
      }
    }
    const double value = f.value + Gain(v);
    clique_[Idx(d)] = v;
    if (value > best_) {
      Record(d + 1, value);
      if (best_ >= lp_cap_) return;  // the root LP bound is reached: no clique beats it strictly
    }
    if (lo < 0) {
      f.cursor = i - 1;
      ClearBit(f.p.data(), v);
      continue;
    }
    if (nodes_ >= params_.max_nodes || TimeUp()) {
      stopped_ = true;
      stop_depth_ = d;
      return;
    }
    f.cursor = i - 1;
    ClearBit(f.p.data(), v);
    c.lo = lo;
    c.hi = hi;
    c.value = value;
    if (edge_) {
      c.save_mark = saved_index_.size();
      const float* wrow = g_.edge_weight_row(orig_[Idx(v)]);
      for (int w = lo; w <= hi; ++w) {
        for (Word x = c.p[Idx(w)]; x != 0U; x &= x - 1) {
          const int t = w * 64 + LowestBit(x);
          saved_index_.push_back(t);
          saved_value_.push_back(wc_[Idx(t)]);
          wc_[Idx(t)] += static_cast<double>(wrow[orig_[Idx(t)]]);
        }
      }
    }
    Colour(&c);
    ++nodes_;
    ++d;
    if (lp_pending_ && nodes_ >= params_.lp_after_nodes) {
      RootLpBound();
      if (best_ >= lp_cap_) return;
    }
  }
}

void CliqueSearch::Run(CliqueSearchResult* out) {
  BuildOrder();
  frames_.reserve(Idx(n_) + 2);
  frames_.emplace_back();
  clique_.assign(Idx(n_) + 1, 0);
  u_.assign(words_, 0U);
  q_.assign(words_, 0U);
  ord_.assign(Idx(n_), 0);
  class_start_.assign(Idx(n_) + 1, 0);
  y_.assign(Idx(n_), 0.0);
  prefix_.assign(Idx(n_), 0.0);
  sort_buf_.assign(Idx(n_), {0.0, 0});
  if (edge_) {
    ord_orig_.assign(Idx(n_), 0);
    wc_.assign(Idx(n_), 0.0);
    saved_index_.reserve(Idx(n_) * 4);
    saved_value_.reserve(Idx(n_) * 4);
  }
  Greedy();
  Search();

  double upper = best_;
  if (stopped_) {
    for (int d = 0; d <= stop_depth_; ++d) {
      const Frame& f = frames_[Idx(d)];
      if (f.cursor >= 0) upper = std::max(upper, f.value + f.bound[Idx(f.cursor)]);
    }
    // A node limit stopped the search before the LP was due: solve it now as the gap certificate (one solve, only
    // for a search that did not finish; a time limit leaves no time for it).
    if (lp_pending_ && upper > best_) RootLpBound();
  }
  const bool lp_valid = lp_.status == CliqueLpStatus::kOptimal || lp_.status == CliqueLpStatus::kTrivial;
  if (lp_valid) upper = std::max(best_, std::min(upper, lp_.upper_bound));
  out->lp_status = lp_.status;
  out->lp_solves = lp_solves_;
  if (lp_valid) out->lp_bound = lp_.upper_bound;
  out->nodes = nodes_;
  out->clique.clear();
  for (const int v : best_clique_) out->clique.push_back(orig_[Idx(v)]);
  std::sort(out->clique.begin(), out->clique.end());
  double objective = 0.0;
  const std::vector<int>& k = out->clique;
  if (cardinality_) {
    objective = static_cast<double>(k.size());
  } else if (!edge_) {
    for (const int v : k) objective += g_.vertex_weight(v);
  } else {
    for (std::size_t a = 0; a < k.size(); ++a) {
      for (std::size_t b = a + 1; b < k.size(); ++b) objective += g_.edge_weight(k[a], k[b]);
    }
  }
  out->objective = objective;
  // The LP bound carries a rounding margin of about 1e-11 relative (clique_lp_bound.hpp): a bound that reaches the
  // incumbent within 1e-9 relative proves it.
  if (lp_valid && upper > best_ && upper <= best_ + 1e-9 * std::max(1.0, std::fabs(best_))) upper = best_;
  if (upper <= best_) {
    out->status = CliqueSearchStatus::kOptimal;
    out->upper_bound = objective;
  } else {
    out->status = CliqueSearchStatus::kLimitReached;
    out->upper_bound = std::max(upper, objective);
  }
}

std::string VertexName(int v) { return "vertex " + std::to_string(v); }

}  // namespace

Result<CliqueGraph> CliqueGraph::Create(int num_vertices, bool with_edge_weights) {
  if (num_vertices < 0 || num_vertices > kMaxCliqueVertices) {
    return InvalidArgument("clique graph: vertex count " + std::to_string(num_vertices) + " is outside 0.." +
                           std::to_string(kMaxCliqueVertices));
  }
  if (with_edge_weights && num_vertices > kMaxEdgeWeightedCliqueVertices) {
    return InvalidArgument("clique graph: " + std::to_string(num_vertices) +
                           " vertices with edge weights exceed the limit of " +
                           std::to_string(kMaxEdgeWeightedCliqueVertices) + " (dense weight matrix)");
  }
  CliqueGraph g;
  g.n_ = num_vertices;
  g.words_ = WordsFor(num_vertices);
  g.edge_weighted_ = with_edge_weights;
  const std::size_t n = Idx(num_vertices);
  try {
    g.adjacency_.assign(n * g.words_, 0U);
    g.vertex_weight_.assign(n, 1.0);
    if (with_edge_weights) g.edge_weight_.assign(n * n, 0.0f);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted("clique graph: cannot allocate " + std::to_string(num_vertices) + " vertices (" +
                             std::to_string(n * g.words_ * 8 + (with_edge_weights ? n * n * 4 : 0)) + " bytes)");
  }
  return g;
}

Status CliqueGraph::AddEdge(int u, int v, double weight) {
  if (u < 0 || u >= n_ || v < 0 || v >= n_) {
    return InvalidArgument("clique graph: edge (" + std::to_string(u) + ", " + std::to_string(v) +
                           ") has a vertex outside 0.." + std::to_string(n_ - 1));
  }
  if (u == v) return InvalidArgument("clique graph: self-loop at " + VertexName(u));
  if (edge_weighted_ && (!std::isfinite(weight) || weight < 0.0 ||
                         weight > static_cast<double>(std::numeric_limits<float>::max()))) {
    return InvalidArgument("clique graph: edge (" + std::to_string(u) + ", " + std::to_string(v) + ") weight " +
                           std::to_string(weight) + " is not a finite non-negative float");
  }
  if (!HasEdge(u, v)) ++num_edges_;
  adjacency_[Idx(u) * words_ + Idx(v >> 6)] |= Word{1} << (v & 63);
  adjacency_[Idx(v) * words_ + Idx(u >> 6)] |= Word{1} << (u & 63);
  if (edge_weighted_) {
    const float w = static_cast<float>(weight);
    edge_weight_[Idx(u) * Idx(n_) + Idx(v)] = w;
    edge_weight_[Idx(v) * Idx(n_) + Idx(u)] = w;
  }
  return Status::Ok();
}

Status CliqueGraph::SetVertexWeight(int v, double weight) {
  if (v < 0 || v >= n_) {
    return InvalidArgument("clique graph: " + VertexName(v) + " is outside 0.." + std::to_string(n_ - 1));
  }
  if (!std::isfinite(weight) || weight < 0.0) {
    return InvalidArgument("clique graph: " + VertexName(v) + " weight " + std::to_string(weight) +
                           " is not finite and non-negative");
  }
  vertex_weight_[Idx(v)] = weight;
  return Status::Ok();
}

bool CliqueGraph::HasEdge(int u, int v) const noexcept {
  if (u < 0 || u >= n_ || v < 0 || v >= n_) return false;
  return TestBit(adjacency_.data() + Idx(u) * words_, v);
}

double CliqueGraph::edge_weight(int u, int v) const noexcept {
  if (!HasEdge(u, v)) return 0.0;
  if (!edge_weighted_) return 1.0;
  return static_cast<double>(edge_weight_[Idx(u) * Idx(n_) + Idx(v)]);
}

std::size_t CliqueGraph::MemoryBytes() const noexcept {
  return adjacency_.capacity() * sizeof(std::uint64_t) + vertex_weight_.capacity() * sizeof(double) +
         edge_weight_.capacity() * sizeof(float);
}

const char* CliqueSearchStatusName(CliqueSearchStatus status) noexcept {
  switch (status) {
    case CliqueSearchStatus::kOptimal:
      return "optimal";
    case CliqueSearchStatus::kLimitReached:
      return "limit reached";
    case CliqueSearchStatus::kEmptyGraph:
      return "empty graph";
  }
  return "unknown";
}

double CliqueSearchResult::gap() const noexcept {
  if (status == CliqueSearchStatus::kOptimal) return 0.0;
  return std::max(0.0, upper_bound - objective) / std::max(upper_bound, 1e-12);
}

Result<CliqueSearchResult> SolveMaxClique(const CliqueGraph& graph, const CliqueSearchParams& params) {
  const auto start = std::chrono::steady_clock::now();
  if (!(params.time_limit_s > 0.0) || std::isnan(params.time_limit_s)) {
    return InvalidArgument("max clique: time_limit_s must be > 0 (got " + std::to_string(params.time_limit_s) + ")");
  }
  if (params.max_nodes < 1) {
    return InvalidArgument("max clique: max_nodes must be >= 1 (got " + std::to_string(params.max_nodes) + ")");
  }
  if (params.lp_after_nodes < 0) {
    return InvalidArgument("max clique: lp_after_nodes must be >= 0 (got " + std::to_string(params.lp_after_nodes) +
                           ")");
  }
  if (params.lp_max_nonzeros < 0) {
    return InvalidArgument("max clique: lp_max_nonzeros must be >= 0 (got " + std::to_string(params.lp_max_nonzeros) +
                           ")");
  }
  if (params.objective != CliqueObjective::kCardinality && params.objective != CliqueObjective::kVertexWeight &&
      params.objective != CliqueObjective::kEdgeWeight) {
    return InvalidArgument("max clique: unknown objective " + std::to_string(static_cast<int>(params.objective)));
  }
  if (params.objective == CliqueObjective::kEdgeWeight && !graph.has_edge_weights()) {
    return InvalidArgument("max clique: the edge-weight objective needs a graph created with edge weights");
  }
  CliqueSearchResult result;
  if (graph.num_vertices() == 0) {
    result.status = CliqueSearchStatus::kEmptyGraph;
    return result;
  }
  // Durations beyond ~30 years are "no limit" (and keep the nanosecond count far from overflow).
  const double limit_s = std::min(params.time_limit_s, 1e9);
  const auto deadline =
      start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(limit_s));
  try {
    CliqueSearch search(graph, params, deadline);
    search.Run(&result);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted("max clique: out of memory for the search buffers of " +
                             std::to_string(graph.num_vertices()) + " vertices");
  }
  return result;
}

}  // namespace commerge
