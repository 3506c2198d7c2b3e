// SPDX-License-Identifier: BSD-3-Clause
// commerge: four floats in one SIMD register (GCC/Clang vector extension: SSE2 on x86-64, NEON on aarch64), with
// loads and stores through memcpy, so no alignment or aliasing assumption is made on the buffers. Lane operations
// are the correctly rounded scalar ones. Used by the affinity kernel, the sequence smoothing and the neighbour rank.
#pragma once

#include <cstring>

namespace commerge {

typedef float V4f __attribute__((vector_size(16)));

inline V4f Load4f(const float* p) noexcept {
  V4f v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void Store4f(float* p, V4f v) noexcept { std::memcpy(p, &v, sizeof v); }

}  // namespace commerge
