// SPDX-License-Identifier: BSD-3-Clause
// Scan Context affinity tiles (core/exchange/scan_context_affinity.hpp) against the brute-force MatchScanContext:
// exact mode cell by cell (random grids with empty columns and negative cells, ray-cast street scans), whole-sector
// yaw at distance ~0, sector-key mode never below exact and equal on turned / noisy copies, its agreement with
// exact on realistic sets (ray-cast streets; KITTI scans when the shared data is present), invalid keyframes,
// position independence, errors, and stage A end to end on two Scan Context sequences of one path.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/descriptor/scan_context.hpp"
#include "core/exchange/scan_context_affinity.hpp"
#include "core/exchange/sequential_matching.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "platform/io/kitti_bin.hpp"
#include "tests/core/exchange/affinity_tiles_check.hpp"
#include "tests/support/scan_context_scans.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace {
namespace sc_affinity_test {  // unity builds compile this file with test_affinity.cpp's helpers

constexpr int kRings = 20, kSectors = 60;
constexpr std::size_t kDim = static_cast<std::size_t>(kRings) * kSectors;
// Exact mode against the double brute force: float products of column-normalised values summed over
// N_r x N_s <= 1200 terms (|terms| <= 1, relative rounding 2^-24 per operation, partly cancelling) and divided
// by |C_s|: a few 1e-7 in practice; 1e-5 leaves a margin without hiding a wrong shift or column set (those move
// the distance by >= 1e-3 on these grids).
constexpr double kExactTol = 1e-5;

ScanContextAffinityParams Params(ScanContextAffinityMode mode, int rings = kRings, int sectors = kSectors) {
  ScanContextAffinityParams p;
  p.num_rings = rings;
  p.num_sectors = sectors;
  p.mode = mode;
  return p;
}

// count random Scan Contexts: heights in [0, 12] m with ~30 % empty cells, some empty columns, a few negative cells.
std::vector<float> RandomScanContexts(std::size_t count, int rings, int sectors, std::uint32_t seed,
                                      bool negative_cells) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const std::size_t dim = static_cast<std::size_t>(rings) * static_cast<std::size_t>(sectors);
  std::vector<float> v(count * dim, 0.0f);
  for (std::size_t k = 0; k < count; ++k) {
    for (int c = 0; c < sectors; ++c) {
      if (u(rng) < 0.15f) continue;  // empty column
      for (int r = 0; r < rings; ++r) {
        const float x = u(rng);
        float cell = x < 0.3f ? 0.0f : 12.0f * u(rng);
        if (negative_cells && x > 0.98f) cell = -0.5f * u(rng) - 0.01f;
        v[k * dim + static_cast<std::size_t>(r * sectors + c)] = cell;
      }
    }
  }
  return v;
}

using test::RayCastScanContext;

void Append(std::vector<float>* set, const std::vector<float>& sc) { set->insert(set->end(), sc.begin(), sc.end()); }

// The Scan Context turned by `shift` whole sectors: column c of the result is column (c + shift) of `sc`.
std::vector<float> RollColumns(const std::vector<float>& sc, int rings, int sectors, int shift) {
  std::vector<float> out(sc.size());
  for (int r = 0; r < rings; ++r) {
    for (int c = 0; c < sectors; ++c) {
      out[static_cast<std::size_t>(r * sectors + c)] = sc[static_cast<std::size_t>(r * sectors + (c + shift) % sectors)];
    }
  }
  return out;
}

// Every cell of the source in one tile.
std::vector<float> WholeMatrix(ScanContextTileSource& src, std::size_t tile = 64) {
  const std::size_t n = src.num_rows(), m = src.num_cols();
  std::vector<float> out(n * m);
  const Status s = ForEachAffinityTile(src, tile, tile, [&](const AffinityTile& t) {
    for (std::size_t r = 0; r < t.rows; ++r) {
      for (std::size_t c = 0; c < t.cols; ++c) out[(t.row_begin + r) * m + t.col_begin + c] = t.at(r, c);
    }
    return Status::Ok();
  });
  REQUIRE(s.ok());
  return out;
}

