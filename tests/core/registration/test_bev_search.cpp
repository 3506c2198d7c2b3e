// SPDX-License-Identifier: BSD-3-Clause
// The bird's-eye-view global search (core/registration/bev_search) and its use as the fallback coarse stage
// of submap registration: FFT correlation against a brute-force one over independently built grids, the truth
// among the candidates of generated pairs, a registration whose feature stage is made to fail, ground-only
// input and parameter checks.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/memory/budget.hpp"
#include "core/registration/bev_search.hpp"
#include "core/registration/submap_registration.hpp"
#include "tests/core/registration/registration_test_support.hpp"

namespace commerge {
namespace {

// The grid of the header's definition, built independently: +1 structure, -w observed without structure,
// 0 unobserved; cell (floor(y / cell) mod n, floor(x / cell) mod n) of the point turned by yaw.
std::vector<double> ReferenceGrid(const std::vector<PointXYZI>& pts, double yaw, const BevSearchParams& p) {
  const int n = p.grid_cells;
  std::vector<double> zmin(static_cast<std::size_t>(n * n), 1e300), zmax(static_cast<std::size_t>(n * n), -1e300);
  for (const PointXYZI& q : pts) {
    const double qx = static_cast<double>(q.x), qy = static_cast<double>(q.y);
    const double x = std::cos(yaw) * qx - std::sin(yaw) * qy, y = std::sin(yaw) * qx + std::cos(yaw) * qy;
    const int cx = ((static_cast<int>(std::floor(x / p.cell_size_m)) % n) + n) % n;
    const int cy = ((static_cast<int>(std::floor(y / p.cell_size_m)) % n) + n) % n;
    const std::size_t k = static_cast<std::size_t>(cy * n + cx);
    zmin[k] = std::min(zmin[k], static_cast<double>(q.z));
    zmax[k] = std::max(zmax[k], static_cast<double>(q.z));
  }
  std::vector<double> g(static_cast<std::size_t>(n * n), 0.0);
  for (std::size_t k = 0; k < g.size(); ++k) {
    if (zmax[k] < zmin[k]) continue;
    g[k] = zmax[k] - zmin[k] > p.min_vertical_extent_m ? 1.0 : -p.free_cell_weight;
  }
  return g;
}

std::vector<PointXYZI> RandomColumns(std::uint32_t seed, int count, float extent_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> xy(-extent_m, extent_m), z(-2.0f, 2.0f);
  std::vector<PointXYZI> pts;
  for (int i = 0; i < count; ++i) pts.push_back({xy(rng), xy(rng), z(rng), 0.0f});
  return pts;
}

}  // namespace

TEST_CASE("Global search: FFT correlation equals a brute-force correlation of independently built grids") {
  BevSearchParams p;
  p.grid_cells = 16;
  p.yaw_steps = 8;
  p.cell_size_m = 1.0;
  const std::vector<PointXYZI> target = RandomColumns(3, 120, 6.0f), source = RandomColumns(4, 100, 6.0f);
  BevSearch bev;
  std::vector<BevCandidate> candidates;
  REQUIRE(bev.Search(source, target, p, &candidates).ok());
  REQUIRE_FALSE(candidates.empty());
  const std::vector<double> t = ReferenceGrid(target, 0.0, p);
  const int n = p.grid_cells;
  double best_overall = -1e300;
  for (int step = 0; step < p.yaw_steps; ++step) {
    CAPTURE(step);
    const std::vector<double> s = ReferenceGrid(source, 2.0 * kPi * step / p.yaw_steps, p);
    std::vector<float> fft_scores;
    REQUIRE(bev.CorrelationForYawStep(source, p, step, &fft_scores).ok());
    REQUIRE(fft_scores.size() == static_cast<std::size_t>(n * n));
    for (int dy = 0; dy < n; ++dy) {
      for (int dx = 0; dx < n; ++dx) {
        double sum = 0.0;  // sum over source cells x of t(x + d) s(x)
        for (int r = 0; r < n; ++r) {
          for (int c = 0; c < n; ++c) {
            sum += t[static_cast<std::size_t>(((r + dy) % n) * n + (c + dx) % n)] * s[static_cast<std::size_t>(r * n + c)];
          }
        }
        CHECK(static_cast<double>(fft_scores[static_cast<std::size_t>(dy * n + dx)]) == doctest::Approx(sum).epsilon(1e-4));
        best_overall = std::max(best_overall, sum);
      }
    }
  }
  // The first candidate is the best (yaw, shift) of all.
  CHECK(candidates[0].score == doctest::Approx(best_overall).epsilon(1e-4));
}

TEST_CASE("Global search: the truth is the first candidate of generated street pairs turned and shifted") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(31, Eigen::Isometry3d::Identity(), 3.0f, true), &pair).ok());
  const BevSearchParams params = MakeSubmapRegistrationParams(1.0).global_search;
  BevSearch bev;
  for (const Eigen::Isometry3d& P : {test::YawOffset(0.0, 0.0, 0.0, 0.0), test::YawOffset(77.0, 12.0, -5.0, 0.4),
                                      test::YawOffset(200.0, -8.0, 15.0, -0.3), test::YawOffset(301.0, 0.0, 20.0, 0.0)}) {
    const std::vector<PointXYZI> source = test::Transformed(pair.source.points, P.inverse());
    const Eigen::Isometry3d truth = pair.T_target_source * P;
    std::vector<BevCandidate> candidates;
    REQUIRE(bev.Search(source, pair.target.points, params, &candidates).ok());
    REQUIRE_FALSE(candidates.empty());
    CAPTURE(test::RotationErrorDeg(truth, candidates[0].T_target_source));
    CAPTURE(test::TranslationErrorM(truth, candidates[0].T_target_source));
    // Half a yaw step (1.5 deg) plus the cell quantisation (<= 1.5 cells over the submap's radius).
    CHECK(test::RotationErrorDeg(truth, candidates[0].T_target_source) < 2.0);
    CHECK(test::TranslationErrorM(truth, candidates[0].T_target_source) < 3.0);
  }
  // The server's registration budget holds the grids apart from the per-point share (core/memory/budget.hpp):
  // they do not depend on the submaps' size, and the ones at the default grid_cells fit that constant.
  MESSAGE("global search grids " << bev.workspace_bytes() << " B at " << params.grid_cells << " cells");
  CHECK(params.grid_cells == 256);
  CHECK(bev.workspace_bytes() >= static_cast<std::size_t>(params.grid_cells * params.grid_cells) * 8);
  CHECK(static_cast<std::int64_t>(bev.workspace_bytes()) <= BudgetRecordSizes::kRegistrationGridBytes);
}

