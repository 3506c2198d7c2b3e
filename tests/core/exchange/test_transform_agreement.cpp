// SPDX-License-Identifier: BSD-3-Clause
// Descriptor agreement under a registered transform (core/exchange/transform_agreement.hpp) on two robots whose
// answer is known: beta's map lies in alpha's at yaw 40 deg, t = (12, -7, 0.5) m, and beta drives alpha's keyframes
// 30..89 again (1 m apart on a straight road, then a turn), its descriptors alpha's plus noise. Every entry is
// checked against a brute-force pass over all keyframe pairs; the rank measure under the true transform against
// one shifted 40 m along the road (where beta's keyframes land on keyframes of other places).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/exchange/transform_agreement.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {
namespace {

constexpr std::size_t kDim = 16;
constexpr double kPi = 3.14159265358979323846;

struct Robot {
  std::vector<float> descriptors;
  std::vector<std::uint8_t> valid;
  std::vector<Eigen::Isometry3d> poses;
  KeyframeSetView View() const {
    return {Span<const float>(descriptors), Span<const std::uint8_t>(valid), Span<const Eigen::Isometry3d>(poses)};
  }
};

// Deterministic values in [-1, 1).
struct Lcg {
  std::uint64_t state = 0x9e3779b97f4a7c15ull;
  double Next() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / static_cast<double>(1ull << 53) * 2.0 - 1.0;
  }
};

void Normalise(float* d) {
  double n = 0.0;
  for (std::size_t k = 0; k < kDim; ++k) n += static_cast<double>(d[k]) * static_cast<double>(d[k]);
  for (std::size_t k = 0; k < kDim; ++k) d[k] = static_cast<float>(static_cast<double>(d[k]) / std::sqrt(n));
}

// Alpha: 120 keyframes, 0..79 along x (heading 0), 80..119 along y from (79, 0) (heading 90 deg).
Eigen::Isometry3d AlphaPose(std::size_t i) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (i < 80) {
    T.translation() = Eigen::Vector3d(static_cast<double>(i), 0.0, 0.0);
  } else {
    T.linear() = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(79.0, static_cast<double>(i) - 79.0, 0.0);
  }
  return T;
}

Eigen::Isometry3d TrueAlphaBeta() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(40.0 * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(12.0, -7.0, 0.5);
  return T;
}

struct Fixture {
  Robot alpha, beta;
  Fixture(bool beta_reversed = false) {
    Lcg rng;
    for (std::size_t i = 0; i < 120; ++i) {
      alpha.poses.push_back(AlphaPose(i));
      alpha.valid.push_back(i == 50 ? 0 : 1);  // one keyframe without a descriptor
      for (std::size_t k = 0; k < kDim; ++k) alpha.descriptors.push_back(static_cast<float>(rng.Next()));
      Normalise(&alpha.descriptors[i * kDim]);
    }
    // Beta keyframe j stands at alpha's 30 + j (lateral offset 0.4 m), in its own frame.
    const Eigen::Isometry3d T_beta_alpha = TrueAlphaBeta().inverse();
    for (std::size_t j = 0; j < 60; ++j) {
      Eigen::Isometry3d at = AlphaPose(30 + j);
      at.translation() += Eigen::Vector3d(0.0, 0.4, 0.0);
      if (beta_reversed) at.linear() = at.linear() * Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      beta.poses.push_back(T_beta_alpha * at);
      beta.valid.push_back(j == 7 ? 0 : 1);
      for (std::size_t k = 0; k < kDim; ++k) {
        beta.descriptors.push_back(alpha.descriptors[(30 + j) * kDim + k] + static_cast<float>(0.15 * rng.Next()));
      }
      Normalise(&beta.descriptors[j * kDim]);
    }
  }
};

float Distance(const float* a, const float* b) {
  float dot = 0.0f;
  for (std::size_t k = 0; k < kDim; ++k) dot += a[k] * b[k];
  return std::sqrt(std::max(0.0f, 2.0f - 2.0f * dot));
}

