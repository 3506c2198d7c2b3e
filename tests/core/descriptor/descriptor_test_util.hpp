// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the descriptor tests.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"

namespace commerge {

/// Span over a std::array with the element type deduced.
template <class T, std::size_t N>
Span<T> AsSpan(std::array<T, N>& a) {
  return {a.data(), N};
}
template <class T, std::size_t N>
Span<const T> AsSpan(const std::array<T, N>& a) {
  return {a.data(), N};
}

/// p_q = R_z(-psi) p: the query seen from a sensor yawed by +psi (SOLID.md §3), rotated in double.
inline std::vector<PointXYZI> YawedCopy(const std::vector<PointXYZI>& in, double psi_rad) {
  const double c = std::cos(psi_rad), s = std::sin(psi_rad);
  std::vector<PointXYZI> out(in);
  for (PointXYZI& p : out) {
    const double x = static_cast<double>(p.x), y = static_cast<double>(p.y);
    p.x = static_cast<float>(c * x + s * y);
    p.y = static_cast<float>(-s * x + c * y);
  }
  return out;
}

}  // namespace commerge
