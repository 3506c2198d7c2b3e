// SPDX-License-Identifier: BSD-3-Clause
// commerge: the SOLiD place descriptor (Kim et al., "Narrowing your FOV with SOLiD", RA-L 2024) exactly as
// specified in shared/spec/SOLID.md §1-§3: R-SOLiD (range rings, yaw-invariant, used for place recognition)
// and A-SOLiD (azimuth sectors, shifts with yaw, used for the optional yaw estimate), both weighted by the
// min-max-normalised elevation histogram.
//
// Per point (double precision): 3-D range filter min_range_m < |p| < max_range_m (compared as squares);
// with min_z_m set (our extension, off by default), points with z < min_z_m are skipped and counted;
// x == 0 -> 0.001, y == 0 -> 0.001; rho = sqrt(x^2 + y^2); theta = atan2(y, x) in [0, 360) deg;
// phi = atan2(z, rho) deg; ring = min(floor(rho / (L / N_r)), N_r - 1); sector = min(floor(theta /
// (360 / N_a)), N_a - 1); elevation bin = min(floor((phi - f_d) / ((f_u - f_d) / N_e)), N_e - 1) for
// f_d <= phi <= f_u, points outside the vertical FOV are skipped and counted (production policy).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/place_descriptor.hpp"
#include "core/descriptor/sensor_presets.hpp"

namespace commerge {

/// What happens to a point whose elevation lies outside [fov_down_deg, fov_up_deg].
enum class OutOfFovPolicy {
  /// Production (SOLID.md §1.3): the point is counted in num_below_fov / num_above_fov and skipped.
  kSkip,
  /// TEST-ONLY parity with the reference code (SOLID.md §5.2): bin = trunc((phi - f_d) / delta_e) clamped to
  /// <= N_e - 1, the point is skipped only when that value is negative (phi <= f_d - delta_e). Points above
  /// the FOV land in the top bin, points less than one bin below it in bin 0. Apps never select it.
  /// num_below_fov / num_above_fov still count every point outside the nominal FOV.
  kReferenceClamp,
};

/// Why a descriptor is invalid (SolidResult::valid == false).
enum class SolidInvalidReason : std::uint8_t {
  kNone = 0,                ///< valid
  kNoPointsCounted,         ///< empty scan, only non-finite / out-of-range / out-of-FOV points
  kSingleElevationBin,      ///< all counted points in one elevation bin (includes a single point, N_e = 1)
  kFlatElevationHistogram,  ///< max n_h == min n_h: the min-max weights are undefined (0 / 0)
  kZeroNorm,                ///< ||R||_2 == 0
};

/// "valid", "no points counted", "single elevation bin", "flat elevation histogram", "zero norm".
const char* SolidInvalidReasonName(SolidInvalidReason reason) noexcept;

/// One SOLiD computation: R-SOLiD (first num_rings entries of r), A-SOLiD (first num_sectors entries of a),
/// validity and the point counters (DescriptorInfo). Not normalised: the scale grows with the point count.
/// When invalid, r and a are all zeros (never NaN).
struct SolidResult : DescriptorInfo {
  int num_rings = 0;
  int num_sectors = 0;
  SolidInvalidReason invalid_reason = SolidInvalidReason::kNoPointsCounted;
  std::array<double, kSolidMaxRings> r{};    ///< R-SOLiD: weighted point count per range ring (yaw-invariant)
  std::array<double, kSolidMaxSectors> a{};  ///< A-SOLiD: weighted point count per azimuth sector

  /// The num_rings R-SOLiD values.
  Span<const double> rsolid() const noexcept { return {r.data(), static_cast<std::size_t>(num_rings)}; }
  /// The num_sectors A-SOLiD values.
  Span<const double> asolid() const noexcept { return {a.data(), static_cast<std::size_t>(num_sectors)}; }
};

/// Share of the in-range finite points that fell outside the vertical FOV:
/// (num_below_fov + num_above_fov) / (num_points_in - num_nonfinite - num_out_of_range - num_below_min_z);
/// 0 when none.
double OutOfFovFraction(const DescriptorInfo& info) noexcept;

/// Suggested warning threshold for OutOfFovFraction (SOLID.md §1.5): 10 % also catches a swapped FOV.
constexpr double kSolidOutOfFovWarnFraction = 0.10;

/// True when OutOfFovFraction(info) > max_fraction: the FOV preset probably does not fit the sensor.
bool SolidFovWarning(const DescriptorInfo& info, double max_fraction = kSolidOutOfFovWarnFraction) noexcept;

/// The REC (N_r x N_e) and AEC (N_a x N_e) counters plus the elevation histogram. Sized once for the
/// parameters (Reserve or the constructor); ComputeSolid only grows it when the parameters need more, so
/// repeated calls with the same parameters do not allocate. Not thread-safe: one per thread.
class SolidWorkspace {
 public:
  SolidWorkspace() = default;
  /// Reserves the counters for `params` (assumed valid; invalid counts reserve nothing).
  explicit SolidWorkspace(const SolidParams& params) { Reserve(params); }
  void Reserve(const SolidParams& params);
  /// Bytes currently held (grows to fit the largest parameter set seen, never shrinks).
  std::size_t capacity_bytes() const noexcept;