// Brute force over every pair: the reference for ColocatedKeyframes.
std::vector<ColocatedKeyframe> Reference(const Robot& a, const Robot& b, const Eigen::Isometry3d& T,
                                         const TransformAgreementParams& p) {
  std::vector<ColocatedKeyframe> out;
  std::size_t valid_alpha = 0;
  for (auto v : a.valid) valid_alpha += v;
  for (std::size_t j = 0; j < b.poses.size(); ++j) {
    if (!b.valid[j]) continue;
    const Eigen::Isometry3d Tj = T * b.poses[j];
    float best = std::numeric_limits<float>::infinity();
    std::uint32_t best_i = 0, candidates = 0;
    for (std::size_t i = 0; i < a.poses.size(); ++i) {
      if (!a.valid[i]) continue;
      if ((a.poses[i].translation() - Tj.translation()).norm() > p.near_m) continue;
      const Eigen::Matrix3d rel = a.poses[i].linear().transpose() * Tj.linear();
      const double heading_deg =
          std::fabs(std::atan2(std::sin(YawRad(rel)), std::cos(YawRad(rel)))) * 180.0 / kPi;
      if (p.max_heading_deg < 180.0 && heading_deg > p.max_heading_deg) continue;
      const float d = Distance(&a.descriptors[i * kDim], &b.descriptors[j * kDim]);
      ++candidates;
      if (d < best) {
        best = d;
        best_i = static_cast<std::uint32_t>(i);
      }
    }
    if (!std::isfinite(best)) continue;
    std::size_t nearer = 0;
    for (std::size_t i = 0; i < a.poses.size(); ++i) {
      if (a.valid[i] && Distance(&a.descriptors[i * kDim], &b.descriptors[j * kDim]) < best) ++nearer;
    }
    const double r = static_cast<double>(nearer) / static_cast<double>(valid_alpha);
    ColocatedKeyframe c{static_cast<std::uint32_t>(j), best_i, best, candidates, static_cast<float>(r), 0.0f};
    c.chance = static_cast<float>(1.0 - std::pow(1.0 - r, candidates));
    out.push_back(c);
  }
  return out;
}

void CheckAgainstReference(const Fixture& f, const Eigen::Isometry3d& T, const TransformAgreementParams& p) {
  auto got = ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, T, p);
  REQUIRE(got.ok());
  const std::vector<ColocatedKeyframe> want = Reference(f.alpha, f.beta, T, p);
  REQUIRE(got->size() == want.size());
  for (std::size_t n = 0; n < want.size(); ++n) {
    CHECK((*got)[n].beta == want[n].beta);
    CHECK((*got)[n].alpha == want[n].alpha);
    CHECK(static_cast<double>((*got)[n].distance) == doctest::Approx(static_cast<double>(want[n].distance)).epsilon(1e-5));
    CHECK((*got)[n].candidates == want[n].candidates);
    CHECK(static_cast<double>((*got)[n].rank_fraction) == doctest::Approx(static_cast<double>(want[n].rank_fraction)));
    CHECK(static_cast<double>((*got)[n].chance) == doctest::Approx(static_cast<double>(want[n].chance)));
  }
}

Eigen::Isometry3d Shifted(double along_x_m) {
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Eigen::Vector3d(along_x_m, 0.0, 0.0);
  return shift * TrueAlphaBeta();
}

}  // namespace

TEST_CASE("Transform agreement: co-located keyframes and ranks equal a brute-force pass over every pair") {
  const Fixture f;
  for (double near_m : {1.0, 3.0, 6.0}) {
    for (double heading : {35.0, 180.0}) {
      TransformAgreementParams p;
      p.near_m = near_m;
      p.max_heading_deg = heading;
      CAPTURE(near_m);
      CAPTURE(heading);
      CheckAgainstReference(f, TrueAlphaBeta(), p);
      CheckAgainstReference(f, Shifted(40.0), p);
      CheckAgainstReference(f, Shifted(-25.5), p);
    }
  }
}

