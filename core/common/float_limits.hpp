// SPDX-License-Identifier: BSD-3-Clause
// commerge: float special values: infinity (minimum searches start from it, ray casts return it for no hit) and
// the quiet NaN (the invalid input that validation must reject).
#pragma once

#include <limits>

namespace commerge {

constexpr float kFloatInf = std::numeric_limits<float>::infinity();
constexpr float kFloatNaN = std::numeric_limits<float>::quiet_NaN();

}  // namespace commerge