ScanContextTileSource MakeSource(const DescriptorSetView& a, const DescriptorSetView& b,
                                 const ScanContextAffinityParams& p, std::size_t tile = 64) {
  auto src = ScanContextTileSource::Create(a, b, p, tile, tile);
  REQUIRE_MESSAGE(src.ok(), src.status().ToString());
  return std::move(src.value());
}

// Exact-mode cells against MatchScanContext; returns the largest difference. An all-zero Scan Context is invalid
// (+inf; MatchScanContext gives 1 for it).
double CheckExactAgainstBruteForce(const std::vector<float>& va, const std::vector<float>& vb, int rings, int sectors,
                                   std::size_t tile) {
  const std::size_t dim = static_cast<std::size_t>(rings) * static_cast<std::size_t>(sectors);
  const DescriptorSetView a{va, dim, {}}, b{vb, dim, {}};
  auto src = ScanContextTileSource::Create(a, b, Params(ScanContextAffinityMode::kExact, rings, sectors), tile, tile);
  REQUIRE(src.ok());
  const auto all_zero = [dim](const std::vector<float>& v, std::size_t k) {
    return std::all_of(v.begin() + static_cast<std::ptrdiff_t>(k * dim),
                       v.begin() + static_cast<std::ptrdiff_t>((k + 1) * dim), [](float x) { return x == 0.0f; });
  };
  double max_err = 0.0;
  std::size_t valid_pairs = 0;
  bool inf_mismatch = false;
  const Status s = ForEachAffinityTile(*src, tile, tile, [&](const AffinityTile& t) {
    for (std::size_t r = 0; r < t.rows; ++r) {
      for (std::size_t c = 0; c < t.cols; ++c) {
        const std::size_t i = t.row_begin + r, j = t.col_begin + c;
        if (all_zero(va, i) || all_zero(vb, j)) {
          inf_mismatch = inf_mismatch || !std::isinf(t.at(r, c));
          continue;
        }
        ++valid_pairs;
        const double ref = MatchScanContext(Span<const float>(va.data() + i * dim, dim),
                                            Span<const float>(vb.data() + j * dim, dim), rings, sectors)
                               .distance;
        max_err = std::max(max_err, std::fabs(static_cast<double>(t.at(r, c)) - ref));
      }
    }
    return Status::Ok();
  });
  REQUIRE(s.ok());
  CHECK_FALSE(inf_mismatch);
  CHECK(valid_pairs > 0);
  CHECK(src->shifts_evaluated() == valid_pairs * static_cast<std::size_t>(sectors));
  return max_err;
}

const BoxScene& Street() {
  static const BoxScene scene = MakeStreetScene(11);
  return scene;
}

TEST_CASE("Scan Context affinity exact mode equals MatchScanContext on random grids with empty and negative cells") {
  struct Grid {
    int rings, sectors;
    std::size_t tile;
  };
  for (const Grid g : {Grid{20, 60, 7}, Grid{20, 60, 64}, Grid{3, 8, 5}, Grid{7, 36, 16}, Grid{1, 1, 3}}) {
    CAPTURE(g.rings);
    CAPTURE(g.sectors);
    const std::vector<float> va = RandomScanContexts(23, g.rings, g.sectors, 1, true);
    const std::vector<float> vb = RandomScanContexts(17, g.rings, g.sectors, 2, true);
    const double err = CheckExactAgainstBruteForce(va, vb, g.rings, g.sectors, g.tile);
    MESSAGE("exact vs MatchScanContext, random " << g.rings << " x " << g.sectors << ": max |diff| " << err);
    CHECK(err < kExactTol);
  }
}