TEST_CASE("Transform agreement: under the true transform the co-located keyframe is the nearest, shifted to "
          "other places no better than chance") {
  const Fixture f;
  const TransformAgreementParams p;
  auto truth = ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, TrueAlphaBeta(), p);
  REQUIRE(truth.ok());
  CHECK(truth->size() == 59);  // every beta keyframe with a descriptor
  std::size_t n = 0;
  CHECK(MedianChance(Span<const ColocatedKeyframe>(*truth), 1, 0, &n) == doctest::Approx(0.0));
  CHECK(n == 59);
  for (const ColocatedKeyframe& c : *truth) {
    if (c.beta != 20) CHECK(c.alpha == 30 + c.beta);  // alpha's keyframe 50 has no descriptor
    CHECK(c.candidates >= 3);                          // 1 m apart, 0.4 m aside, within 3 m
  }
  // Shifted 40 m along the road: the same keyframes sit among descriptors of other places. The best of m
  // random ranks is as good as r with chance 1 - (1 - r)^m, so the median of that is about 0.5.
  auto shifted = ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, Shifted(40.0), p);
  REQUIRE(shifted.ok());
  CHECK(shifted->size() > 10);
  const double chance = MedianChance(Span<const ColocatedKeyframe>(*shifted), 1, 0, &n);
  CHECK(chance > 0.25);
  CHECK(chance < 0.75);
  CHECK(n == shifted->size());
}

TEST_CASE("Transform agreement: a forward-looking heading limit drops keyframes seen the other way round") {
  const Fixture reversed(true);
  TransformAgreementParams p;
  p.max_heading_deg = 35.0;
  auto narrow = ColocatedKeyframes(reversed.alpha.View(), reversed.beta.View(), kDim, TrueAlphaBeta(), p);
  REQUIRE(narrow.ok());
  CHECK(narrow->empty());
  std::size_t n = 7;
  CHECK(MedianChance(Span<const ColocatedKeyframe>(*narrow), 1, 0, &n) == -1.0);
  CHECK(n == 0);
  p.max_heading_deg = 180.0;
  auto any = ColocatedKeyframes(reversed.alpha.View(), reversed.beta.View(), kDim, TrueAlphaBeta(), p);
  REQUIRE(any.ok());
  CHECK(any->size() == 59);
}

TEST_CASE("Transform agreement: the median skips the excluded beta range") {
  std::vector<ColocatedKeyframe> c;
  for (std::uint32_t j = 0; j < 10; ++j) {
    ColocatedKeyframe k;
    k.beta = j;
    k.chance = j < 4 ? 0.0f : 0.5f + 0.01f * static_cast<float>(j);
    c.push_back(k);
  }
  std::size_t n = 0;
  CHECK(MedianChance(Span<const ColocatedKeyframe>(c), 1, 0, &n) == doctest::Approx(0.55));
  CHECK(n == 10);
  CHECK(MedianChance(Span<const ColocatedKeyframe>(c), 4, 9, &n) == doctest::Approx(0.0));
  CHECK(n == 4);
  CHECK(MedianChance(Span<const ColocatedKeyframe>(c), 0, 3, &n) == doctest::Approx(0.57));
  CHECK(n == 6);
}

