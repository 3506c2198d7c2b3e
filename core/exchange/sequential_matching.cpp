// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/sequential_matching.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "core/common/number_text.hpp"

namespace commerge {
namespace {

constexpr std::int32_t kNoLabel = -1;

// A contiguous block of the affinity matrix, in global indices, handed to the labeller.
struct Block {
  std::size_t row_begin = 0, col_begin = 0, rows = 0, cols = 0, stride = 0;
  const float* distances = nullptr;
  float min_distance = std::numeric_limits<float>::quiet_NaN();  // a lower bound of the block; NaN = unknown
  bool min_is_exact = false;  // min_distance is the block's minimum (else only a bound: the enclosing tile's)
};

// Union-find node; the statistics are meaningful on roots only.
struct Node {
  std::int32_t parent = 0;
  SequentialCluster cluster;
  std::size_t seed_row = 0, seed_col = 0;  // one cell of the cluster (identifies it in the second pass)
};

// Keeps the two largest span areas seen (ties count twice).
void NoteSpanArea(std::uint64_t area, std::uint64_t* largest, std::uint64_t* second) {
  if (area > *largest) {
    *second = *largest;
    *largest = area;
  } else if (area > *second) {
    *second = area;
  }
}

struct RecordedCell {
  std::size_t row = 0, col = 0;
  std::int32_t label = kNoLabel;
  float distance = 0.0f;
};

struct LabelledCell {
  std::size_t root = 0;  // the cluster's union-find root
  SequentialLoopCell cell;
};

// Groups labelled cells into a SequentialClusterSet: clusters in the order of their first cell (row-major),
// each cluster's cells row-major; stats(root) gives a cluster's SequentialCluster.
template <typename Stats>
SequentialClusterSet GroupClusterCells(std::vector<LabelledCell> labelled, const Stats& stats) {
  std::sort(labelled.begin(), labelled.end(), [](const LabelledCell& a, const LabelledCell& b) {
    return a.cell.alpha_index != b.cell.alpha_index ? a.cell.alpha_index < b.cell.alpha_index
                                                    : a.cell.beta_index < b.cell.beta_index;
  });
  SequentialClusterSet set;
  std::vector<std::size_t> roots;  // slot -> root
  std::vector<std::size_t> slot_of(labelled.size(), 0);
  std::vector<std::size_t> count;
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::size_t max_root = 0;
  for (const LabelledCell& c : labelled) max_root = std::max(max_root, c.root);
  std::vector<std::size_t> slot_of_root(labelled.empty() ? 0 : max_root + 1, kNone);  // roots are node indices
  for (std::size_t q = 0; q < labelled.size(); ++q) {
    std::size_t& slot = slot_of_root[labelled[q].root];
    if (slot == kNone) {
      slot = roots.size();
      roots.push_back(labelled[q].root);
      count.push_back(0);
    }
    slot_of[q] = slot;
    ++count[slot];
  }
  set.clusters.reserve(roots.size());
  for (const std::size_t root : roots) set.clusters.push_back(stats(root));
  set.begin.assign(roots.size() + 1, 0);
  for (std::size_t k = 0; k < count.size(); ++k) set.begin[k + 1] = set.begin[k] + count[k];
  std::vector<std::size_t> next(set.begin.begin(), set.begin.end() - 1);
  set.cells.resize(labelled.size());
  for (std::size_t q = 0; q < labelled.size(); ++q) set.cells[next[slot_of[q]]++] = labelled[q].cell;
  return set;
}

// Lower mean wins; ties by span corners so the choice does not depend on the labelling order.
bool Better(const SequentialCluster& a, const SequentialCluster& b) {
  const double ma = a.mean_distance(), mb = b.mean_distance();
  if (ma != mb) return ma < mb;
  if (a.row_min != b.row_min) return a.row_min < b.row_min;
  if (a.col_min != b.col_min) return a.col_min < b.col_min;
  if (a.row_max != b.row_max) return a.row_max < b.row_max;
  return a.col_max < b.col_max;
}

// Streaming 8-connected labelling of B = [A <= tau] over a region [r0, r1) x [c0, c1) fed as blocks in
// row-major block order (bands of equal height, each band left to right). Keeps the label row above the
// current band (width), the band's last row, the previous block's last column and one block of labels.
// With `compact`, clusters that do not reach a band's last row are finalised (scored and dropped) at the
// end of each band, so the union-find holds only the open clusters.
class StreamingLabeler {
 public:
  void Begin(std::size_t r0, std::size_t r1, std::size_t c0, std::size_t c1, float tau, std::uint64_t tau_area,
             bool compact, bool record_cells) {
    r0_ = r0;
    r1_ = r1;
    c0_ = c0;
    c1_ = c1;
    tau_ = tau;
    tau_area_ = tau_area;
    compact_ = compact;
    record_ = record_cells;
    prev_row_.assign(c1 - c0, kNoLabel);
    next_row_.assign(c1 - c0, kNoLabel);
    nodes_.clear();
    cells_.clear();
    band_begin_ = r0;
    band_rows_ = 0;
    next_col_ = c1;  // "previous band complete"
    num_clusters_ = 0;
    num_below_ = 0;
    largest_area_ = 0;
    has_best_ = false;
    min_distance_ = std::numeric_limits<double>::infinity();
  }