TEST_CASE("Scan Context affinity exact mode equals MatchScanContext on ray-cast street scans") {
  std::vector<float> va, vb;
  for (int k = 0; k < 12; ++k) Append(&va, RayCastScanContext(Street(), -60.0f + 10.0f * k, 0.0f, 0.0f, 1));
  for (int k = 0; k < 9; ++k) Append(&vb, RayCastScanContext(Street(), -55.0f + 13.0f * k, 1.0f, 0.4f * k, 2));
  const double err = CheckExactAgainstBruteForce(va, vb, kRings, kSectors, 5);
  MESSAGE("exact vs MatchScanContext, street scans: max |diff| " << err);
  CHECK(err < kExactTol);
}

TEST_CASE("Scan Context affinity: a scan turned by whole sectors matches itself at distance ~0 in both modes") {
  const std::vector<float> base = RayCastScanContext(Street(), -20.0f, 0.5f, 0.0f, 3);
  std::vector<float> va, vb;
  Append(&va, base);
  // Turned grids (exact copies with rolled columns) and ray-cast scans from a sensor turned by k x 6 deg.
  const int shifts[] = {0, 1, 5, 17, 30, 59};
  for (const int s : shifts) Append(&vb, RollColumns(base, kRings, kSectors, s));
  for (const int s : shifts) {
    Append(&vb, RayCastScanContext(Street(), -20.0f, 0.5f, static_cast<float>(s) * 6.0f * 3.14159265358979f / 180.0f, 3));
  }
  for (const auto mode : {ScanContextAffinityMode::kExact, ScanContextAffinityMode::kSectorKeyShift}) {
    const std::string mode_name = ScanContextAffinityModeName(mode);
    CAPTURE(mode_name);
    ScanContextTileSource src = MakeSource({va, kDim, {}}, {vb, kDim, {}}, Params(mode));
    const std::vector<float> d = WholeMatrix(src);
    for (std::size_t k = 0; k < 6; ++k) CHECK(d[k] < 1e-6f);  // rolled grids: the same columns
    for (std::size_t k = 6; k < 12; ++k) {
      // Ray cast from a turned sensor: points near sector borders may change sector (float rotation of rays).
      const double ref = MatchScanContext(Span<const float>(base), Span<const float>(vb.data() + k * kDim, kDim),
                                          kRings, kSectors)
                             .distance;
      CHECK(d[k] < 0.05f);
      CHECK(std::fabs(static_cast<double>(d[k]) - ref) < kExactTol);
    }
  }
}

// Sector-key cells never below exact ones (bitwise >=, one d_s function); returns the fraction of equal cells
// and the largest difference over the valid cells; *near_equal: the fraction equal among pairs with exact < 0.3.
struct Agreement {
  double equal_fraction = 0.0, max_diff = 0.0, near_equal_fraction = 1.0;
  std::size_t cells = 0, near_cells = 0;
};
Agreement CompareModes(const std::vector<float>& va, const std::vector<float>& vb, int candidates = 2, int window = 3) {
  const DescriptorSetView a{va, kDim, {}}, b{vb, kDim, {}};
  ScanContextTileSource exact = MakeSource(a, b, Params(ScanContextAffinityMode::kExact));
  ScanContextAffinityParams kp = Params(ScanContextAffinityMode::kSectorKeyShift);
  kp.num_candidate_shifts = candidates;
  kp.shift_window_sectors = window;
  ScanContextTileSource key = MakeSource(a, b, kp);
  const std::vector<float> de = WholeMatrix(exact), dk = WholeMatrix(key);
  Agreement ag;
  std::size_t equal = 0, near = 0, near_equal = 0;
  bool never_below = true;
  for (std::size_t k = 0; k < de.size(); ++k) {
    if (std::isinf(de[k])) continue;
    ++ag.cells;
    never_below = never_below && dk[k] >= de[k];
    equal += dk[k] == de[k];
    ag.max_diff = std::max(ag.max_diff, static_cast<double>(dk[k] - de[k]));
    if (de[k] < 0.3f) {
      ++near;
      near_equal += dk[k] == de[k];
    }
  }
  CHECK(never_below);
  ag.equal_fraction = static_cast<double>(equal) / static_cast<double>(std::max<std::size_t>(ag.cells, 1));
  ag.near_cells = near;
  if (near > 0) ag.near_equal_fraction = static_cast<double>(near_equal) / static_cast<double>(near);
  CHECK(key.shifts_evaluated() < exact.shifts_evaluated() / 3);
  return ag;
}