TEST_CASE("Transform agreement: an excluded beta range is skipped and at most max_ranked keyframes are ranked, "
          "evenly spaced") {
  const Fixture f;
  TransformAgreementParams p;
  const std::vector<ColocatedKeyframe> all = Reference(f.alpha, f.beta, TrueAlphaBeta(), p);
  REQUIRE(all.size() == 59);
  std::size_t total = 0;
  auto outside = ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, TrueAlphaBeta(), p, 10, 29, &total);
  REQUIRE(outside.ok());
  CHECK(total == 39);  // 59 less beta 10..29 (keyframe 7, without a descriptor, is not among them)
  REQUIRE(outside->size() == 39);
  for (const ColocatedKeyframe& c : *outside) CHECK((c.beta < 10 || c.beta > 29));

  p.max_ranked = 10;
  auto ranked = ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, TrueAlphaBeta(), p, 1, 0, &total);
  REQUIRE(ranked.ok());
  CHECK(total == 59);
  REQUIRE(ranked->size() == 10);
  for (std::size_t k = 0; k < 10; ++k) {
    const ColocatedKeyframe& want = all[k * 59 / 10];  // evenly spaced over the 59
    CHECK((*ranked)[k].beta == want.beta);
    CHECK((*ranked)[k].alpha == want.alpha);
    CHECK(static_cast<double>((*ranked)[k].rank_fraction) == doctest::Approx(static_cast<double>(want.rank_fraction)));
    CHECK(static_cast<double>((*ranked)[k].chance) == doctest::Approx(static_cast<double>(want.chance)));
  }
  p.max_ranked = 0;
  CHECK_FALSE(ValidateTransformAgreementParams(p).ok());
}

TEST_CASE("Transform agreement: sizes that disagree, a non-finite transform and bad parameters are errors") {
  Fixture f;
  const TransformAgreementParams p;
  CHECK(ColocatedKeyframes(f.alpha.View(), f.beta.View(), 0, TrueAlphaBeta(), p).status().code() ==
        StatusCode::kInvalidArgument);
  CHECK(ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim + 1, TrueAlphaBeta(), p).status().code() ==
        StatusCode::kInvalidArgument);
  Eigen::Isometry3d bad = TrueAlphaBeta();
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  CHECK(ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, bad, p).status().code() ==
        StatusCode::kInvalidArgument);
  f.beta.poses.pop_back();
  CHECK(ColocatedKeyframes(f.alpha.View(), f.beta.View(), kDim, TrueAlphaBeta(), p).status().code() ==
        StatusCode::kInvalidArgument);
  for (double near : {0.0, -1.0, std::numeric_limits<double>::infinity()}) {
    TransformAgreementParams q;
    q.near_m = near;
    CHECK_FALSE(ValidateTransformAgreementParams(q).ok());
  }
  for (double heading : {0.0, 181.0, std::numeric_limits<double>::quiet_NaN()}) {
    TransformAgreementParams q;
    q.max_heading_deg = heading;
    CHECK_FALSE(ValidateTransformAgreementParams(q).ok());
  }
}

}  // namespace commerge

