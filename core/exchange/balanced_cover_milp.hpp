// SPDX-License-Identifier: BSD-3-Clause
// commerge stage B: the balanced-vertex-cover MILP of the paper written out as a plain 0/1 program, for a general
// MIP solver (GLPK's glp_intopt through SolveMipWithGlpk). It is the reference our own branch-and-bound
// (balanced_vertex_cover.hpp) is tested and benchmarked against, so it shares no code with that solver.
#pragma once

#include <vector>

#include "core/common/status.hpp"
#include "core/exchange/exchange_graph.hpp"
#include "core/solvers/lp_relaxation.hpp"

namespace commerge {

/// The model: one binary variable per candidate (non-isolated) scan, in global vertex id order; minimise the
/// total weight (`vertex_weights`, one per vertex, or unit cost when empty); x_u + x_v >= 1 for every candidate
/// loop; sum of robot r's candidate variables >= shares[r] (rows with a share of 0 are left out). `shares` is
/// typically MultiRobotCoverResult::share_per_robot. All variables are integer. InvalidArgument for a weight or
/// share vector of the wrong size, a weight that is not finite and > 0, or a negative share.
Result<LinearProgram> BalancedCoverMilp(const ExchangeGraph& graph, const std::vector<double>& vertex_weights,
                                        const std::vector<int>& shares);

}  // namespace commerge
