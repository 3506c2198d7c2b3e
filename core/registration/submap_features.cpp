// SPDX-License-Identifier: BSD-3-Clause
// Submap preprocessing (../shared/spec/REGISTRATION.md §1.2 "Pipeline", steps 2-7, §2.1 "Preprocessing"). One capped
// radius search per point gives a sorted neighbour list; its prefix within normal_radius_m gives the normal, its first
// covariance_neighbors entries the GICP covariance, the whole list (within fpfh_radius_m) the descriptor support.
#include "core/registration/submap_features.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "core/geometry/angles.hpp"

#if defined(__SSE__)
#include <xmmintrin.h>
#elif defined(__aarch64__) && defined(__ARM_NEON)
#include <arm_neon.h>
#endif

namespace commerge {
namespace {

inline Eigen::Vector3f PositionF(const PointXYZI& p) { return {p.x, p.y, p.z}; }

// SPFH rows are padded to a multiple of 4 floats so that the weighted sums vectorise without a remainder.
constexpr int kSpfhStride = 36;

// atan2 with a minimax polynomial for atan on [0, 1] (max error about 1e-5 rad): the angle only selects one of
// 11 bins, and libm's atan2f would be the single largest cost of the descriptor stage.
inline float FastAtan2(float y, float x) {
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  if (!(mx > 0.0f)) return 0.0f;
  const float z = mn / mx;
  const float z2 = z * z;
  float r = z * (0.99997726f +
                 z2 * (-0.33262347f + z2 * (0.19354346f + z2 * (-0.11643287f + z2 * (0.05265332f + z2 * -0.01172120f)))));
  if (ay > ax) r = 1.57079633f - r;
  if (x < 0.0f) r = kPiF - r;
  return y < 0.0f ? -r : r;
}

// The SPFH kernel evaluates kPairLanes neighbours at once with the compiler's portable 16-byte vectors (SSE on
// x86-64, NEON on aarch64), branch-free: the scalar ComputePairFeature is latency bound (sqrt, two divisions,
// the atan polynomial) and would take a fifth of the coarse stage. (Not Eigen arrays: their select() with a bool
// condition is evaluated lane by lane, so they are no faster.) Every lane performs the same IEEE
// operations in the same order as ComputePairFeature (dot products as x + (y + z)), FastAtan2 and the
// histogram binning, so the bins are identical.
constexpr int kPairLanes = 4;
using V4f = float __attribute__((vector_size(16)));
using V4i = std::int32_t __attribute__((vector_size(16)));

inline V4f Select(V4i mask, V4f a, V4f b) {  // mask ? a : b
  V4i ia, ib;
  std::memcpy(&ia, &a, sizeof(ia));
  std::memcpy(&ib, &b, sizeof(ib));
  const V4i r = (ia & mask) | (ib & ~mask);
  V4f out;
  std::memcpy(&out, &r, sizeof(out));
  return out;
}
inline V4f Abs(V4f a) {
  V4i bits;
  std::memcpy(&bits, &a, sizeof(bits));
  bits &= 0x7fffffff;
  std::memcpy(&a, &bits, sizeof(a));
  return a;
}
inline V4f Sqrt(V4f a) {  // correctly rounded, as std::sqrt; callers pass non-negative lanes only
#if defined(__SSE__)
  return _mm_sqrt_ps(a);
#elif defined(__aarch64__) && defined(__ARM_NEON)
  float32x4_t v;
  std::memcpy(&v, &a, sizeof(v));
  v = vsqrtq_f32(v);
  std::memcpy(&a, &v, sizeof(a));
  return a;
#else
  for (int l = 0; l < kPairLanes; ++l) a[l] = std::sqrt(a[l]);
  return a;
#endif
}
inline V4f Dot(V4f ax, V4f ay, V4f az, V4f bx, V4f by, V4f bz) { return ax * bx + (ay * by + az * bz); }
inline V4f Broadcast(float v) { return V4f{v, v, v, v}; }

inline V4f FastAtan2Lanes(V4f y, V4f x) {
  const V4f ax = Abs(x), ay = Abs(y);
  const V4f mx = Select(ax < ay, ay, ax), mn = Select(ay < ax, ay, ax);
  const V4i defined = mx > 0.0f;
  const V4f z = mn / Select(defined, mx, Broadcast(1.0f));
  const V4f z2 = z * z;
  V4f r = z * (0.99997726f +
               z2 * (-0.33262347f + z2 * (0.19354346f + z2 * (-0.11643287f + z2 * (0.05265332f + z2 * -0.01172120f)))));
  r = Select(ay > ax, 1.57079633f - r, r);
  r = Select(x < 0.0f, kPiF - r, r);
  r = Select(y < 0.0f, -r, r);
  return Select(defined, r, Broadcast(0.0f));
}

// Histogram bin of each lane: floor((value - lo) / (hi - lo) * kFpfhBins) clamped to [0, kFpfhBins - 1]
// (clamped first, then truncated: the same bin). Lanes not in `valid` get bin 0 and must not be counted.
inline V4i BinLanes(V4f value, V4i valid, float lo, float hi) {
  V4f t = (value - lo) / (hi - lo) * static_cast<float>(kFpfhBins);
  t = Select(valid, t, Broadcast(0.0f));
  t = Select(t < 0.0f, Broadcast(0.0f), t);
  t = Select(t > static_cast<float>(kFpfhBins - 1), Broadcast(static_cast<float>(kFpfhBins - 1)), t);
  return __builtin_convertvector(t, V4i);
}

// Pair features of (p, n) with kPairLanes neighbours, as ComputePairFeature(p, n, q, m) per lane; `soa` holds
// the neighbours' x, y, z, nx, ny, nz rows, `row` floats apart. Fills the three bins and which lanes are defined
// (all bits set) or not (0).
void PairFeatureBins(const Eigen::Vector3f& p, const Eigen::Vector3f& n, const float* soa, std::size_t row,
                     V4i* b1, V4i* b2, V4i* b3, V4i* defined) {
  V4f dx, dy, dz, mx, my, mz;
  std::memcpy(&dx, soa, sizeof(dx));
  std::memcpy(&dy, soa + row, sizeof(dy));
  std::memcpy(&dz, soa + 2 * row, sizeof(dz));
  std::memcpy(&mx, soa + 3 * row, sizeof(mx));
  std::memcpy(&my, soa + 4 * row, sizeof(my));
  std::memcpy(&mz, soa + 5 * row, sizeof(mz));
  dx -= p.x(), dy -= p.y(), dz -= p.z();
  const V4f len = Sqrt(Dot(dx, dy, dz, dx, dy, dz));
  const V4i has_length = len > 0.0f;
  const V4f inv = 1.0f / Select(has_length, len, Broadcast(1.0f));
  dx *= inv, dy *= inv, dz *= inv;
  const V4f nx = Broadcast(n.x()), ny = Broadcast(n.y()), nz = Broadcast(n.z());
  const V4f a1 = Dot(nx, ny, nz, dx, dy, dz);
  const V4f a2 = Dot(mx, my, mz, dx, dy, dz);
  // Frame source: the neighbour when its normal is closer to the line (then d flips).
  const V4i swap = Abs(a1) < Abs(a2);
  const V4f ux = Select(swap, mx, nx), uy = Select(swap, my, ny), uz = Select(swap, mz, nz);
  const V4f ox = Select(swap, nx, mx), oy = Select(swap, ny, my), oz = Select(swap, nz, mz);
  dx = Select(swap, -dx, dx), dy = Select(swap, -dy, dy), dz = Select(swap, -dz, dz);
  const V4f a = Select(swap, -a2, a1);
  const V4f s2 = 1.0f - a * a;
  *defined = has_length & (s2 > 1e-12f);
  const V4f s = Sqrt(Select(*defined, s2, Broadcast(1.0f)));
  const V4f uo = Dot(ux, uy, uz, ox, oy, oz);
  const V4f f1 = FastAtan2Lanes(Dot(dx, dy, dz, ox, oy, oz) - a * uo, s * uo);
  // (d x u) . other, with ComputePairFeature's cross product component formulas.
  const V4f cx = dy * uz - dz * uy, cy = dz * ux - dx * uz, cz = dx * uy - dy * ux;
  const V4f f2 = Dot(cx, cy, cz, ox, oy, oz) / s;
  *b1 = BinLanes(f1, *defined, -kPiF, kPiF);
  *b2 = BinLanes(f2, *defined, -1.0f, 1.0f);
  *b3 = BinLanes(a, *defined, -1.0f, 1.0f);
}

}  // namespace

Status ValidateSubmapFeatureParams(const SubmapFeatureParams& p) {
  if (!(std::isfinite(p.normal_radius_m) && p.normal_radius_m > 0.0)) {
    return InvalidArgument("registration features: normal_radius_m must be finite and > 0");
  }
  if (!(std::isfinite(p.fpfh_radius_m) && p.fpfh_radius_m >= p.normal_radius_m)) {
    return InvalidArgument("registration features: fpfh_radius_m must be finite and >= normal_radius_m");
  }
  if (p.max_neighbors < 4 || p.max_neighbors > 1024) {
    return InvalidArgument("registration features: max_neighbors must be in [4, 1024], got " +
                           std::to_string(p.max_neighbors));
  }
  if (p.min_normal_neighbors < 3 || p.min_normal_neighbors > p.max_neighbors) {
    return InvalidArgument("registration features: min_normal_neighbors must be in [3, max_neighbors]");
  }
  if (!(p.linearity_threshold > 0.0 && p.linearity_threshold <= 1.0)) {
    return InvalidArgument("registration features: linearity_threshold must be in (0, 1]");
  }
  if (p.min_covariance_neighbors < 5 || p.covariance_neighbors < p.min_covariance_neighbors ||
      p.covariance_neighbors > p.max_neighbors) {
    return InvalidArgument(
        "registration features: need 5 <= min_covariance_neighbors <= covariance_neighbors <= max_neighbors");
  }
  return Status::Ok();
}

bool ComputePairFeature(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1, const Eigen::Vector3f& p2,
                        const Eigen::Vector3f& n2, PairFeature* feature) {
  // Dot products summed as x + (y + z), written out: Eigen's own order differs between x86-64 (SSE) and
  // aarch64 (NEON), and the vector kernel of ComputeDescriptors must repeat this function bit for bit.
  const auto dot = [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
    return a.x() * b.x() + (a.y() * b.y() + a.z() * b.z());
  };
  Eigen::Vector3f d = p2 - p1;
  const float len = std::sqrt(dot(d, d));
  if (!(len > 0.0f)) return false;
  d *= 1.0f / len;
  const float a1 = dot(n1, d);
  const float a2 = dot(n2, d);
  // The source of the frame is the point whose normal is closer to the line (smaller acos |a|).
  const Eigen::Vector3f* u = &n1;
  const Eigen::Vector3f* other = &n2;
  float a = a1;  // u . d
  if (std::fabs(a1) < std::fabs(a2)) {
    u = &n2;
    other = &n1;
    d = -d;
    a = -a2;
  }
  // With unit d and u: v = (d x u) / s and w = u x v = (d - a u) / s, where s = |d x u| = sqrt(1 - a^2), so
  // f2 = v . n_other = det[d, u, n_other] / s and f1 = atan2(w . n_other, u . n_other)
  // = atan2(d . n_other - a (u . n_other), s (u . n_other)) (atan2 ignores the common positive factor 1 / s).
  const float s2 = 1.0f - a * a;
  if (!(s2 > 1e-12f)) return false;
  const float s = std::sqrt(s2);
  const float uo = dot(*u, *other);
  feature->f1 = FastAtan2(dot(d, *other) - a * uo, s * uo);
  const Eigen::Vector3f c(d.y() * u->z() - d.z() * u->y(), d.z() * u->x() - d.x() * u->z(),
                          d.x() * u->y() - d.y() * u->x());  // d x u
  feature->f2 = dot(c, *other) / s;
  feature->f3 = a;
  return true;
}

const KdTree3& SubmapFeatures::tree() const {
  if (!tree_built_) {
    tree_.Build(points_);
    tree_built_ = true;
  }
  return tree_;
}

void SubmapFeatures::ComputeGeometry(Span<const PointXYZI> points, Span<const Eigen::Vector3d> sensor_origins_m,
                                     const SubmapFeatureParams& params) {
  points_ = points;
  const std::size_t n = points.size();
  stats_ = SubmapFeatureStats{};
  stats_.num_points = n;
  keypoints_.clear();
  descriptors_.clear();
  tree_built_ = false;  // built on first use by tree(): only the fine stage's target needs it

  const auto normal_r2 = static_cast<float>(params.normal_radius_m * params.normal_radius_m);
  neighbors_.Compute(points, static_cast<float>(params.fpfh_radius_m), static_cast<std::size_t>(params.max_neighbors));
  stats_.num_capped_neighborhoods = neighbors_.num_capped();
  normals_.assign(n, Eigen::Vector3f::Zero());
  normal_valid_.assign(n, 0);
  covariances_.assign(n, Eigen::Matrix3d::Identity());

  const Eigen::Vector3d default_origin = Eigen::Vector3d::Zero();
  const Span<const Eigen::Vector3d> origins =
      sensor_origins_m.empty() ? Span<const Eigen::Vector3d>(&default_origin, 1) : sensor_origins_m;

  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  for (std::size_t i = 0; i < n; ++i) {
    const Span<const std::uint32_t> nb = neighbors_.indices(i);
    const Span<const float> nb_d2 = neighbors_.distances_sq(i);
    const std::size_t kept = nb.size();

    // Normal: the neighbours within normal_radius_m, sample covariance (1 / (n - 1)).
    std::size_t nn = 0;
    while (nn < kept && nb_d2[nn] < normal_r2) ++nn;
    if (nn >= static_cast<std::size_t>(params.min_normal_neighbors)) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (std::size_t j = 0; j < nn; ++j) {
        const PointXYZI& q = points[nb[j]];
        mean += Eigen::Vector3d(static_cast<double>(q.x), static_cast<double>(q.y), static_cast<double>(q.z));
      }
      mean /= static_cast<double>(nn);
      Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
      for (std::size_t j = 0; j < nn; ++j) {
        const PointXYZI& q = points[nb[j]];
        const Eigen::Vector3d e =
            Eigen::Vector3d(static_cast<double>(q.x), static_cast<double>(q.y), static_cast<double>(q.z)) - mean;
        c.noalias() += e * e.transpose();
      }
      c /= static_cast<double>(nn - 1);
      eig.computeDirect(c);
      const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
      const bool finite = ev.allFinite() && eig.eigenvectors().allFinite();
      const double linearity = ev(2) > 0.0 ? (ev(2) - ev(1)) / ev(2) : 1.0;
      if (finite && ev(2) > 0.0 && linearity <= params.linearity_threshold) {
        Eigen::Vector3d normal = eig.eigenvectors().col(0).normalized();
        // Towards the nearest sensor origin (spec §1.2 step 3; quirk 11: a list, not only the frame origin).
        std::size_t best = 0;
        double best_d2 = std::numeric_limits<double>::infinity();
        for (std::size_t o = 0; o < origins.size(); ++o) {
          const double d2 = (origins[o] - mean).squaredNorm();
          if (d2 < best_d2) best_d2 = d2, best = o;
        }
        if (normal.dot(origins[best] - mean) < 0.0) normal = -normal;
        if (normal.allFinite()) {
          normals_[i] = normal.cast<float>();
          normal_valid_[i] = 1;
          ++stats_.num_valid_normals;
        }
      }
    }

    // GICP covariance: the k nearest (point included), 1 / n, eigenvalues replaced by (1e-3, 1, 1).
    const std::size_t kc = std::min<std::size_t>(kept, static_cast<std::size_t>(params.covariance_neighbors));
    if (kc >= static_cast<std::size_t>(params.min_covariance_neighbors)) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (std::size_t j = 0; j < kc; ++j) {
        const PointXYZI& q = points[nb[j]];
        mean += Eigen::Vector3d(static_cast<double>(q.x), static_cast<double>(q.y), static_cast<double>(q.z));
      }
      mean /= static_cast<double>(kc);
      Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
      for (std::size_t j = 0; j < kc; ++j) {
        const PointXYZI& q = points[nb[j]];
        const Eigen::Vector3d e =
            Eigen::Vector3d(static_cast<double>(q.x), static_cast<double>(q.y), static_cast<double>(q.z)) - mean;
        c.noalias() += e * e.transpose();
      }
      c /= static_cast<double>(kc);
      eig.computeDirect(c);
      if (eig.eigenvalues().allFinite() && eig.eigenvectors().allFinite() && eig.eigenvalues()(2) > 0.0) {
        const Eigen::Matrix3d& v = eig.eigenvectors();
        covariances_[i] = v * Eigen::Vector3d(1e-3, 1.0, 1.0).asDiagonal() * v.transpose();
        ++stats_.num_valid_covariances;
      }
    }
  }
  stats_.mean_neighbors = n ? neighbors_.total() / n : 0;
}

