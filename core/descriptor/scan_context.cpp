// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/scan_context.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "core/common/number_text.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/geometry/angles.hpp"

namespace commerge {
namespace {

bool GridOk(std::size_t size, int num_rings, int num_sectors) noexcept {
  return num_rings >= 1 && num_rings <= kScanContextMaxRings && num_sectors >= 1 &&
         num_sectors <= kScanContextMaxSectors &&
         size == static_cast<std::size_t>(num_rings) * static_cast<std::size_t>(num_sectors);
}

}  // namespace

Status ValidateScanContextParams(const ScanContextParams& p) {
  if (p.num_rings < 1 || p.num_rings > kScanContextMaxRings) {
    return InvalidArgument("Scan Context parameters: num_rings must be in [1, " +
                           std::to_string(kScanContextMaxRings) + "], got " + std::to_string(p.num_rings));
  }
  if (p.num_sectors < 1 || p.num_sectors > kScanContextMaxSectors || 360 % p.num_sectors != 0) {
    return InvalidArgument("Scan Context parameters: num_sectors must be in [1, 360] and divide 360, got " +
                           std::to_string(p.num_sectors));
  }
  if (!(std::isfinite(p.max_range_m) && p.max_range_m > 0.0)) {
    return InvalidArgument("Scan Context parameters: max_range_m must be finite and > 0, got " +
                           FormatNumber(p.max_range_m, 12));
  }
  if (!std::isfinite(p.lidar_height_m)) {
    return InvalidArgument("Scan Context parameters: lidar_height_m must be finite, got " +
                           FormatNumber(p.lidar_height_m, 12));
  }
  return Status::Ok();
}

std::uint32_t ScanContextParameterId(const ScanContextParams& p) noexcept {
  std::uint32_t h = detail::Fnv1aByte(detail::kFnv1aOffset, 2);  // DescriptorKind::kScanContext
  h = detail::Fnv1aInt32(h, p.num_rings);
  h = detail::Fnv1aInt32(h, p.num_sectors);
  h = detail::Fnv1aDouble(h, p.max_range_m);
  h = detail::Fnv1aDouble(h, p.lidar_height_m);
  return h;
}

Result<DescriptorInfo> ComputeScanContext(Span<const PointXYZI> scan, const ScanContextParams& p, Span<float> out) {
  if (Status s = ValidateScanContextParams(p); !s.ok()) return s;
  if (!GridOk(out.size(), p.num_rings, p.num_sectors)) {
    return InvalidArgument("Scan Context: output holds " + std::to_string(out.size()) + " floats, expected " +
                           std::to_string(p.num_rings * p.num_sectors));
  }
  if (scan.size() > std::numeric_limits<std::uint32_t>::max()) {
    return InvalidArgument("Scan Context: " + std::to_string(scan.size()) + " points, at most 4294967295 per scan");
  }
  constexpr float kEmpty = -std::numeric_limits<float>::infinity();
  std::fill(out.begin(), out.end(), kEmpty);

  DescriptorInfo info;
  info.num_points_in = static_cast<std::uint32_t>(scan.size());
  const int nr = p.num_rings, ns = p.num_sectors;
  for (const PointXYZI& pt : scan) {
    if (!IsFinite(pt)) {
      ++info.num_nonfinite;
      continue;
    }
    double x = static_cast<double>(pt.x), y = static_cast<double>(pt.y);
    const double z = static_cast<double>(pt.z);
    if (x == 0.0) x = 0.001;
    if (y == 0.0) y = 0.001;
    const double rho = std::sqrt(x * x + y * y);
    if (rho > p.max_range_m) {
      ++info.num_out_of_range;
      continue;
    }
    double theta = std::atan2(y, x) * kRadToDeg;
    if (theta < 0.0) theta += 360.0;
    const int ring = std::clamp(static_cast<int>(std::ceil(rho / p.max_range_m * nr)), 1, nr) - 1;
    const int sector = std::clamp(static_cast<int>(std::ceil(theta / 360.0 * ns)), 1, ns) - 1;
    float& cell = out[static_cast<std::size_t>(ring * ns + sector)];
    cell = std::max(cell, static_cast<float>(z + p.lidar_height_m));
    ++info.num_counted;
  }
  bool any_nonzero = false;
  for (float& v : out) {
    if (v == kEmpty) v = 0.0f;
    any_nonzero = any_nonzero || v != 0.0f;
  }
  info.valid = any_nonzero;
  if (!info.valid) std::fill(out.begin(), out.end(), 0.0f);
  return info;
}

Status ScanContextRingKey(Span<const float> sc, int num_rings, int num_sectors, Span<float> out) {
  if (!GridOk(sc.size(), num_rings, num_sectors) || out.size() != static_cast<std::size_t>(num_rings)) {
    return InvalidArgument("Scan Context ring key: descriptor of " + std::to_string(sc.size()) + " floats, key of " +
                           std::to_string(out.size()) + " for a " + std::to_string(num_rings) + " x " +
                           std::to_string(num_sectors) + " grid");
  }
  for (int r = 0; r < num_rings; ++r) {
    double s = 0.0;
    for (int c = 0; c < num_sectors; ++c) s += static_cast<double>(sc[static_cast<std::size_t>(r * num_sectors + c)]);
    out[static_cast<std::size_t>(r)] = static_cast<float>(s / num_sectors);
  }
  return Status::Ok();
}

ScanContextMatch MatchScanContext(Span<const float> q, Span<const float> k, int nr, int ns) noexcept {
  ScanContextMatch best;
  if (!GridOk(q.size(), nr, ns) || !GridOk(k.size(), nr, ns)) return best;
  double qn[kScanContextMaxSectors];
  double kn[kScanContextMaxSectors];
  for (int c = 0; c < ns; ++c) {
    double sq = 0.0, sk = 0.0;
    for (int r = 0; r < nr; ++r) {
      const double a = static_cast<double>(q[static_cast<std::size_t>(r * ns + c)]);
      const double b = static_cast<double>(k[static_cast<std::size_t>(r * ns + c)]);
      sq += a * a;
      sk += b * b;
    }
    qn[c] = std::sqrt(sq);
    kn[c] = std::sqrt(sk);
  }
  best.distance = std::numeric_limits<double>::infinity();
  for (int s = 0; s < ns; ++s) {
    double sum_cos = 0.0;
    int used = 0;
    for (int c = 0; c < ns; ++c) {
      const int kc = (c + s) % ns;
      if (!(qn[c] > 0.0) || !(kn[kc] > 0.0)) continue;
      double dot = 0.0;
      for (int r = 0; r < nr; ++r) {
        dot += static_cast<double>(q[static_cast<std::size_t>(r * ns + c)]) *
               static_cast<double>(k[static_cast<std::size_t>(r * ns + kc)]);
      }
      sum_cos += dot / (qn[c] * kn[kc]);
      ++used;
    }
    const double d = used == 0 ? 1.0 : 1.0 - sum_cos / used;
    if (d < best.distance) {
      best.distance = d;
      best.shift = s;
      best.num_columns = used;
    }
  }
  if (!std::isfinite(best.distance)) {  // non-finite cells
    best = ScanContextMatch{};
    return best;
  }
  double yaw_deg = best.shift * (360.0 / ns);
  if (yaw_deg > 180.0) yaw_deg -= 360.0;
  best.yaw_rad = yaw_deg * kDegToRad;
  return best;
}

ScanContextDescriptor::ScanContextDescriptor() : ScanContextDescriptor(ScanContextParams{}) {}

ScanContextDescriptor::ScanContextDescriptor(const ScanContextParams& params)
    : params_(params), parameter_id_(ScanContextParameterId(params)) {}

Result<ScanContextDescriptor> ScanContextDescriptor::Create(const ScanContextParams& params) {
  if (Status s = ValidateScanContextParams(params); !s.ok()) return s;
  return ScanContextDescriptor(params);
}

Result<DescriptorInfo> ScanContextDescriptor::Compute(Span<const PointXYZI> scan, Span<float> out) {
  return ComputeScanContext(scan, params_, out);
}

double ScanContextDescriptor::Distance(Span<const float> a, Span<const float> b) const {
  return Match(a, b).distance;
}

ScanContextMatch ScanContextDescriptor::Match(Span<const float> query, Span<const float> candidate) const noexcept {
  return MatchScanContext(query, candidate, params_.num_rings, params_.num_sectors);
}

}  // namespace commerge