  Status Consume(const Block& b) {
    if (Status s = CheckOrder(b); !s.ok()) return s;
    const std::size_t x0 = b.col_begin - c0_;
    if (!std::isnan(b.min_distance) && !(b.min_distance <= tau_)) {
      // No cell of the block below tau (the common case far from a revisit): only the minimum and the
      // border labels (all empty) change.
      if (b.min_is_exact && std::isfinite(b.min_distance) && static_cast<double>(b.min_distance) < min_distance_) {
        min_distance_ = static_cast<double>(b.min_distance);
      }
      std::fill(left_col_.begin(), left_col_.begin() + static_cast<std::ptrdiff_t>(b.rows), kNoLabel);
      std::fill(next_row_.begin() + static_cast<std::ptrdiff_t>(x0),
                next_row_.begin() + static_cast<std::ptrdiff_t>(x0 + b.cols), kNoLabel);
      next_col_ = b.col_begin + b.cols;
      if (next_col_ == c1_) EndBand();
      return Status::Ok();
    }
    labels_.assign(b.rows * b.cols, kNoLabel);
    for (std::size_t r = 0; r < b.rows; ++r) {
      const float* row = b.distances + r * b.stride;
      for (std::size_t c = 0; c < b.cols; ++c) LabelCell(b, labels_.data(), r, c, row[c]);
    }
    EndBlock(b, labels_.data());
    return Status::Ok();
  }

  // Consume for a block given by its finite cells only (every other cell +inf), row-major within the block:
  // the same state changes as Consume on the dense block, in the same order.
  Status ConsumeSparse(const Block& b, Span<const NeighbourRankTileSource::KeptCell> cells) {
    if (Status s = CheckOrder(b); !s.ok()) return s;
    if (sparse_labels_.size() < b.rows * b.cols) sparse_labels_.resize(b.rows * b.cols, kNoLabel);
    touched_.clear();
    for (const NeighbourRankTileSource::KeptCell& cell : cells) {
      const std::size_t r = cell.row - b.row_begin, c = cell.col - b.col_begin;
      if (LabelCell(b, sparse_labels_.data(), r, c, cell.value)) touched_.push_back(r * b.cols + c);
    }
    EndBlock(b, sparse_labels_.data());
    for (const std::size_t q : touched_) sparse_labels_[q] = kNoLabel;  // clean for the next block
    return Status::Ok();
  }

  // Call after the last block. Finalises the remaining clusters (compact mode).
  Status Finish() {
    if (next_col_ != c1_ || band_begin_ + band_rows_ != r1_) {
      return Status(StatusCode::kInternal, "sequential matching: the tile stream ended before covering the matrix");
    }
    if (compact_) {
      for (std::size_t l = 0; l < nodes_.size(); ++l) {
        if (nodes_[l].parent == static_cast<std::int32_t>(l)) Finalize(nodes_[l]);
      }
      nodes_.clear();
    }
    return Status::Ok();
  }

  // Every cluster with its cells (non-compact, recording mode).
  SequentialClusterSet AllClusters() {
    std::vector<LabelledCell> labelled;
    labelled.reserve(cells_.size());
    for (const RecordedCell& c : cells_) {
      labelled.push_back({static_cast<std::size_t>(Find(c.label)), {c.row, c.col, c.distance}});
    }
    return GroupClusterCells(std::move(labelled), [&](std::size_t root) { return nodes_[root].cluster; });
  }

