// SPDX-License-Identifier: BSD-3-Clause
// commerge: a number as text for error messages and reports, with a chosen count of significant digits.
#pragma once

#include <sstream>
#include <string>

namespace commerge {

/// `value` printed by an ostream with `significant_digits` of precision ("0.25", "1e-06", "nan").
inline std::string FormatNumber(double value, int significant_digits) {
  std::ostringstream os;
  os.precision(significant_digits);
  os << value;
  return os.str();
}

}  // namespace commerge
