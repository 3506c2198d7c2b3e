// SPDX-License-Identifier: BSD-3-Clause
#include "core/registration/bev_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/geometry/angles.hpp"

namespace commerge {
namespace {

struct Peak {
  double score = 0.0;
  double yaw_rad = 0.0;
  int dx = 0;  // cell shift, in [-n/2, n/2)
  int dy = 0;
};

int Unwrap(int d, int n) { return d >= n / 2 ? d - n : d; }

// Cell index of a coordinate: floor(v / cell) modulo n (n a power of two).
int CellOf(double v, double inv_cell, int n) {
  const double f = std::floor(v * inv_cell);
  // Far points (beyond +-2^30 cells) fold onto the grid too; the cast is guarded by the clamp.
  const double c = std::max(-1073741824.0, std::min(1073741823.0, f));
  return static_cast<int>(static_cast<long long>(c) & static_cast<long long>(n - 1));
}

// Best cell of a correlation plane (real values, n x n); ties -> the lowest index.
Peak BestShift(const std::complex<float>* plane, bool imaginary, int n, double yaw_rad) {
  const std::size_t cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  std::size_t best = 0;
  float best_v = -std::numeric_limits<float>::infinity();
  for (std::size_t k = 0; k < cells; ++k) {
    const float v = imaginary ? -plane[k].imag() : plane[k].real();
    if (v > best_v) best_v = v, best = k;
  }
  Peak p;
  p.score = static_cast<double>(best_v) / (static_cast<double>(n) * static_cast<double>(n));
  p.yaw_rad = yaw_rad;
  p.dx = Unwrap(static_cast<int>(best % static_cast<std::size_t>(n)), n);
  p.dy = Unwrap(static_cast<int>(best / static_cast<std::size_t>(n)), n);
  return p;
}

double AngleDiff(double a, double b) {
  double d = std::fmod(std::fabs(a - b), 2.0 * kPi);
  return d > kPi ? 2.0 * kPi - d : d;
}

}  // namespace

Status ValidateBevSearchParams(const BevSearchParams& p) {
  if (!(std::isfinite(p.cell_size_m) && p.cell_size_m > 0.0)) {
    return InvalidArgument("bev search: cell_size_m must be finite and > 0, got " + std::to_string(p.cell_size_m));
  }
  if (p.grid_cells < 16 || p.grid_cells > 1024 || (p.grid_cells & (p.grid_cells - 1)) != 0) {
    return InvalidArgument("bev search: grid_cells must be a power of two in [16, 1024], got " +
                           std::to_string(p.grid_cells));
  }
  if (p.yaw_steps < 8 || p.yaw_steps > 720 || p.yaw_steps % 2 != 0) {
    return InvalidArgument("bev search: yaw_steps must be even and in [8, 720], got " + std::to_string(p.yaw_steps));
  }
  if (!(std::isfinite(p.min_vertical_extent_m) && p.min_vertical_extent_m >= 0.0)) {
    return InvalidArgument("bev search: min_vertical_extent_m must be finite and >= 0");
  }
  if (!(std::isfinite(p.free_cell_weight) && p.free_cell_weight >= 0.0 && p.free_cell_weight <= 1.0)) {
    return InvalidArgument("bev search: free_cell_weight must be in [0, 1]");
  }
  if (!(std::isfinite(p.min_peak_ratio) && p.min_peak_ratio >= 1.0)) {
    return InvalidArgument("bev search: min_peak_ratio must be finite and >= 1");
  }
  if (p.max_candidates < 1 || p.max_candidates > 8) {
    return InvalidArgument("bev search: max_candidates must be in [1, 8], got " + std::to_string(p.max_candidates));
  }
  if (!(std::isfinite(p.min_separation_rad) && p.min_separation_rad >= 0.0) ||
      !(std::isfinite(p.min_separation_m) && p.min_separation_m >= 0.0)) {
    return InvalidArgument("bev search: min_separation_rad and min_separation_m must be finite and >= 0");
  }
  return Status::Ok();
}

void BevSearch::Rasterise(Span<const PointXYZI> points, double yaw_rad, const BevSearchParams& params,
                          std::vector<float>* structure, std::vector<float>* zmin) {
  const int n = params.grid_cells;
  const std::size_t cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  const float kEmpty = std::numeric_limits<float>::infinity();
  zmin->assign(cells, kEmpty);
  zmax_.assign(cells, -kEmpty);
  const float c = static_cast<float>(std::cos(yaw_rad)), s = static_cast<float>(std::sin(yaw_rad));
  const double inv_cell = 1.0 / params.cell_size_m;
  for (const PointXYZI& p : points) {
    const double x = static_cast<double>(c * p.x - s * p.y);
    const double y = static_cast<double>(s * p.x + c * p.y);
    const std::size_t k = static_cast<std::size_t>(CellOf(y, inv_cell, n)) * static_cast<std::size_t>(n) +
                          static_cast<std::size_t>(CellOf(x, inv_cell, n));
    (*zmin)[k] = std::min((*zmin)[k], p.z);
    zmax_[k] = std::max(zmax_[k], p.z);
  }
  structure->assign(cells, 0.0f);
  const float extent = static_cast<float>(params.min_vertical_extent_m);
  const float free_weight = -static_cast<float>(params.free_cell_weight);
  for (std::size_t k = 0; k < cells; ++k) {
    if (!(zmax_[k] >= (*zmin)[k])) continue;  // no point
    (*structure)[k] = zmax_[k] - (*zmin)[k] > extent ? 1.0f : free_weight;
  }
}

double BevSearch::GroundOffset(Span<const PointXYZI> source, double yaw_rad, int dx, int dy,
                               const BevSearchParams& params) {
  Rasterise(source, yaw_rad, params, &structure_a_, &zmin_a_);
  const int n = params.grid_cells;
  offsets_.clear();
  for (int r = 0; r < n; ++r) {
    for (int col = 0; col < n; ++col) {
      const float zs = zmin_a_[static_cast<std::size_t>(r) * static_cast<std::size_t>(n) + static_cast<std::size_t>(col)];
      if (!std::isfinite(zs)) continue;
      const int tr = (r + dy) & (n - 1), tc = (col + dx) & (n - 1);
      const float zt = target_zmin_[static_cast<std::size_t>(tr) * static_cast<std::size_t>(n) + static_cast<std::size_t>(tc)];
      if (std::isfinite(zt)) offsets_.push_back(zt - zs);
    }
  }
  if (offsets_.empty()) return 0.0;
  const auto mid = offsets_.begin() + static_cast<std::ptrdiff_t>(offsets_.size() / 2);
  std::nth_element(offsets_.begin(), mid, offsets_.end());
  return static_cast<double>(*mid);
}

Status BevSearch::Search(Span<const PointXYZI> source, Span<const PointXYZI> target, const BevSearchParams& params,
                         std::vector<BevCandidate>* candidates) {
  const Status valid = ValidateBevSearchParams(params);
  if (!valid.ok()) return valid;
  candidates->clear();
  const int n = params.grid_cells;
  const Status init = fft_.Init(n);
  if (!init.ok()) return init;
  const std::size_t cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);