TEST_CASE("Scan Context affinity sector-key mode is never below exact and equals it on turned noisy copies") {
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.05f);
  std::uniform_int_distribution<int> any_shift(0, kSectors - 1);
  std::vector<float> va, vb;
  for (int k = 0; k < 10; ++k) {
    const std::vector<float> sc = RayCastScanContext(Street(), -70.0f + 15.0f * k, 0.0f, 0.0f, 5);
    Append(&va, sc);
    std::vector<float> copy = RollColumns(sc, kRings, kSectors, any_shift(rng));
    for (float& v : copy) {
      if (v != 0.0f) v = std::max(0.01f, v + noise(rng));  // noisy heights, same occupancy
    }
    Append(&vb, copy);
  }
  const DescriptorSetView a{va, kDim, {}}, b{vb, kDim, {}};
  ScanContextTileSource exact = MakeSource(a, b, Params(ScanContextAffinityMode::kExact));
  ScanContextTileSource key = MakeSource(a, b, Params(ScanContextAffinityMode::kSectorKeyShift));
  const std::vector<float> de = WholeMatrix(exact), dk = WholeMatrix(key);
  for (std::size_t k = 0; k < 10; ++k) {
    CHECK(dk[k * 10 + k] == de[k * 10 + k]);  // the turned copy: the key finds the shift, the value is exact
    CHECK(de[k * 10 + k] < 0.05f);
  }
  for (std::size_t k = 0; k < de.size(); ++k) CHECK(dk[k] >= de[k]);
  const Agreement ag = CompareModes(va, vb);
  MESSAGE("turned noisy copies: sector-key equal to exact in " << 100.0 * ag.equal_fraction << " % of " << ag.cells
                                                               << " cells, max difference " << ag.max_diff);
}

// Sector-key vs exact on scans of many places, positions and headings of the street (a realistic spread of
// near and far pairs). Bound: every pair of nearby places (exact < 0.3, where stage A decides) equal, >= 80 % of
// all cells equal, no cell more than 0.35 above exact (a missed shift costs at most the gap between the exact best
// d_s and the best d_s in the key's windows).
TEST_CASE("Scan Context affinity sector-key agreement with exact on ray-cast street scans") {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> yaw(-3.14159f, 3.14159f), lateral(-1.5f, 1.5f);
  std::vector<float> va, vb;
  for (int k = 0; k < 30; ++k) Append(&va, RayCastScanContext(Street(), -80.0f + 5.5f * k, lateral(rng), yaw(rng), 10u + k));
  for (int k = 0; k < 30; ++k) Append(&vb, RayCastScanContext(Street(), -78.0f + 5.5f * k, lateral(rng), yaw(rng), 50u + k));
  const Agreement ag = CompareModes(va, vb);
  MESSAGE("street scans: sector-key equal to exact in " << 100.0 * ag.equal_fraction << " % of " << ag.cells
                                                        << " cells (" << 100.0 * ag.near_equal_fraction << " % of "
                                                        << ag.near_cells << " near pairs), max difference "
                                                        << ag.max_diff);
  for (const int cand : {1, 3}) {
    const Agreement other = CompareModes(va, vb, cand, 3);
    MESSAGE("  with " << cand << " candidate shift(s): equal in " << 100.0 * other.equal_fraction << " %, near pairs "
                      << 100.0 * other.near_equal_fraction << " %, max difference " << other.max_diff);
  }
  CHECK(ag.near_cells > 20);
  CHECK(ag.near_equal_fraction >= 0.99);
  CHECK(ag.equal_fraction >= 0.80);
  CHECK(ag.max_diff < 0.35);
}

