// SPDX-License-Identifier: BSD-3-Clause
// SOLiD: one pass over the points fills the REC / AEC counters and the elevation histogram, then the
// min-max elevation weights turn both counter matrices into R-SOLiD and A-SOLiD (SOLID.md §1.3-§1.4).
#include "core/descriptor/solid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/geometry/angles.hpp"

namespace commerge {
namespace {

template <class T>
double NormSquared(Span<const T> v) noexcept {
  double s = 0.0;
  for (const T x : v) s += static_cast<double>(x) * static_cast<double>(x);
  return s;
}

// Cosine of two equally long vectors in one pass, accumulated in double; false when unusable (size
// mismatch, empty, a zero or non-finite vector).
template <class T>
bool Cosine(Span<const T> a, Span<const T> b, double* cosine) noexcept {
  if (a.size() != b.size() || a.empty()) return false;
  double ab = 0.0, aa = 0.0, bb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double x = static_cast<double>(a[i]);
    const double y = static_cast<double>(b[i]);
    ab += x * y;
    aa += x * x;
    bb += y * y;
  }
  if (!(aa > 0.0 && bb > 0.0)) return false;
  const double c = ab / (std::sqrt(aa) * std::sqrt(bb));
  if (!std::isfinite(c)) return false;
  *cosine = c;
  return true;
}

template <class T>
double CosineOrZero(Span<const T> a, Span<const T> b) noexcept {
  double c = 0.0;
  return Cosine(a, b, &c) ? c : 0.0;
}

template <class T>
double Distance(Span<const T> a, Span<const T> b) noexcept {
  double c = 0.0;
  if (!Cosine(a, b, &c)) return kSolidMaxDistance;
  return std::sqrt(std::max(0.0, 2.0 - 2.0 * c));
}

}  // namespace

// Friend of SolidWorkspace: the binning kernel, templated on the point source.
struct SolidKernel {
  template <class PointAt>
  static void Run(std::size_t n, PointAt point_at, const SolidParams& p, SolidWorkspace* ws, SolidResult* out,
                  OutOfFovPolicy policy) {
    const int nr = p.num_rings, na = p.num_sectors, ne = p.num_elev_bins;
    ws->Reserve(p);
    std::fill(ws->rec_.begin(), ws->rec_.begin() + static_cast<std::ptrdiff_t>(nr) * ne, 0u);
    std::fill(ws->aec_.begin(), ws->aec_.begin() + static_cast<std::ptrdiff_t>(na) * ne, 0u);
    std::fill(ws->hist_.begin(), ws->hist_.begin() + ne, 0u);
    std::uint32_t* const rec = ws->rec_.data();
    std::uint32_t* const aec = ws->aec_.data();
    std::uint32_t* const hist = ws->hist_.data();

    SolidResult& res = *out;
    static_cast<DescriptorInfo&>(res) = DescriptorInfo{};
    res.num_rings = nr;
    res.num_sectors = na;
    res.r.fill(0.0);
    res.a.fill(0.0);
    res.num_points_in = static_cast<std::uint32_t>(n);

    const double ring_width_m = p.max_range_m / nr;
    const double sector_width_deg = 360.0 / na;  // floating-point division (SOLID.md §1.3)
    const double elev_width_deg = (p.fov_up_deg - p.fov_down_deg) / ne;
    const double fov_down = p.fov_down_deg, fov_up = p.fov_up_deg;
    const double min_r2 = p.min_range_m * p.min_range_m;
    const double max_r2 = p.max_range_m * p.max_range_m;
    const bool skip = policy == OutOfFovPolicy::kSkip;
    const double min_z = p.min_z_m;  // -infinity when off: no finite z is below it

    std::uint32_t nonfinite = 0, out_of_range = 0, below = 0, above = 0, below_z = 0, counted = 0;
    for (std::size_t i = 0; i < n; ++i) {
      double x, y, z;
      point_at(i, &x, &y, &z);
      if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
        ++nonfinite;
        continue;
      }
      const double r2 = x * x + y * y + z * z;
      if (!(r2 > min_r2 && r2 < max_r2)) {
        ++out_of_range;
        continue;
      }
      if (z < min_z) {
        ++below_z;
        continue;
      }
      if (x == 0.0) x = 0.001;  // the reference's guard, kept for parity
      if (y == 0.0) y = 0.001;
      const double rho = std::sqrt(x * x + y * y);
      const double phi = std::atan2(z, rho) * kRadToDeg;
      int ie;
      if (skip) {
        if (phi < fov_down) {
          ++below;
          continue;
        }
        if (phi > fov_up) {
          ++above;
          continue;
        }
        ie = std::min(static_cast<int>((phi - fov_down) / elev_width_deg), ne - 1);
      } else {
        below += phi < fov_down;
        above += phi > fov_up;
        const double t = (phi - fov_down) / elev_width_deg;
        if (t <= -1.0) continue;  // trunc(t) < 0
        ie = std::min(static_cast<int>(t), ne - 1);  // t in (-1, 0) truncates to bin 0
      }
      double theta = std::atan2(y, x) * kRadToDeg;
      if (theta < 0.0) theta += 360.0;
      const int ir = std::min(static_cast<int>(rho / ring_width_m), nr - 1);
      const int ia = std::min(static_cast<int>(theta / sector_width_deg), na - 1);
      ++rec[ir * ne + ie];
      ++aec[ia * ne + ie];
      ++hist[ie];
      ++counted;
    }
    res.num_nonfinite = nonfinite;
    res.num_out_of_range = out_of_range;
    res.num_below_fov = below;
    res.num_above_fov = above;
    res.num_below_min_z = below_z;
    res.num_counted = counted;