TEST_CASE("Registration falls back to the global search when the feature stage fails, and only then") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(31, Eigen::Isometry3d::Identity(), 3.0f, true), &pair).ok());
  const Eigen::Isometry3d P = test::YawOffset(133.0, 9.0, -14.0, 0.2);
  const std::vector<PointXYZI> source = test::Transformed(pair.source.points, P.inverse());
  const Eigen::Isometry3d truth = pair.T_target_source * P;
  SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  // An impossible keypoint gate makes the feature stage fail before matching.
  params.gates.min_keypoints = 1000000;
  struct Recorder : RegistrationStageObserver {
    int global_runs = 0;
    void OnStageBegin(RegistrationStage s) override { global_runs += s == RegistrationStage::kGlobalSearch; }
    void OnStageEnd(RegistrationStage) override {}
  } recorder;
  SubmapRegistration reg;
  // Default peak-ratio gate: this repetitive street's best peak is not distinct enough, nothing is verified.
  auto gated = reg.Register({source, {}}, {pair.target.points, {}}, params, &recorder);
  REQUIRE(gated.ok());
  CHECK(recorder.global_runs == 1);
  CHECK(gated->global_peak_ratio > 1.0);
  REQUIRE(gated->global_peak_ratio < params.global_search.min_peak_ratio);
  CHECK(gated->global_candidates == 0);
  CHECK(gated->verdict == RegistrationVerdict::kTooFewKeypoints);

  // Gate at the pair's ratio: the best candidate goes through GICP and the gates and is the truth.
  params.global_search.min_peak_ratio = gated->global_peak_ratio;
  auto r = reg.Register({source, {}}, {pair.target.points, {}}, params, &recorder);
  REQUIRE(r.ok());
  CHECK(recorder.global_runs == 2);
  CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
  REQUIRE(r->success());
  CHECK(r->from_global_search);
  CHECK(r->global_candidates == 1);
  CHECK(test::TranslationErrorM(truth, r->T_target_source) < 0.2);
  CHECK(test::RotationErrorDeg(truth, r->T_target_source) < 1.0);

  // Disabled: the feature stage's verdict stands.
  params.global_search.enabled = false;
  auto off = reg.Register({source, {}}, {pair.target.points, {}}, params);
  REQUIRE(off.ok());
  CHECK(off->verdict == RegistrationVerdict::kTooFewKeypoints);
  CHECK(off->global_candidates == 0);
  CHECK_FALSE(off->from_global_search);
}

TEST_CASE("Global search: ground-only or empty input gives no candidate and no registration") {
  std::vector<PointXYZI> ground;
  for (int i = -30; i <= 30; ++i)
    for (int j = -30; j <= 30; ++j) ground.push_back({static_cast<float>(i), static_cast<float>(j), -1.7f, 0.0f});
  BevSearch bev;
  std::vector<BevCandidate> candidates(3);
  const BevSearchParams params;
  REQUIRE(bev.Search(ground, ground, params, &candidates).ok());
  CHECK(candidates.empty());
  REQUIRE(bev.Search({}, ground, params, &candidates).ok());
  CHECK(candidates.empty());
  auto r = SubmapRegistration().Register({ground, {}}, {ground, {}}, MakeSubmapRegistrationParams(1.0));
  REQUIRE(r.ok());
  CHECK_FALSE(r->success());
}

TEST_CASE("Global search parameters are validated with the field's name") {
  BevSearch bev;
  std::vector<BevCandidate> c;
  // Each case breaks one field of the defaults; the error must name it.
  auto check = [&](const char* field, void (*breaks)(BevSearchParams*)) {
    BevSearchParams p;
    breaks(&p);
    const Status s = bev.Search({}, {}, p, &c);
    CHECK_FALSE(s.ok());
    CHECK(s.message().find(field) != std::string::npos);
  };
  check("grid_cells", [](BevSearchParams* p) { p->grid_cells = 100; });
  check("yaw_steps", [](BevSearchParams* p) { p->yaw_steps = 7; });
  check("cell_size_m", [](BevSearchParams* p) { p->cell_size_m = 0.0; });
  check("free_cell_weight", [](BevSearchParams* p) { p->free_cell_weight = 2.0; });
  check("max_candidates", [](BevSearchParams* p) { p->max_candidates = 0; });
  check("min_peak_ratio", [](BevSearchParams* p) { p->min_peak_ratio = 0.5; });
  SubmapRegistrationParams rp = MakeSubmapRegistrationParams(1.0);
  rp.global_search.grid_cells = 3;
  CHECK_FALSE(ValidateSubmapRegistrationParams(rp).ok());
}

}  // namespace commerge