TEST_CASE("Scan Context affinity sector-key agreement with exact on KITTI scans") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/kitti00_frames0-15");
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> yaw(-3.14159, 3.14159);
  std::vector<float> va, vb;
  ScanContextParams scp;
  scp.lidar_height_m = 1.73;  // KITTI's Velodyne height above the road
  for (int f = 0; f < 16; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "/velodyne/%06d.bin", f);
    auto scan = platform::ReadKittiBin(dir + name);
    REQUIRE(scan.ok());
    for (int copy = 0; copy < 2; ++copy) {  // alpha: as recorded and turned; beta: turned twice more
      std::vector<PointXYZI> pts = scan->points;
      const double psi = copy == 0 && f % 2 == 0 ? 0.0 : yaw(rng);
      const double c = std::cos(psi), s = std::sin(psi);
      for (PointXYZI& p : pts) {
        const double x = static_cast<double>(p.x), y = static_cast<double>(p.y);
        p.x = static_cast<float>(c * x + s * y);
        p.y = static_cast<float>(-s * x + c * y);
      }
      std::vector<float> sc(kDim);
      const auto info = ComputeScanContext(pts, scp, sc);
      REQUIRE(info.ok());
      REQUIRE(info->valid);
      Append(copy == 0 ? &va : &vb, sc);
    }
  }
  const Agreement ag = CompareModes(va, vb);
  MESSAGE("KITTI 00 frames 0-15 (turned copies): sector-key equal to exact in "
          << 100.0 * ag.equal_fraction << " % of " << ag.cells << " cells (" << 100.0 * ag.near_equal_fraction
          << " % of " << ag.near_cells << " near pairs), max difference " << ag.max_diff);
  CHECK(ag.near_equal_fraction >= 0.95);
  CHECK(ag.equal_fraction >= 0.80);
  CHECK(ag.max_diff < 0.35);
}

TEST_CASE("Scan Context affinity: invalid keyframes (flag 0, NaN, inf, all zero) are infinitely far") {
  std::vector<float> va = RandomScanContexts(4, kRings, kSectors, 3, false);
  std::vector<float> vb = RandomScanContexts(4, kRings, kSectors, 4, false);
  va[1 * kDim + 100] = std::numeric_limits<float>::quiet_NaN();    // alpha 1: NaN
  std::fill(va.begin() + 3 * kDim, va.begin() + 4 * kDim, 0.0f);   // alpha 3: all zero
  vb[0 * kDim + 5] = std::numeric_limits<float>::infinity();      // beta 0: inf
  const std::vector<std::uint8_t> flags_b = {1, 1, 0, 1};           // beta 2: flagged invalid
  for (const auto mode : {ScanContextAffinityMode::kExact, ScanContextAffinityMode::kSectorKeyShift}) {
    ScanContextTileSource src = MakeSource({va, kDim, {}}, {vb, kDim, flags_b}, Params(mode), 3);
    CHECK(src.alpha_valid(0));
    CHECK_FALSE(src.alpha_valid(1));
    CHECK(src.alpha_valid(2));
    CHECK_FALSE(src.alpha_valid(3));
    CHECK_FALSE(src.beta_valid(0));
    CHECK(src.beta_valid(1));
    CHECK_FALSE(src.beta_valid(2));
    CHECK(src.beta_valid(3));
    const std::vector<float> d = WholeMatrix(src, 3);
    for (std::size_t i = 0; i < 4; ++i) {
      for (std::size_t j = 0; j < 4; ++j) {
        const bool valid = (i == 0 || i == 2) && (j == 1 || j == 3);
        CHECK(std::isinf(d[i * 4 + j]) == !valid);
        if (valid) {
          CHECK(d[i * 4 + j] >= 0.0f);
          CHECK(d[i * 4 + j] <= 1.0f);
        }
      }
    }
    AffinityTile t;
    REQUIRE(src.ComputeTile(1, 0, 3, 1, &t).ok());  // alpha 1..3 x beta 0: all invalid
    CHECK(std::isinf(t.min_distance));
  }
}