    // Min-max elevation weights (SOLID.md §1.4): w_h = (n_h - min n) / (max n - min n).
    std::uint32_t min_n = std::numeric_limits<std::uint32_t>::max(), max_n = 0;
    int nonempty = 0;
    for (int h = 0; h < ne; ++h) {
      min_n = std::min(min_n, hist[h]);
      max_n = std::max(max_n, hist[h]);
      nonempty += hist[h] != 0;
    }
    SolidInvalidReason reason = SolidInvalidReason::kNone;
    if (counted == 0) {
      reason = SolidInvalidReason::kNoPointsCounted;
    } else if (nonempty < 2) {
      reason = SolidInvalidReason::kSingleElevationBin;
    } else if (max_n == min_n) {
      reason = SolidInvalidReason::kFlatElevationHistogram;
    }
    if (reason == SolidInvalidReason::kNone) {
      double* const w = ws->weights_.data();
      const double span = static_cast<double>(max_n - min_n);
      for (int h = 0; h < ne; ++h) w[h] = static_cast<double>(hist[h] - min_n) / span;
      double norm2 = 0.0;
      for (int r = 0; r < nr; ++r) {
        const std::uint32_t* row = rec + r * ne;
        double s = 0.0;
        for (int h = 0; h < ne; ++h) s += static_cast<double>(row[h]) * w[h];
        res.r[static_cast<std::size_t>(r)] = s;
        norm2 += s * s;
      }
      for (int a = 0; a < na; ++a) {
        const std::uint32_t* row = aec + a * ne;
        double s = 0.0;
        for (int h = 0; h < ne; ++h) s += static_cast<double>(row[h]) * w[h];
        res.a[static_cast<std::size_t>(a)] = s;
      }
      if (!(norm2 > 0.0) || !std::isfinite(norm2)) reason = SolidInvalidReason::kZeroNorm;
    }
    res.invalid_reason = reason;
    res.valid = reason == SolidInvalidReason::kNone;
    if (!res.valid) {
      res.r.fill(0.0);
      res.a.fill(0.0);
    }
  }
};

const char* SolidInvalidReasonName(SolidInvalidReason reason) noexcept {
  switch (reason) {
    case SolidInvalidReason::kNone: return "valid";
    case SolidInvalidReason::kNoPointsCounted: return "no points counted";
    case SolidInvalidReason::kSingleElevationBin: return "single elevation bin";
    case SolidInvalidReason::kFlatElevationHistogram: return "flat elevation histogram";
    case SolidInvalidReason::kZeroNorm: return "zero norm";
  }
  return "unknown";
}

