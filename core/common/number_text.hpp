// SPDX-License-Identifier: BSD-3-Clause
// commerge: a number as text for error messages and reports, with a chosen count of significant digits or decimals.
#pragma once

#include <iomanip>
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

/// `value` in fixed-point notation with `decimals` digits after the point ("8.33", "0.00").
inline std::string FormatFixed(double value, int decimals) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(decimals) << value;
  return os.str();
}

}  // namespace commerge