TEST_CASE("Scan Context affinity values are position independent and tiles report their minimum") {
  const std::size_t n = 37, m = 29;
  std::vector<float> va = RandomScanContexts(n, kRings, kSectors, 8, true);
  std::vector<float> vb = RandomScanContexts(m, kRings, kSectors, 9, true);
  std::copy(va.begin() + 5 * kDim, va.begin() + 6 * kDim, vb.begin() + 3 * kDim);  // one exact pair
  vb[10 * kDim + 4] = std::numeric_limits<float>::quiet_NaN();                    // one invalid column
  for (const auto mode : {ScanContextAffinityMode::kExact, ScanContextAffinityMode::kSectorKeyShift}) {
    const std::string mode_name = ScanContextAffinityModeName(mode);
    CAPTURE(mode_name);
    const DescriptorSetView a{va, kDim, {}}, b{vb, kDim, {}};
    auto whole_src = ScanContextTileSource::Create(a, b, Params(mode), n, m);
    REQUIRE(whole_src.ok());
    AffinityTile whole_tile;
    REQUIRE(whole_src->ComputeTile(0, 0, n, m, &whole_tile).ok());
    const std::vector<float> whole(whole_tile.distances, whole_tile.distances + n * m);
    CHECK(whole[5 * m + 3] < 1e-6f);
    CHECK(std::isinf(whole[7 * m + 10]));
    ScanContextTileSource src = MakeSource(a, b, Params(mode), 16);
    std::mt19937 rng(4);
    const std::uint64_t cells = test::CheckRandomTiles(src, whole, n, m, 16, 60, &rng);
    CHECK(src.cells_computed() == cells);
    CHECK(src.CellDistance(5, 3) == whole[5 * m + 3]);
  }
}

TEST_CASE("Scan Context affinity rejects bad parameters, dims and tiles") {
  const std::vector<float> v(2 * kDim, 1.0f), v40(80, 0.1f);
  const DescriptorSetView good{v, kDim, {}};
  const auto expect = [](const Result<ScanContextTileSource>& r, const char* words) {
    CHECK_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(r.status().message().find(words) != std::string::npos, r.status().message());
  };
  const ScanContextAffinityParams p = Params(ScanContextAffinityMode::kExact);
  expect(ScanContextTileSource::Create({v40, 40, {}}, good, p, 4, 4), "expected num_rings x num_sectors");
  expect(ScanContextTileSource::Create(good, {v40, 40, {}}, p, 4, 4), "beta 40");
  expect(ScanContextTileSource::Create({Span<const float>(v.data(), kDim - 1), kDim, {}}, good, p, 4, 4),
         "not a multiple");
  expect(ScanContextTileSource::Create(good, good, p, 0, 4), "tile capacity");
  ScanContextAffinityParams bad = p;
  bad.num_sectors = 7;
  expect(ScanContextTileSource::Create(good, good, bad, 4, 4), "num_sectors");
  bad = p;
  bad.num_rings = 0;
  expect(ScanContextTileSource::Create(good, good, bad, 4, 4), "num_rings");
  bad = p;
  bad.num_candidate_shifts = 0;
  expect(ScanContextTileSource::Create(good, good, bad, 4, 4), "num_candidate_shifts");
  bad = p;
  bad.shift_window_sectors = 181;
  expect(ScanContextTileSource::Create(good, good, bad, 4, 4), "shift_window_sectors");
  CHECK(ValidateScanContextAffinityParams(ScanContextAffinityParams{}).ok());
  CHECK(ScanContextAffinityParams{}.mode == ScanContextAffinityMode::kSectorKeyShift);

  ScanContextTileSource src = MakeSource(good, good, p, 1);
  AffinityTile t;
  CHECK_FALSE(src.ComputeTile(0, 0, 2, 1, &t).ok());  // above capacity
  CHECK_FALSE(src.ComputeTile(2, 0, 1, 1, &t).ok());  // outside
  CHECK_FALSE(src.ComputeTile(0, 2, 1, 1, &t).ok());  // outside
  CHECK_FALSE(src.ComputeTile(0, 0, 0, 1, &t).ok());  // empty
  CHECK(src.ComputeTile(1, 1, 1, 1, &t).code() == StatusCode::kOk);
  CHECK(t.at(0, 0) < 1e-6f);
  // Empty sets: no tile at all.
  ScanContextTileSource empty = MakeSource({{}, kDim, {}}, good, p, 4);
  int tiles = 0;
  CHECK(ForEachAffinityTile(empty, 4, 4, [&](const AffinityTile&) {
          ++tiles;
          return Status::Ok();
        }).ok());
  CHECK(tiles == 0);
}

