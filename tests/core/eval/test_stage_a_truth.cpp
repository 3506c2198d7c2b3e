// SPDX-License-Identifier: BSD-3-Clause
// Stage A's cluster against ground truth (core/eval/stage_a_truth.hpp): cells whose keyframes are placed by hand
// so that which of them are true (keyframes within 10 m) is known; the limit itself, cells outside the ground
// truth, and the cases without an answer.
#include <doctest/doctest.h>

#include <vector>

#include "core/eval/stage_a_truth.hpp"

using namespace commerge;

namespace {

Eigen::Isometry3d StageAPose(double x, double y) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

SequentialLoopCell StageACell(std::size_t alpha_index, std::size_t beta_index) {
  SequentialLoopCell c;
  c.alpha_index = alpha_index;
  c.beta_index = beta_index;
  return c;
}

// Alpha at (0, 0), (10, 0), (20, 0), (30, 0); beta at (0, 3), (25, 0), (60, 0), (20, 0).
const std::vector<Eigen::Isometry3d> kStageAAlpha = {StageAPose(0, 0), StageAPose(10, 0), StageAPose(20, 0),
                                                     StageAPose(30, 0)};
const std::vector<Eigen::Isometry3d> kStageABeta = {StageAPose(0, 3), StageAPose(25, 0), StageAPose(60, 0),
                                                    StageAPose(20, 0)};

double StageAFraction(const std::vector<SequentialLoopCell>& cells, const StageATruthParams& params = {}) {
  return StageATrueFraction(Span<const SequentialLoopCell>(cells), Span<const Eigen::Isometry3d>(kStageAAlpha),
                            Span<const Eigen::Isometry3d>(kStageABeta), params);
}

}  // namespace

TEST_CASE("Stage A truth: the fraction of cells whose keyframes were within 10 m, cells beyond the truth not judged") {
  // (0,0) 3 m true, (1,0) 10.4 m false, (2,1) 5 m true, (3,1) 5 m true, (3,2) 30 m false; (4,0) and (0,7) lie
  // outside the ground truth.
  const std::vector<SequentialLoopCell> cells = {StageACell(0, 0), StageACell(1, 0), StageACell(2, 1),
                                                 StageACell(3, 1), StageACell(3, 2), StageACell(4, 0),
                                                 StageACell(0, 7)};
  CHECK(StageAFraction(cells) == doctest::Approx(0.6));
  CHECK(StageAFraction({StageACell(1, 3)}) == 1.0);  // exactly 10 m is the same place
  CHECK(StageAFraction({StageACell(0, 3)}) == 0.0);  // 20 m
  StageATruthParams tight;
  tight.same_place_max_m = 4.0;  // (2,1) and (3,1) at 5 m are no longer true
  CHECK(StageAFraction(cells, tight) == doctest::Approx(0.2));
}

TEST_CASE("Stage A truth: no cells, no ground truth of either robot, or no cell within it give -1") {
  CHECK(StageAFraction({}) == -1.0);
  CHECK(StageAFraction({StageACell(4, 0), StageACell(0, 4)}) == -1.0);
  const std::vector<SequentialLoopCell> one = {StageACell(0, 0)};
  const Span<const SequentialLoopCell> cells(one);
  CHECK(StageATrueFraction(cells, {}, Span<const Eigen::Isometry3d>(kStageABeta)) == -1.0);
  CHECK(StageATrueFraction(cells, Span<const Eigen::Isometry3d>(kStageAAlpha), {}) == -1.0);
  CHECK(StageAFraction(one) == 1.0);
}
