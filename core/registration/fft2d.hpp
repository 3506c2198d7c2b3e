// SPDX-License-Identifier: BSD-3-Clause
// commerge: a small radix-2 complex FFT for square power-of-two grids (the bird's-eye-view correlation of
// bev_search). Iterative Cooley-Tukey with precomputed twiddles and bit-reversal; no allocation per call.
#pragma once

#include <complex>
#include <cstddef>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// 2-D discrete Fourier transform of an n x n grid (row-major), n a power of two in [2, 4096].
/// Forward: X[k] = sum_j x[j] exp(-2 pi i j.k / n). Inverse: the same with +i and WITHOUT the 1 / n^2 factor.
/// Layout: Forward returns the spectrum TRANSPOSED (X[k_col][k_row] at row k_col) to save one transposition;
/// Inverse expects that layout and returns the grid in its original layout. Element-wise products of two
/// spectra (the correlation theorem) are layout-independent, so Forward -> multiply -> Inverse is exact.
class Fft2d {
 public:
  /// InvalidArgument unless n is a power of two in [2, 4096].
  Status Init(int n);
  int size() const noexcept { return n_; }
  /// Bytes of the twiddle and bit-reversal tables (capacities).
  std::size_t workspace_bytes() const noexcept {
    return twiddles_f_.capacity() * sizeof(std::complex<float>) + bit_reverse_.capacity() * sizeof(std::size_t);
  }

  /// grid.size() must be n * n (checked: InvalidArgument otherwise).
  Status Forward(Span<std::complex<float>> grid);
  Status Inverse(Span<std::complex<float>> grid);

 private:
  Status Transform(Span<std::complex<float>> grid, bool inverse);
  void Rows(std::complex<float>* grid, bool inverse) const;
  void Transpose(std::complex<float>* grid) const;

  int n_ = 0;
  std::vector<std::complex<float>> twiddles_f_;
  std::vector<std::size_t> bit_reverse_;
};

}  // namespace commerge