// Two robots drive the same 150 m of street (alpha from x = -75 m, beta from x = -74 m in the other lane, 1.5 m
// apart, both every 2.5 m): stage A on the Scan Context affinity finds the diagonal.
TEST_CASE("Stage A on Scan Context affinity tiles finds two robots' shared path") {
  const int n = 60;
  std::vector<float> va, vb;
  for (int k = 0; k < n; ++k) {
    Append(&va, RayCastScanContext(Street(), -75.0f + 2.5f * k, -0.25f, 0.0f, 100u + k));
    Append(&vb, RayCastScanContext(Street(), -74.5f + 2.5f * k, 0.25f, 0.3f, 300u + k));
  }
  SequentialMatchParams sp;
  sp.tau_inter = 0.2;
  sp.tau_area = 400;
  sp.tile_rows = 16;
  sp.tile_cols = 16;
  for (const auto mode : {ScanContextAffinityMode::kExact, ScanContextAffinityMode::kSectorKeyShift}) {
    const std::string mode_name = ScanContextAffinityModeName(mode);
    CAPTURE(mode_name);
    ScanContextTileSource src = MakeSource({va, kDim, {}}, {vb, kDim, {}}, Params(mode), 16);
    const auto r = RunSequentialMatching(src, sp);
    REQUIRE(r.ok());
    REQUIRE_MESSAGE(r->found, r->no_candidate_reason);
    MESSAGE(std::string(ScanContextAffinityModeName(mode)) << ": cluster rows " << r->best.row_min << "-" << r->best.row_max
                                              << ", cols " << r->best.col_min << "-" << r->best.col_max << ", "
                                              << r->cells.size() << " cells, mean " << r->best.mean_distance());
    CHECK(r->best.span_rows() >= static_cast<std::size_t>(n) * 3 / 4);
    std::size_t on_diagonal = 0, near_diagonal = 0;
    for (const SequentialLoopCell& c : r->cells) {
      const std::size_t gap = c.alpha_index >= c.beta_index ? c.alpha_index - c.beta_index : c.beta_index - c.alpha_index;
      on_diagonal += gap == 0;
      near_diagonal += gap <= 2;  // 2 keyframes = 5 m: the scans of neighbouring places look alike
    }
    MESSAGE("  " << on_diagonal << " cells on the diagonal, " << near_diagonal << " within 2 keyframes");
    CHECK(on_diagonal >= static_cast<std::size_t>(n) * 3 / 4);   // most of the true pairs
    CHECK(near_diagonal * 100 >= r->cells.size() * 85);          // few look-alikes of the repetitive street
  }
}

}  // namespace sc_affinity_test
}  // namespace
}  // namespace commerge