double OutOfFovFraction(const DescriptorInfo& info) noexcept {
  const std::uint64_t excluded =
      static_cast<std::uint64_t>(info.num_nonfinite) + info.num_out_of_range + info.num_below_min_z;
  if (info.num_points_in <= excluded) return 0.0;
  const std::uint64_t in_range = info.num_points_in - excluded;
  return static_cast<double>(static_cast<std::uint64_t>(info.num_below_fov) + info.num_above_fov) /
         static_cast<double>(in_range);
}

bool SolidFovWarning(const DescriptorInfo& info, double max_fraction) noexcept {
  return OutOfFovFraction(info) > max_fraction;
}

void SolidWorkspace::Reserve(const SolidParams& p) {
  if (p.num_rings < 1 || p.num_sectors < 1 || p.num_elev_bins < 1) return;
  const auto ne = static_cast<std::size_t>(p.num_elev_bins);
  const std::size_t rec = static_cast<std::size_t>(p.num_rings) * ne;
  const std::size_t aec = static_cast<std::size_t>(p.num_sectors) * ne;
  if (rec_.size() < rec) rec_.resize(rec);
  if (aec_.size() < aec) aec_.resize(aec);
  if (hist_.size() < ne) hist_.resize(ne);
  if (weights_.size() < ne) weights_.resize(ne);
}

std::size_t SolidWorkspace::capacity_bytes() const noexcept {
  return (rec_.capacity() + aec_.capacity() + hist_.capacity()) * sizeof(std::uint32_t) +
         weights_.capacity() * sizeof(double);
}

namespace {

Status CheckCall(std::size_t n, const SolidParams& params, const SolidWorkspace* ws, const SolidResult* out) {
  if (ws == nullptr) return InvalidArgument("SOLiD: the workspace is null");
  if (out == nullptr) return InvalidArgument("SOLiD: the result pointer is null");
  if (n > std::numeric_limits<std::uint32_t>::max()) {
    return InvalidArgument("SOLiD: " + std::to_string(n) + " points, at most 4294967295 per scan");
  }
  return ValidateSolidParams(params);
}

}  // namespace

Status ComputeSolid(Span<const PointXYZI> scan, const SolidParams& params, SolidWorkspace* workspace,
                    SolidResult* out, OutOfFovPolicy policy) {
  if (Status s = CheckCall(scan.size(), params, workspace, out); !s.ok()) return s;
  const PointXYZI* pts = scan.data();
  SolidKernel::Run(
      scan.size(),
      [pts](std::size_t i, double* x, double* y, double* z) {
        *x = static_cast<double>(pts[i].x);
        *y = static_cast<double>(pts[i].y);
        *z = static_cast<double>(pts[i].z);
      },
      params, workspace, out, policy);
  return Status::Ok();
}

Status ComputeSolidXyz(Span<const double> xyz, const SolidParams& params, SolidWorkspace* workspace,
                       SolidResult* out, OutOfFovPolicy policy) {
  if (xyz.size() % 3 != 0) {
    return InvalidArgument("SOLiD: xyz holds " + std::to_string(xyz.size()) + " values, not a multiple of 3");
  }
  if (Status s = CheckCall(xyz.size() / 3, params, workspace, out); !s.ok()) return s;
  const double* v = xyz.data();
  SolidKernel::Run(
      xyz.size() / 3,
      [v](std::size_t i, double* x, double* y, double* z) {
        *x = v[3 * i];
        *y = v[3 * i + 1];
        *z = v[3 * i + 2];
      },
      params, workspace, out, policy);
  return Status::Ok();
}

Status UnitNormalizeRSolid(const SolidResult& result, Span<float> out) {
  if (result.num_rings < 0 || out.size() != static_cast<std::size_t>(result.num_rings)) {
    return InvalidArgument("SOLiD: the unit R-SOLiD output holds " + std::to_string(out.size()) +
                           " floats, expected num_rings = " + std::to_string(result.num_rings));
  }
  std::fill(out.begin(), out.end(), 0.0f);
  if (!result.valid) return Status::Ok();
  const double norm = std::sqrt(NormSquared(result.rsolid()));
  if (!(norm > 0.0) || !std::isfinite(norm)) return Status::Ok();
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<float>(result.r[i] / norm);
  return Status::Ok();
}