  // Second pass: the cells whose cluster contains the seed cell, sorted row-major.
  std::vector<SequentialLoopCell> CellsOfClusterAt(std::size_t seed_row, std::size_t seed_col) {
    std::int32_t seed_label = kNoLabel;
    for (const RecordedCell& c : cells_) {
      if (c.row == seed_row && c.col == seed_col) seed_label = c.label;
    }
    std::vector<SequentialLoopCell> out;
    if (seed_label == kNoLabel) return out;
    const std::int32_t root = Find(seed_label);
    for (const RecordedCell& c : cells_) {
      if (Find(c.label) == root) out.push_back({c.row, c.col, c.distance});
    }
    std::sort(out.begin(), out.end(), [](const SequentialLoopCell& a, const SequentialLoopCell& b) {
      return a.alpha_index != b.alpha_index ? a.alpha_index < b.alpha_index : a.beta_index < b.beta_index;
    });
    return out;
  }

  std::size_t num_clusters() const noexcept { return num_clusters_; }
  std::uint64_t num_below() const noexcept { return num_below_; }
  std::uint64_t largest_area() const noexcept { return largest_area_; }
  std::uint64_t second_area() const noexcept { return second_area_; }
  double min_distance() const noexcept { return min_distance_; }
  bool has_best() const noexcept { return has_best_; }
  const Node& best() const noexcept { return best_; }

 private:
  Status OrderError(const Block& b) const {
    return Status(StatusCode::kInternal, "sequential matching: tile " + std::to_string(b.rows) + " x " +
                                             std::to_string(b.cols) + " at (" + std::to_string(b.row_begin) + ", " +
                                             std::to_string(b.col_begin) + ") out of row-major tile order");
  }

  // Order check: a new band starts at the region's first column right below the previous band.
  Status CheckOrder(const Block& b) {
    if (b.col_begin == c0_) {
      if (next_col_ != c1_ || b.row_begin != band_begin_ + band_rows_) return OrderError(b);
      band_begin_ = b.row_begin;
      band_rows_ = b.rows;
      left_col_.assign(b.rows, kNoLabel);
    } else if (b.row_begin != band_begin_ || b.rows != band_rows_ || b.col_begin != next_col_) {
      return OrderError(b);
    }
    if (b.rows == 0 || b.cols == 0 || b.row_begin + b.rows > r1_ || b.col_begin + b.cols > c1_) return OrderError(b);
    return Status::Ok();
  }

  // Cell (r, c) of block b with value d: the running minimum, and when d <= tau its label (joined with the
  // labelled neighbours above and to the left) in labels (b.rows x b.cols, this block's labels so far). True when
  // the cell was labelled.
  bool LabelCell(const Block& b, std::int32_t* labels, std::size_t r, std::size_t c, float d) {
    if (std::isfinite(d) && static_cast<double>(d) < min_distance_) min_distance_ = static_cast<double>(d);
    if (!(d <= tau_)) return false;
    ++num_below_;
    const std::size_t width = c1_ - c0_, x0 = b.col_begin - c0_;
    const bool has_left = b.col_begin > c0_;
    std::int32_t label = kNoLabel;
    auto join = [&](std::int32_t other) {
      if (other == kNoLabel) return;
      if (label == kNoLabel) {
        label = other;
      } else {
        Union(label, other);
      }
    };
    const std::size_t x = x0 + c;
    if (r > 0) {
      const std::int32_t* up = labels + (r - 1) * b.cols;
      if (c > 0) join(up[c - 1]);
      join(up[c]);
      if (c + 1 < b.cols) join(up[c + 1]);
    } else {
      if (x > 0) join(prev_row_[x - 1]);
      join(prev_row_[x]);
      if (x + 1 < width) join(prev_row_[x + 1]);
    }
    if (c > 0) {
      join(labels[r * b.cols + c - 1]);
    } else if (has_left) {  // previous block's last column: up-left (r > 0), left, down-left
      if (r > 0) join(left_col_[r - 1]);
      join(left_col_[r]);
      if (r + 1 < b.rows) join(left_col_[r + 1]);
    }
    const std::size_t i = b.row_begin + r, j = b.col_begin + c;
    if (label == kNoLabel) label = NewNode(i, j);
    labels[r * b.cols + c] = label;
    SequentialCluster& s = nodes_[static_cast<std::size_t>(Find(label))].cluster;
    s.row_min = std::min(s.row_min, i);
    s.row_max = std::max(s.row_max, i);
    s.col_min = std::min(s.col_min, j);
    s.col_max = std::max(s.col_max, j);
    ++s.cell_count;
    s.distance_sum += static_cast<double>(d);
    if (record_) cells_.push_back({i, j, label, d});
    return true;
  }

