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

/// Registers every row of the table and --cover on `cmd`, bound to `*params` (whose current values are the defaults
/// shown), and --profile bound to `*profile`.
void AddMergeFlags(CLI::App* cmd, MergeServerParams* params, std::string* profile);

/// After parsing: the parameters of `profile` (MergeProfileParams for the sensor named `lidar`) with every merge
/// flag given on `cmd`'s command line (and --cover) taken from `*params`, into `*params`. Errors: an unknown profile.
Status ApplyMergeProfile(const CLI::App& cmd, const std::string& profile, const std::string& lidar,
                         MergeServerParams* params);
/// The descriptor a profile's robots use when --descriptor is not given: SOLiD for the paper, else `fallback`.
std::string ProfileDescriptor(const std::string& profile, const std::string& fallback);

/// The value of `flag` in `params` as text (as --help shows it).
std::string MergeFlagValue(const MergeFlag& flag, MergeServerParams* params);

}  // namespace commerge::app
