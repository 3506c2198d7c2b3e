// SPDX-License-Identifier: BSD-3-Clause
// commerge: the inter-robot affinity of stage A with Scan Context (SOLID.md §6) instead of SOLiD: cell (i, j) is
// the Scan Context distance D(alpha_i, beta_j) = min_s d_s (alpha row i = query, beta column j = candidate),
// d_s = 1 - (1/|C_s|) sum_{c in C_s} cos(col_c(alpha_i), col_{c+s}(beta_j)), C_s the columns non-zero in both,
// d_s = 1 when |C_s| = 0 (MatchScanContext's definition), delivered tile by tile like AffinityTileKernel so that
// stage A (RunSequentialMatching) runs on it unchanged. The paper shows descriptor-agnosticism this way.
//
// Why a dedicated source: a Scan Context distance is a minimum over column shifts, not a dot product, so the
// SOLiD GEMM kernel does not apply. Two modes:
//   kExact           every shift s = 0 .. N_s - 1 (~N_s x N_r x N_s = 72 000 multiply-adds per cell at 20 x 60).
//   kSectorKeyShift  (default) Scan Context++ / SC-LIO-SAM style: the sector keys (column means of the raw
//                    cells) are aligned by circular cross-correlation over all shifts (N_s^2 = 3 600
//                    multiply-adds, measured as costly as ~5 shifts), the best `num_candidate_shifts` key
//                    shifts (each peak taken outside the windows of the earlier ones) are kept, and d_s is
//                    evaluated exactly only at those shifts +- `shift_window_sectors`. The value is the
//                    minimum of d_s over a subset of the shifts, so it is never below the exact distance,
//                    and equals it whenever the exact best shift lies in a window (always for copies of one
//                    place turned by whole sectors).
// d_s is computed by one function in both modes, so a sector-key cell equals, bit for bit, the exact cell when
// the exact best shift is among its evaluated shifts.
//
// Precomputed once per keyframe (Create): the column-normalised copy laid out column by column
// ([sector][ring], each column padded with zeros to a multiple of 4 floats, empty column = zeros), the column
// non-empty mask (float 0/1) and the sector key (beta's stored twice, 2 N_s floats, so that every shift is one
// contiguous dot product). Memory: (N + M) x (N_s x ceil4(N_r) + 3 N_s) floats plus one tile of
// max_tile_rows x max_tile_cols floats (20 x 60: ~1 380 floats = 5.5 KB per keyframe); the descriptor sets are
// only read during Create. ComputeTile allocates nothing.
//
// Negative cells (a cell whose points all lie below -lidar_height_m keeps its negative maximum height) are used
// as they are, as MatchScanContext does: such a column is non-empty, its cosine with another column may be
// negative, and the distance of a pair may then exceed 1 (it stays in [0, 2]). Cells of non-negative Scan
// Contexts are in [0, 1].
//
// Accuracy: float sums of column-normalised products; |value - MatchScanContext(alpha_i, beta_j).distance| is
// below ~1e-6 in practice (the tests allow 1e-5). Position independent and deterministic: a cell is computed by the
// same instruction sequence whatever tile contains it, so it is the same float in every tiling.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"

namespace commerge {

enum class ScanContextAffinityMode {
  kExact,           ///< d_s at every column shift: equals MatchScanContext (to float rounding)
  kSectorKeyShift,  ///< d_s only near the best sector-key alignments: >= the exact distance, ~3x cheaper
};

/// "exact" / "sector-key".
const char* ScanContextAffinityModeName(ScanContextAffinityMode mode) noexcept;

struct ScanContextAffinityParams {
  int num_rings = 20;    ///< N_r of the Scan Contexts (ScanContextParams::num_rings), in [1, kScanContextMaxRings]
  int num_sectors = 60;  ///< N_s, in [1, kScanContextMaxSectors], divides 360 (ScanContextParams::num_sectors)
  ScanContextAffinityMode mode = ScanContextAffinityMode::kSectorKeyShift;
  /// kSectorKeyShift: how many sector-key alignment peaks are refined, in [1, kScanContextMaxSectors]. Each peak is
  /// the best key shift outside the windows of the earlier ones; once the windows cover every shift the mode
  /// evaluates what kExact does. 2: nearly always the exact distance, at a fraction of its time
  /// (core/agent/decisions/022-scan-context-candidate-shifts.md).
  int num_candidate_shifts = 2;
  /// kSectorKeyShift: d_s is evaluated at each peak +- this many sectors, in [0, kScanContextMaxSectors / 2].
  /// 3 = SC-LIO-SAM's search radius (0.1 x 60 / 2 sectors, +-18 deg at 6 deg per sector).
  int shift_window_sectors = 3;
};

/// OK, or invalid argument naming the field and value (ranges as documented on the fields).
Status ValidateScanContextAffinityParams(const ScanContextAffinityParams& params);

/// Affinity tiles of Scan Context distances (layout and contract of AffinityTile / AffinityTileSource).
/// Cell (i, j): D(alpha_i, beta_j) as float in [0, 1] for non-negative Scan Contexts ([0, 2] with negative cells),
/// +inf when either keyframe is invalid: flag 0, a value that is not finite, or no non-zero cell.
/// Every tile reports its minimum (AffinityTile::min_distance).
class ScanContextTileSource final : public AffinityTileSource {
 public:
  ScanContextTileSource() = default;