namespace commerge {
namespace {

// The true transform as a cluster's placement (yaw about the vertical and a translation); `valid` as given.
ClusterPlacement PlacementOf(const Eigen::Isometry3d& T, bool valid = true) {
  ClusterPlacement p;
  p.valid = valid;
  p.yaw_rad = YawRad(T.linear());
  p.t_alpha_beta_m = T.translation();
  return p;
}

}  // namespace

TEST_CASE("Placement agreement: a cluster's placement is ranked like a transform, without the cluster's own "
          "beta keyframes; agreeing counts the ranked chances at most agree_chance") {
  const Fixture f;
  const TransformAgreementParams p;
  SequentialCluster cluster;  // beta keyframes 10..29 were stage A's cluster
  cluster.col_min = 10;
  cluster.col_max = 29;
  const ClusterPlacement truth = PlacementOf(TrueAlphaBeta());
  CHECK(PlacementTransform(truth).isApprox(TrueAlphaBeta(), 1e-12));
  for (const Eigen::Isometry3d& T : {TrueAlphaBeta(), Shifted(40.0)}) {
    const ClusterPlacement placement = PlacementOf(T);
    for (double agree_chance : {0.0, 0.05, 0.5, 1.0}) {
      auto got = MeasurePlacementAgreement(f.alpha.View(), f.beta.View(), kDim, placement, cluster, p, agree_chance);
      REQUIRE(got.ok());
      // The reference: every co-located keyframe outside columns 10..29, brute force.
      std::vector<ColocatedKeyframe> want;
      for (const ColocatedKeyframe& c : Reference(f.alpha, f.beta, T, p)) {
        if (c.beta < 10 || c.beta > 29) want.push_back(c);
      }
      CHECK(got->measured);
      CHECK(got->colocated == want.size());
      CHECK(got->ranked == want.size());
      std::size_t agreeing = 0;
      for (const ColocatedKeyframe& c : want) agreeing += static_cast<double>(c.chance) <= agree_chance ? 1 : 0;
      CHECK(got->agreeing == agreeing);
      CHECK(got->median_chance == doctest::Approx(MedianChance(Span<const ColocatedKeyframe>(want), 1, 0, nullptr)));
    }
  }
  auto truth_agreement = MeasurePlacementAgreement(f.alpha.View(), f.beta.View(), kDim, truth, cluster, p, 0.05);
  REQUIRE(truth_agreement.ok());
  CHECK(truth_agreement->agreeing == 39);  // 59 beta keyframes with descriptors, 20 of them the cluster's
  auto invalid = MeasurePlacementAgreement(f.alpha.View(), f.beta.View(), kDim, PlacementOf(TrueAlphaBeta(), false),
                                           cluster, p, 0.05);
  REQUIRE(invalid.ok());
  CHECK_FALSE(invalid->measured);
  CHECK(invalid->median_chance == -1.0);
  CHECK_FALSE(MeasurePlacementAgreement(f.alpha.View(), f.beta.View(), kDim, truth, cluster, p, 1.5).ok());
  CHECK_FALSE(MeasurePlacementAgreement(f.alpha.View(), f.beta.View(), kDim, truth, cluster, p, std::nan("")).ok());
}


TEST_CASE("AgreementLogOdds: the log ratio of the binomial probabilities of k agreeing of n at a true place and "
          "among strangers") {
  for (double a : {0.01, 0.05, 0.2}) {
    for (double q : {0.25, 0.5, 0.9}) {
      for (std::size_t n : {0, 1, 7, 60, 256}) {
        for (std::size_t k = 0; k <= n; k += (n > 20 ? 13 : 1)) {
          // The reference: the logs of the two probabilities of one sequence of k agreeing and n - k not (the
          // binomial coefficient is common), keyframe by keyframe.
          double log_true = 0.0, log_strangers = 0.0;
          for (std::size_t i = 0; i < n; ++i) {
            log_true += std::log(i < k ? q : 1.0 - q);
            log_strangers += std::log(i < k ? a : 1.0 - a);
          }
          const double want = log_true - log_strangers;
          CHECK(AgreementLogOdds(n, k, a, q) == doctest::Approx(want).epsilon(1e-9));
        }
      }
    }
  }
  CHECK(AgreementLogOdds(0, 0, 0.05, 0.25) == 0.0);
  CHECK(AgreementLogOdds(40, 2, 0.05, 0.25) < 0.0);   // chance's share: strangers
  CHECK(AgreementLogOdds(40, 10, 0.05, 0.25) > 0.0);  // a true place's share
  CHECK(std::isnan(AgreementLogOdds(5, 6, 0.05, 0.25)));   // more agreeing than ranked
  CHECK(std::isnan(AgreementLogOdds(5, 1, 0.25, 0.25)));   // a true place no likelier to agree than strangers
  CHECK(std::isnan(AgreementLogOdds(5, 1, 0.0, 0.25)));
  CHECK(std::isnan(AgreementLogOdds(5, 1, 0.05, 1.0)));
  CHECK(std::isnan(AgreementLogOdds(5, 1, std::nan(""), 0.25)));
}

}  // namespace commerge