  // After a block's cells: its last column and last row become the left and upper borders of what follows.
  void EndBlock(const Block& b, const std::int32_t* labels) {
    const std::size_t x0 = b.col_begin - c0_;
    for (std::size_t r = 0; r < b.rows; ++r) left_col_[r] = labels[r * b.cols + b.cols - 1];
    std::copy(labels + (b.rows - 1) * b.cols, labels + b.rows * b.cols,
              next_row_.begin() + static_cast<std::ptrdiff_t>(x0));
    next_col_ = b.col_begin + b.cols;
    if (next_col_ == c1_) EndBand();
  }

  std::int32_t NewNode(std::size_t i, std::size_t j) {
    Node n;
    n.parent = static_cast<std::int32_t>(nodes_.size());
    n.cluster.row_min = n.cluster.row_max = i;
    n.cluster.col_min = n.cluster.col_max = j;
    n.seed_row = i;
    n.seed_col = j;
    nodes_.push_back(n);
    return n.parent;
  }

  std::int32_t Find(std::int32_t x) {
    while (nodes_[static_cast<std::size_t>(x)].parent != x) {
      Node& n = nodes_[static_cast<std::size_t>(x)];
      n.parent = nodes_[static_cast<std::size_t>(n.parent)].parent;  // path halving
      x = n.parent;
    }
    return x;
  }

  void Union(std::int32_t a, std::int32_t b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return;
    if (b < a) std::swap(a, b);  // the older node stays the root
    Node& ra = nodes_[static_cast<std::size_t>(a)];
    const Node& rb = nodes_[static_cast<std::size_t>(b)];
    ra.cluster.row_min = std::min(ra.cluster.row_min, rb.cluster.row_min);
    ra.cluster.row_max = std::max(ra.cluster.row_max, rb.cluster.row_max);
    ra.cluster.col_min = std::min(ra.cluster.col_min, rb.cluster.col_min);
    ra.cluster.col_max = std::max(ra.cluster.col_max, rb.cluster.col_max);
    ra.cluster.cell_count += rb.cluster.cell_count;
    ra.cluster.distance_sum += rb.cluster.distance_sum;
    nodes_[static_cast<std::size_t>(b)].parent = a;
  }

  // Scores a finished cluster (a root node): counts it and keeps it when it is the best qualifying one.
  void Finalize(const Node& node) {
    ++num_clusters_;
    const std::uint64_t area = node.cluster.span_area();
    NoteSpanArea(area, &largest_area_, &second_area_);
    if (area >= tau_area_ && (!has_best_ || Better(node.cluster, best_.cluster))) {
      has_best_ = true;
      best_ = node;
    }
  }

  void EndBand() {
    std::swap(prev_row_, next_row_);
    std::fill(next_row_.begin(), next_row_.end(), kNoLabel);
    if (!compact_) return;
    // Keep the clusters that reach the band's last row; score and drop the others.
    remap_.assign(nodes_.size(), kNoLabel);
    compacted_.clear();
    for (std::int32_t& label : prev_row_) {
      if (label == kNoLabel) continue;
      const auto root = static_cast<std::size_t>(Find(label));
      if (remap_[root] == kNoLabel) {
        remap_[root] = static_cast<std::int32_t>(compacted_.size());
        compacted_.push_back(nodes_[root]);
        compacted_.back().parent = remap_[root];
      }
      label = remap_[root];
    }
    for (std::size_t l = 0; l < nodes_.size(); ++l) {
      if (nodes_[l].parent == static_cast<std::int32_t>(l) && remap_[l] == kNoLabel) {
        Finalize(nodes_[l]);
      }
    }
    nodes_.swap(compacted_);
  }