  /// Borrowed sets of row-major Scan Contexts ([ring][sector], ComputeScanContext's layout), dim = num_rings x
  /// num_sectors. Precomputes the per-keyframe arrays (the sets are not read afterwards). Errors (invalid
  /// argument): bad params, an invalid set (ValidateDescriptorSet), dims that differ from each other or from
  /// num_rings x num_sectors, a zero tile capacity. A start-up allocation (may throw std::bad_alloc).
  static Result<ScanContextTileSource> Create(const DescriptorSetView& alpha, const DescriptorSetView& beta,
                                              const ScanContextAffinityParams& params, std::size_t max_tile_rows,
                                              std::size_t max_tile_cols);

  std::size_t num_rows() const noexcept override { return alpha_.count; }
  std::size_t num_cols() const noexcept override { return beta_.count; }
  /// Same contract as AffinityTileKernel::ComputeTile: error for a block that is empty, outside the matrix or
  /// larger than the capacity given to Create. No allocation.
  Status ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows, std::size_t cols,
                     AffinityTile* tile) override;

  /// The value of cell (i, j) (the one ComputeTile writes), for i < num_rows(), j < num_cols().
  float CellDistance(std::size_t i, std::size_t j) noexcept;

  bool alpha_valid(std::size_t i) const noexcept { return alpha_.valid[i] != 0; }
  bool beta_valid(std::size_t j) const noexcept { return beta_.valid[j] != 0; }
  const ScanContextAffinityParams& params() const noexcept { return params_; }

  /// Cells computed by ComputeTile since creation (sum of rows x cols of every successful call).
  std::uint64_t cells_computed() const noexcept { return cells_computed_; }
  /// Column shifts at which d_s was evaluated, over all valid pairs computed so far (CellDistance included):
  /// N_s per valid pair in kExact, fewer in kSectorKeyShift.
  std::uint64_t shifts_evaluated() const noexcept { return shifts_evaluated_; }

 private:
  /// Per-keyframe arrays of one set.
  struct Prepared {
    std::size_t count = 0;
    std::vector<float> columns;      ///< [keyframe][sector][padded ring], column-normalised, empty column = 0
    std::vector<float> masks;        ///< [keyframe][sector]: 1 = non-empty column
    std::vector<float> keys;         ///< [keyframe][key_len]: sector key (column means), stored key_copies times
    std::vector<std::uint8_t> valid; ///< effective validity
  };
  static void Prepare(const DescriptorSetView& set, int num_rings, int num_sectors, std::size_t padded_rings,
                      int key_copies, Prepared* out);
  float ShiftDistance(const float* q_cols, const float* q_mask, const float* c_cols, const float* c_mask,
                      int shift) const noexcept;

  ScanContextAffinityParams params_;
  std::size_t padded_rings_ = 0;  ///< N_r rounded up to a multiple of 4
  std::size_t max_tile_rows_ = 0;
  std::size_t max_tile_cols_ = 0;
  Prepared alpha_;
  Prepared beta_;
  std::vector<float> tile_;
  std::uint64_t cells_computed_ = 0;
  std::uint64_t shifts_evaluated_ = 0;
};

}  // namespace commerge