  Rasterise(target, 0.0, params, &structure_b_, &target_zmin_);
  bool any = false;
  target_spectrum_.resize(cells);
  for (std::size_t k = 0; k < cells; ++k) {
    target_spectrum_[k] = std::complex<float>(structure_b_[k], 0.0f);
    any = any || structure_b_[k] > 0.0f;  // at least one structure cell
  }
  if (!any) return Status::Ok();
  const Status ft = fft_.Forward(target_spectrum_);
  if (!ft.ok()) return ft;

  // Two yaws per transform: a (real part) and b (imaginary part). With A, B the spectra of the real grids,
  // T conj(A + iB) = T conj(A) - i T conj(B), whose inverse is corr_a - i corr_b (both real).
  std::vector<Peak> peaks;
  peaks.reserve(static_cast<std::size_t>(params.yaw_steps));
  work_.resize(cells);
  const double step = 2.0 * kPi / static_cast<double>(params.yaw_steps);
  bool source_any = false;
  for (int k = 0; k < params.yaw_steps; k += 2) {
    const double yaw_a = step * k, yaw_b = step * (k + 1);
    Rasterise(source, yaw_a, params, &structure_a_, &zmin_a_);
    Rasterise(source, yaw_b, params, &structure_b_, &zmin_b_);
    for (std::size_t c = 0; c < cells; ++c) {
      work_[c] = std::complex<float>(structure_a_[c], structure_b_[c]);
      source_any = source_any || structure_a_[c] > 0.0f || structure_b_[c] > 0.0f;
    }
    if (!source_any) return Status::Ok();
    Status s = fft_.Forward(work_);
    if (!s.ok()) return s;
    for (std::size_t c = 0; c < cells; ++c) work_[c] = target_spectrum_[c] * std::conj(work_[c]);
    s = fft_.Inverse(work_);
    if (!s.ok()) return s;
    peaks.push_back(BestShift(work_.data(), false, n, yaw_a));
    peaks.push_back(BestShift(work_.data(), true, n, yaw_b));
  }