void SubmapFeatures::ComputeDescriptors(const SubmapFeatureParams& /*params*/) {
  const std::size_t n = points_.size();
  keypoints_.clear();
  keypoint_of_point_.assign(n, -1);

  // Keypoints: a valid normal and >= 3 valid-normal neighbours within fpfh_radius_m (self included).
  for (std::size_t i = 0; i < n; ++i) {
    if (!normal_valid_[i]) continue;
    int valid = 0;
    for (std::uint32_t j : neighbor_indices(i)) valid += normal_valid_[j];
    if (valid >= 3) {
      keypoint_of_point_[i] = static_cast<std::int32_t>(keypoints_.size());
      keypoints_.push_back(static_cast<std::uint32_t>(i));
    }
  }
  const std::size_t nk = keypoints_.size();
  stats_.num_keypoints = nk;

  // SPFH (spec step 6): histogram of the pair features with every other valid-normal neighbour.
  spfh_.assign(nk * kSpfhStride, 0.0f);
  for (std::size_t k = 0; k < nk; ++k) {
    const std::uint32_t i = keypoints_[k];
    const Span<const std::uint32_t> nb = neighbor_indices(i);
    int num_valid = 0;
    for (std::uint32_t j : nb) num_valid += (j != i && normal_valid_[j]);
    if (num_valid == 0) continue;
    const float inc = 100.0f / static_cast<float>(num_valid);
    float* h = spfh_.data() + k * kSpfhStride;
    // The valid-normal neighbours as structure of arrays. The lanes past them in the last group hold whatever an
    // earlier keypoint left there (initialised floats); their results are not counted.
    const std::size_t lanes = (static_cast<std::size_t>(num_valid) + kPairLanes - 1) / kPairLanes * kPairLanes;
    if (pair_soa_.size() < 6 * lanes) pair_soa_.resize(6 * lanes);
    float* soa = pair_soa_.data();
    std::size_t m = 0;
    for (std::uint32_t j : nb) {
      if (j == i || !normal_valid_[j]) continue;
      const PointXYZI& q = points_[j];
      const Eigen::Vector3f& nj = normals_[j];
      soa[m] = q.x, soa[lanes + m] = q.y, soa[2 * lanes + m] = q.z;
      soa[3 * lanes + m] = nj.x(), soa[4 * lanes + m] = nj.y(), soa[5 * lanes + m] = nj.z();
      ++m;
    }
    const Eigen::Vector3f pi = PositionF(points_[i]);
    const Eigen::Vector3f& ni = normals_[i];
    for (std::size_t base = 0; base < m; base += kPairLanes) {
      V4i b1, b2, b3, defined;
      PairFeatureBins(pi, ni, soa + base, lanes, &b1, &b2, &b3, &defined);
      const int used = static_cast<int>(std::min<std::size_t>(kPairLanes, m - base));
      for (int l = 0; l < used; ++l) {
        if (!defined[l]) continue;
        h[b1[l]] += inc;
        h[kFpfhBins + b2[l]] += inc;
        h[2 * kFpfhBins + b3[l]] += inc;
      }
    }
  }

  // FPFH (spec step 7): own SPFH + keypoint neighbours' SPFH weighted by 1 / d^2 (1 at d = 0, the point
  // itself included), then each 11-bin block rescaled to sum 100.
  descriptors_.assign(nk * kFpfhDims, 0.0f);
  using Row = Eigen::Array<float, kSpfhStride, 1>;
  for (std::size_t k = 0; k < nk; ++k) {
    const std::uint32_t i = keypoints_[k];
    float* out = descriptors_.data() + k * kFpfhDims;
    Row acc = Eigen::Map<const Row>(spfh_.data() + k * kSpfhStride);
    const Span<const std::uint32_t> nb = neighbor_indices(i);
    const Span<const float> nd = neighbor_distances_sq(i);
    for (std::size_t m = 0; m < nb.size(); ++m) {
      const std::int32_t kq = keypoint_of_point_[nb[m]];
      if (kq < 0) continue;
      const float w = nd[m] > 0.0f ? 1.0f / nd[m] : 1.0f;
      acc += w * Eigen::Map<const Row>(spfh_.data() + static_cast<std::size_t>(kq) * kSpfhStride);
    }
    for (int b = 0; b < kFpfhDims; ++b) out[b] = acc(b);
    for (int block = 0; block < 3; ++block) {
      float sum = 0.0f;
      for (int b = 0; b < kFpfhBins; ++b) sum += out[block * kFpfhBins + b];
      if (sum > 0.0f) {
        const float scale = 100.0f / sum;
        for (int b = 0; b < kFpfhBins; ++b) out[block * kFpfhBins + b] *= scale;
      }
    }
  }
}

std::size_t SubmapFeatures::workspace_bytes() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return tree_.memory_bytes() + neighbors_.workspace_bytes() + held(normals_) + held(normal_valid_) +
         held(covariances_) + held(keypoints_) + held(keypoint_of_point_) + held(spfh_) + held(pair_soa_) + held(descriptors_);
}

}  // namespace commerge