  std::size_t r0_ = 0, r1_ = 0, c0_ = 0, c1_ = 0;
  float tau_ = 0.0f;
  std::uint64_t tau_area_ = 0;
  bool compact_ = true, record_ = false;
  std::vector<std::int32_t> prev_row_, next_row_, left_col_, labels_, remap_;
  std::vector<std::int32_t> sparse_labels_;  // ConsumeSparse's block labels, all kNoLabel between blocks
  std::vector<std::size_t> touched_;         // the entries of sparse_labels_ set in the current block
  std::vector<Node> nodes_, compacted_;
  std::vector<RecordedCell> cells_;
  std::size_t band_begin_ = 0, band_rows_ = 0, next_col_ = 0;
  std::size_t num_clusters_ = 0;
  std::uint64_t num_below_ = 0, largest_area_ = 0, second_area_ = 0;
  bool has_best_ = false;
  Node best_;
  double min_distance_ = 0.0;
};

std::string EmptySetReason(std::size_t n, std::size_t m) {
  return std::string("no keyframes: robot ") + (n == 0 ? "alpha" : "beta") +
         " has an empty descriptor set (N = " + std::to_string(n) + ", M = " + std::to_string(m) + ")";
}

// Fills the no-candidate reason of a result whose statistics are set; true when a cluster qualified.
bool ExplainCandidate(const SequentialMatchParams& p, bool has_best, SequentialMatchResult* result) {
  if (result->num_cells_below_threshold == 0) {
    result->no_candidate_reason =
        "no cell below tau_inter = " + FormatNumber(p.tau_inter, 4) +
        (std::isfinite(result->min_distance) ? " (smallest distance " + FormatNumber(result->min_distance, 4) + ")"
                                             : std::string(" (no valid descriptor pair)"));
    return false;
  }
  if (!has_best) {
    result->no_candidate_reason = "no cluster with span area >= tau_area = " + std::to_string(p.tau_area) +
                                  ": largest was " + std::to_string(result->largest_span_area) + " (next " +
                                  std::to_string(result->second_span_area) + ", " +
                                  std::to_string(result->num_clusters) + " clusters)";
    return false;
  }
  return true;
}

}  // namespace

Status ValidateSequentialMatchParams(const SequentialMatchParams& p) {
  if (!std::isfinite(p.tau_inter) || p.tau_inter < 0.0) {
    return InvalidArgument("sequential matching: tau_inter must be finite and >= 0, got " +
                           FormatNumber(p.tau_inter, 4));
  }
  if (p.tile_rows == 0 || p.tile_cols == 0) return InvalidArgument("sequential matching: tile size must be >= 1 x 1");
  if (p.sequence_half_window > kMaxSequenceHalfWindow) {
    return InvalidArgument("sequential matching: sequence_half_window must be <= " +
                           std::to_string(kMaxSequenceHalfWindow) + ", got " + std::to_string(p.sequence_half_window));
  }
  if (!std::isfinite(p.tau_area_fraction) || p.tau_area_fraction < 0.0) {
    return InvalidArgument("sequential matching: tau_area_fraction must be finite and >= 0, got " +
                           FormatNumber(p.tau_area_fraction, 4));
  }
  if (p.neighbour_rank > kMaxNeighbourRank) {
    return InvalidArgument("sequential matching: neighbour_rank must be <= " + std::to_string(kMaxNeighbourRank) +
                           ", got " + std::to_string(p.neighbour_rank));
  }
  return Status::Ok();
}

namespace {

// The blocks of the tile_rows x tile_cols grid meeting rows [row_lo, row_hi) x cols [col_lo, col_hi), clipped to
// that region, in row-major tile order, each with its kept cells of `ranked` (sparse()): calls
// f(const Block&, Span<const KeptCell>) -> Status. The blocks are those the tile passes below consume.
template <class F>
Status ForEachSparseBlock(const NeighbourRankTileSource& ranked, std::size_t tile_rows, std::size_t tile_cols,
                          std::size_t row_lo, std::size_t row_hi, std::size_t col_lo, std::size_t col_hi, F&& f) {
  using KeptCell = NeighbourRankTileSource::KeptCell;
  const std::size_t n = ranked.num_rows(), m = ranked.num_cols();
  std::vector<Span<const KeptCell>> rest;  // per row of the band: its kept cells not yet handed out
  std::vector<KeptCell> cells;
  for (std::size_t r0 = row_lo / tile_rows * tile_rows; r0 < row_hi;) {
    const std::size_t rows = std::min(tile_rows, n - r0);
    const std::size_t br0 = std::max(r0, row_lo), br1 = std::min(r0 + rows, row_hi);
    rest.clear();
    for (std::size_t i = br0; i < br1; ++i) rest.push_back(ranked.RowCells(i, col_lo, col_hi));
    for (std::size_t c0 = col_lo / tile_cols * tile_cols; c0 < col_hi;) {
      const std::size_t cols = std::min(tile_cols, m - c0);
      const std::size_t bc0 = std::max(c0, col_lo), bc1 = std::min(c0 + cols, col_hi);
      cells.clear();
      for (Span<const KeptCell>& row : rest) {
        std::size_t q = 0;
        while (q < row.size() && row[q].col < bc1) cells.push_back(row[q++]);
        row = row.subspan(q, row.size() - q);
      }
      const Block b{br0, bc0, br1 - br0, bc1 - bc0, 0, nullptr, std::numeric_limits<float>::quiet_NaN(), false};
      if (Status s = f(b, Span<const KeptCell>(cells)); !s.ok()) return s;
      c0 += cols;
    }
    r0 += rows;
  }
  return Status::Ok();
}

// Stage A proper: thresholds whatever the source serves (A, or V of a SequenceSmoothedTileSource). With `ranked`
// (the source itself, sparse()), the passes read its kept cells instead of its tiles: the same blocks, the same
// labelling.
Result<SequentialMatchResult> RunStageA(AffinityTileSource& source, const SequentialMatchParams& p,
                                        const NeighbourRankTileSource* ranked) {
  Status s;
  SequentialMatchResult result;
  result.min_distance = std::numeric_limits<double>::infinity();
  const std::size_t n = source.num_rows(), m = source.num_cols();
  if (n == 0 || m == 0) {
    result.no_candidate_reason = EmptySetReason(n, m);
    return result;
  }
  const auto tau = static_cast<float>(p.tau_inter);
  StreamingLabeler labeler;
  labeler.Begin(0, n, 0, m, tau, p.tau_area, /*compact=*/true, /*record_cells=*/false);
  const auto whole_matrix = [&](StreamingLabeler* l) {
    if (ranked != nullptr) {
      return ForEachSparseBlock(*ranked, p.tile_rows, p.tile_cols, 0, n, 0, m,
                                [&](const Block& b, Span<const NeighbourRankTileSource::KeptCell> cells) {
                                  return l->ConsumeSparse(b, cells);
                                });
    }
    return ForEachAffinityTile(source, p.tile_rows, p.tile_cols, [&](const AffinityTile& t) {
      return l->Consume(Block{t.row_begin, t.col_begin, t.rows, t.cols, t.stride, t.distances, t.min_distance,
                              /*min_is_exact=*/true});
    });
  };
  s = whole_matrix(&labeler);
  if (!s.ok()) return s;
  s = labeler.Finish();
  if (!s.ok()) return s;
  result.num_clusters = labeler.num_clusters();
  result.num_cells_below_threshold = labeler.num_below();
  result.largest_span_area = labeler.largest_area();
  result.second_span_area = labeler.second_area();
  result.min_distance = labeler.min_distance();
  if (p.all_clusters_max_cells > 0) {
    if (result.num_cells_below_threshold > p.all_clusters_max_cells) {
      result.clusters_skipped = true;
    } else if (result.num_cells_below_threshold > 0) {
      StreamingLabeler all;
      all.Begin(0, n, 0, m, tau, p.tau_area, /*compact=*/false, /*record_cells=*/true);
      s = whole_matrix(&all);
      if (!s.ok()) return s;
      s = all.Finish();
      if (!s.ok()) return s;
      result.clusters = all.AllClusters();
      if (result.clusters.clusters.size() != result.num_clusters) {
        return Status(StatusCode::kInternal, "sequential matching: the cluster pass found " +
                                                 std::to_string(result.clusters.clusters.size()) +
                                                 " clusters, the first pass " + std::to_string(result.num_clusters) +
                                                 " (non-deterministic tile source?)");
      }
    }
  }
  if (!ExplainCandidate(p, labeler.has_best(), &result)) return result;
  const Node best = labeler.best();
  result.best = best.cluster;

  // Second pass: the same tile grid (bit-identical distances), only the tiles meeting the span, clipped to it.
  const SequentialCluster& b = result.best;
  StreamingLabeler span_labeler;
  span_labeler.Begin(b.row_min, b.row_max + 1, b.col_min, b.col_max + 1, tau, p.tau_area, /*compact=*/false,
                     /*record_cells=*/true);
  if (ranked != nullptr) {
    s = ForEachSparseBlock(*ranked, p.tile_rows, p.tile_cols, b.row_min, b.row_max + 1, b.col_min, b.col_max + 1,
                           [&](const Block& block, Span<const NeighbourRankTileSource::KeptCell> cells) {
                             return span_labeler.ConsumeSparse(block, cells);
                           });
    if (!s.ok()) return s;
  }
  AffinityTile tile;
  for (std::size_t r0 = b.row_min / p.tile_rows * p.tile_rows; ranked == nullptr && r0 <= b.row_max;) {
    const std::size_t rows = std::min(p.tile_rows, n - r0);
    for (std::size_t c0 = b.col_min / p.tile_cols * p.tile_cols; c0 <= b.col_max;) {
      const std::size_t cols = std::min(p.tile_cols, m - c0);
      s = source.ComputeTile(r0, c0, rows, cols, &tile);
      if (!s.ok()) return s;
      const std::size_t br0 = std::max(r0, b.row_min), br1 = std::min(r0 + rows, b.row_max + 1);
      const std::size_t bc0 = std::max(c0, b.col_min), bc1 = std::min(c0 + cols, b.col_max + 1);
      s = span_labeler.Consume(Block{br0, bc0, br1 - br0, bc1 - bc0, tile.stride,
                                     tile.distances + (br0 - r0) * tile.stride + (bc0 - c0), tile.min_distance,
                                     /*min_is_exact=*/false});
      if (!s.ok()) return s;
      c0 += cols;
    }
    r0 += rows;
  }
  s = span_labeler.Finish();
  if (!s.ok()) return s;
  result.cells = span_labeler.CellsOfClusterAt(best.seed_row, best.seed_col);
  if (result.cells.size() != b.cell_count) {
    return Status(StatusCode::kInternal, "sequential matching: second pass found " +
                                             std::to_string(result.cells.size()) + " cells, first pass " +
                                             std::to_string(b.cell_count) + " (non-deterministic tile source?)");
  }
  result.found = true;
  return result;
}

}  // namespace

std::uint64_t EffectiveTauArea(const SequentialMatchParams& p, std::size_t n, std::size_t m) noexcept {
  if (!(p.tau_area_fraction > 0.0)) return p.tau_area;
  const double side = p.tau_area_fraction * static_cast<double>(std::min(n, m));
  const double scaled = std::ceil(side * side);
  const std::uint64_t area = scaled >= static_cast<double>(p.tau_area) ? p.tau_area : static_cast<std::uint64_t>(scaled);
  return std::min(p.tau_area, std::max(p.min_tau_area, area));
}

Result<SequentialMatchResult> RunSequentialMatching(AffinityTileSource& source, const SequentialMatchParams& params) {
  Status s = ValidateSequentialMatchParams(params);
  if (!s.ok()) return s;
  SequentialMatchParams p = params;
  p.tau_area = EffectiveTauArea(params, source.num_rows(), source.num_cols());
  AffinityTileSource* served = &source;
  std::optional<SequenceSmoothedTileSource> smoothed;
  if (p.sequence_half_window > 0) {
    Result<SequenceSmoothedTileSource> made =
        SequenceSmoothedTileSource::Create(&source, p.sequence_half_window, p.tile_rows, p.tile_cols);
    if (!made.ok()) return made.status();
    smoothed.emplace(std::move(*made));
    served = &*smoothed;
  }
  if (p.neighbour_rank == 0) return RunStageA(*served, p, nullptr);
  Result<NeighbourRankTileSource> ranked =
      NeighbourRankTileSource::Create(served, p.neighbour_rank, p.tile_rows, p.tile_cols);
  if (!ranked.ok()) return ranked.status();
  if (Status prep = ranked->Prepare(); !prep.ok()) return prep;
  return RunStageA(*ranked, p, ranked->sparse() ? &*ranked : nullptr);
}

std::size_t SequentialMatchTileHalo(const SequentialMatchParams& params) noexcept {
  return params.sequence_half_window == 0 ? 0 : 2 * params.sequence_half_window + 2;
}

Result<SequentialMatchResult> RunSequentialMatching(const DescriptorSetView& alpha, const DescriptorSetView& beta,
                                                    const SequentialMatchParams& params) {
  Status s = ValidateSequentialMatchParams(params);
  if (!s.ok()) return s;
  const std::size_t halo = SequentialMatchTileHalo(params);
  Result<AffinityTileKernel> kernel =
      AffinityTileKernel::Create(alpha, beta, params.tile_rows + halo, params.tile_cols + halo);
  if (!kernel.ok()) return kernel.status();
  return RunSequentialMatching(*kernel, params);
}

}  // namespace commerge