  std::stable_sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.score > b.score; });
  std::vector<Peak> chosen;
  for (const Peak& p : peaks) {
    if (static_cast<int>(chosen.size()) >= params.max_candidates) break;
    if (!(p.score > 0.0)) break;
    bool distinct = true;
    for (const Peak& q : chosen) {
      const double shift_m = std::hypot(p.dx - q.dx, p.dy - q.dy) * params.cell_size_m;
      if (AngleDiff(p.yaw_rad, q.yaw_rad) <= params.min_separation_rad && shift_m <= params.min_separation_m) {
        distinct = false;
        break;
      }
    }
    if (distinct) chosen.push_back(p);
  }
  for (const Peak& p : chosen) {
    BevCandidate c;
    c.yaw_rad = p.yaw_rad;
    c.score = p.score;
    c.T_target_source.linear() = Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    c.T_target_source.translation() =
        Eigen::Vector3d(p.dx * params.cell_size_m, p.dy * params.cell_size_m,
                        GroundOffset(source, p.yaw_rad, p.dx, p.dy, params));
    candidates->push_back(c);
  }
  return Status::Ok();
}

Status BevSearch::CorrelationForYawStep(Span<const PointXYZI> source, const BevSearchParams& params, int step,
                                        std::vector<float>* scores) {
  const Status valid = ValidateBevSearchParams(params);
  if (!valid.ok()) return valid;
  const int n = params.grid_cells;
  const std::size_t cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  if (fft_.size() != n || target_spectrum_.size() != cells || step < 0 || step >= params.yaw_steps) {
    return InvalidArgument("bev search: CorrelationForYawStep needs a Search with the same grid and a valid step");
  }
  Rasterise(source, 2.0 * kPi * step / static_cast<double>(params.yaw_steps), params, &structure_a_, &zmin_a_);
  work_.resize(cells);
  for (std::size_t c = 0; c < cells; ++c) work_[c] = std::complex<float>(structure_a_[c], 0.0f);
  Status s = fft_.Forward(work_);
  if (!s.ok()) return s;
  for (std::size_t c = 0; c < cells; ++c) work_[c] = target_spectrum_[c] * std::conj(work_[c]);
  s = fft_.Inverse(work_);
  if (!s.ok()) return s;
  scores->resize(cells);
  const float inv = 1.0f / static_cast<float>(cells);
  for (std::size_t c = 0; c < cells; ++c) (*scores)[c] = work_[c].real() * inv;
  return Status::Ok();
}

std::size_t BevSearch::workspace_bytes() const noexcept {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return fft_.workspace_bytes() + held(target_spectrum_) + held(work_) + held(structure_a_) + held(structure_b_) +
         held(zmin_a_) + held(zmin_b_) + held(target_zmin_) + held(zmax_) + held(offsets_);
}

}  // namespace commerge
