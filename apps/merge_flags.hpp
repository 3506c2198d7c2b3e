// SPDX-License-Identifier: BSD-3-Clause
// The merge server's parameters that `commerge run` and `commerge server` share, as one table (flag, field of
// MergeServerParams, unit, range, paper symbol, help), registered by both apps. Defaults are the core parameter
// structs' (MergeServerParams{}), so a flag means the same in both apps and its default cannot drift.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "core/agent/merge_server.hpp"
#include "core/common/span.hpp"

namespace commerge::app {

struct MergeFlag {
  enum class Type { kDouble, kUint64, kSize, kUint32, kInt, kInt64 };
  const char* flag;          ///< "--tau-inter"
  const char* field;         ///< "cascade.stage_a.tau_inter" (MergeServerParams member path)
  const char* unit;          ///< "m", "cells", "" (dimensionless)
  double min_value, max_value;
  const char* paper_symbol;  ///< the paper's symbol, or "ours" for parameters the paper does not have
  const char* help;
  Type type;
  void* (*bind)(MergeServerParams*);  ///< the field in a parameter struct
};

/// Every row of the table.
Span<const MergeFlag> MergeFlagTable();

/// Registers every row of the table on `cmd`, bound to `*params` (whose current values are the defaults shown).
void AddMergeFlags(CLI::App* cmd, MergeServerParams* params);

/// The value of `flag` in `params` as text (as --help shows it).
std::string MergeFlagValue(const MergeFlag& flag, MergeServerParams* params);

}  // namespace commerge::app