 private:
  friend struct SolidKernel;
  std::vector<std::uint32_t> rec_;   // [ring][elevation]
  std::vector<std::uint32_t> aec_;   // [sector][elevation]
  std::vector<std::uint32_t> hist_;  // n_h
  std::vector<double> weights_;      // w_h
};

/// Computes SOLiD of one raw (not voxelised) scan in the sensor frame into *out (x, y, z; intensity unused).
/// Errors (invalid argument; *out untouched): params invalid (ValidateSolidParams), null workspace or out,
/// more than 2^32 - 1 points. A degenerate scan is not an error: out->valid == false with the reason.
Status ComputeSolid(Span<const PointXYZI> scan, const SolidParams& params, SolidWorkspace* workspace,
                    SolidResult* out, OutOfFovPolicy policy = OutOfFovPolicy::kSkip);

/// Same on double-precision points given as x, y, z triples (xyz.size() must be a multiple of 3); for
/// bit-exact parity with reference vectors stored as float64.
Status ComputeSolidXyz(Span<const double> xyz, const SolidParams& params, SolidWorkspace* workspace,
                       SolidResult* out, OutOfFovPolicy policy = OutOfFovPolicy::kSkip);

/// Writes R / ||R||_2 as float into `out` (size num_rings); all zeros when the result is invalid.
/// Error (invalid argument) only for a wrong `out` size.
Status UnitNormalizeRSolid(const SolidResult& result, Span<float> out);

/// Largest SOLiD distance (orthogonal non-negative unit vectors); also returned for unusable inputs.
constexpr double kSolidMaxDistance = 1.4142135623730951;

/// Cosine similarity a.b / (|a| |b|) accumulated in double; 0 when a size differs, a vector is empty or zero.
double SolidCosineSimilarity(Span<const double> a, Span<const double> b) noexcept;
double SolidCosineSimilarity(Span<const float> a, Span<const float> b) noexcept;

/// SOLID.md §2.1 distance of two R-SOLiD descriptors: d = sqrt(max(0, 2 - 2 cos)), which is the L2 distance
/// of the unit vectors (the paper's f_sim; thresholds 0.10 / 0.05 / 0.01). The cosine re-normalises in
/// double, so float-rounded unit vectors do not bias d. Near d = 0 the form cancels (error up to ~1.5e-8).
/// Returns kSolidMaxDistance when the sizes differ or a vector is empty or zero.
double SolidDistance(Span<const double> a, Span<const double> b) noexcept;
double SolidDistance(Span<const float> a, Span<const float> b) noexcept;

/// Yaw of the query relative to the candidate from A-SOLiD (SOLID.md §3).
struct SolidYawEstimate {
  int shift = 0;         ///< s* in [0, N_a): argmin_s sum_a |A_q[a] - A_c[(a + s) mod N_a]| (first minimum)
  double yaw_rad = 0.0;  ///< psi = s* x 360 / N_a deg, wrapped to (-pi, pi]; T_candidate_query = R_z(+psi)
  double l1_cost = 0.0;  ///< the minimal L1 cost (unnormalised A-SOLiD)
};

/// A-SOLiD yaw search over all N_a shifts (resolution 360 / N_a deg, no sub-bin refinement). Convention:
/// a query yawed by +psi relative to the candidate (p_q = R_z(-psi) p_c) gives yaw_rad = +psi.
/// Errors (invalid argument): sizes differ, empty, more than kSolidMaxSectors, non-finite values.
Result<SolidYawEstimate> EstimateSolidYaw(Span<const double> a_query, Span<const double> a_candidate);
/// Same on two results; also an error when either is invalid.
Result<SolidYawEstimate> EstimateSolidYaw(const SolidResult& query, const SolidResult& candidate);

/// SOLiD as a PlaceDescriptor: Compute() writes the unit-normalised R-SOLiD (num_rings floats, 40 with the
/// presets) with the production skip policy; Distance() is SolidDistance. The full last result (R, A,
/// counters) stays available for the yaw estimate. Owns its workspace: no allocation after construction.
class SolidDescriptor final : public PlaceDescriptor {
 public:
  /// The HDL-64E (KITTI) preset.
  SolidDescriptor();
  /// Validated construction (ValidateSolidParams).
  static Result<SolidDescriptor> Create(const SolidParams& params);

  DescriptorKind kind() const noexcept override { return DescriptorKind::kSolid; }
  std::size_t dimension() const noexcept override { return static_cast<std::size_t>(params_.num_rings); }
  std::uint32_t parameter_id() const noexcept override { return parameter_id_; }
  /// Error only for out.size() != dimension() or more than 2^32 - 1 points. Invalid scan: out all zeros,
  /// info.valid == false (see last_result().invalid_reason).
  Result<DescriptorInfo> Compute(Span<const PointXYZI> scan, Span<float> out) override;
  double Distance(Span<const float> a, Span<const float> b) const override { return SolidDistance(a, b); }

  /// R, A and counters of the last Compute().
  const SolidResult& last_result() const noexcept { return last_; }
  const SolidParams& params() const noexcept { return params_; }
  /// Bytes held by the workspace (constant after construction for a given parameter set).
  std::size_t workspace_capacity_bytes() const noexcept { return workspace_.capacity_bytes(); }

 private:
  explicit SolidDescriptor(const SolidParams& params);

  SolidParams params_;
  std::uint32_t parameter_id_ = 0;
  SolidWorkspace workspace_;
  SolidResult last_;
};

}  // namespace commerge