double SolidCosineSimilarity(Span<const double> a, Span<const double> b) noexcept { return CosineOrZero(a, b); }
double SolidCosineSimilarity(Span<const float> a, Span<const float> b) noexcept { return CosineOrZero(a, b); }
double SolidDistance(Span<const double> a, Span<const double> b) noexcept { return Distance(a, b); }
double SolidDistance(Span<const float> a, Span<const float> b) noexcept { return Distance(a, b); }

Result<SolidYawEstimate> EstimateSolidYaw(Span<const double> q, Span<const double> c) {
  if (q.size() != c.size() || q.empty() || q.size() > static_cast<std::size_t>(kSolidMaxSectors)) {
    return InvalidArgument("SOLiD yaw: A-SOLiD sizes " + std::to_string(q.size()) + " and " +
                           std::to_string(c.size()) + " must be equal and in [1, " +
                           std::to_string(kSolidMaxSectors) + "]");
  }
  for (std::size_t i = 0; i < q.size(); ++i) {
    if (!std::isfinite(q[i]) || !std::isfinite(c[i])) {
      return InvalidArgument("SOLiD yaw: non-finite A-SOLiD value at sector " + std::to_string(i));
    }
  }
  const std::size_t n = q.size();
  SolidYawEstimate best;
  best.l1_cost = std::numeric_limits<double>::infinity();
  for (std::size_t s = 0; s < n; ++s) {
    double cost = 0.0;
    for (std::size_t a = 0; a < n; ++a) {
      std::size_t j = a + s;
      if (j >= n) j -= n;
      cost += std::fabs(q[a] - c[j]);
    }
    if (cost < best.l1_cost) {
      best.l1_cost = cost;
      best.shift = static_cast<int>(s);
    }
  }
  double yaw_deg = best.shift * (360.0 / static_cast<double>(n));
  if (yaw_deg > 180.0) yaw_deg -= 360.0;  // (-180, 180]
  best.yaw_rad = yaw_deg * kDegToRad;
  return best;
}

Result<SolidYawEstimate> EstimateSolidYaw(const SolidResult& query, const SolidResult& candidate) {
  if (!query.valid || !candidate.valid) {
    return InvalidArgument(std::string("SOLiD yaw: ") + (!query.valid ? "query" : "candidate") +
                           " descriptor is invalid (" +
                           SolidInvalidReasonName(!query.valid ? query.invalid_reason : candidate.invalid_reason) +
                           ")");
  }
  return EstimateSolidYaw(query.asolid(), candidate.asolid());
}

SolidDescriptor::SolidDescriptor() : SolidDescriptor(SolidParams{}) {}

SolidDescriptor::SolidDescriptor(const SolidParams& params)
    : params_(params), parameter_id_(SolidParameterId(params)), workspace_(params) {
  last_.num_rings = params.num_rings;
  last_.num_sectors = params.num_sectors;
}

Result<SolidDescriptor> SolidDescriptor::Create(const SolidParams& params) {
  if (Status s = ValidateSolidParams(params); !s.ok()) return s;
  return SolidDescriptor(params);
}

Result<DescriptorInfo> SolidDescriptor::Compute(Span<const PointXYZI> scan, Span<float> out) {
  if (out.size() != dimension()) {
    return InvalidArgument("SOLiD descriptor: output holds " + std::to_string(out.size()) + " floats, expected " +
                           std::to_string(dimension()));
  }
  if (Status s = ComputeSolid(scan, params_, &workspace_, &last_, OutOfFovPolicy::kSkip); !s.ok()) {
    std::fill(out.begin(), out.end(), 0.0f);
    return s;
  }
  if (Status s = UnitNormalizeRSolid(last_, out); !s.ok()) return s;
  return static_cast<const DescriptorInfo&>(last_);
}

}  // namespace commerge
