// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/common/float_limits.hpp"

namespace commerge {

namespace {

constexpr std::uint32_t kKindBox = 0, kKindCylinder = 1, kKindSphere = 2;
constexpr std::uint32_t kIndexMask = (1u << 30) - 1;
/// Hits closer than this to the ray origin are ignored (self-intersection guard) [m].
constexpr float kMinHitT = 1e-3f;

bool Finite(float v) { return std::isfinite(v); }

/// Ray / oriented box: slab test in the box frame. Updates *best and the hit when nearer.
bool HitBox(const OrientedBox& b, const float o[3], const float d[3], float t_min, float* best, RayHit* hit) {
  const float c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  const float rx = o[0] - b.cx_m, ry = o[1] - b.cy_m;
  const float lo[3] = {c * rx + s * ry, -s * rx + c * ry, o[2]};
  const float ld[3] = {c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]};
  const float mn[3] = {-b.half_x_m, -b.half_y_m, b.z_min_m};
  const float mx[3] = {b.half_x_m, b.half_y_m, b.z_max_m};
  float t_near = -kFloatInf, t_far = *best;
  int axis = -1;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(ld[a]) < 1e-12f) {
      if (lo[a] < mn[a] || lo[a] > mx[a]) return false;
      continue;
    }
    const float inv = 1.0f / ld[a];
    float t0 = (mn[a] - lo[a]) * inv, t1 = (mx[a] - lo[a]) * inv;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      axis = a;
    }
    if (t1 < t_far) t_far = t1;
    if (t_near > t_far) return false;
  }
  if (axis < 0 || !(t_near > t_min) || !(t_near < *best)) return false;
  *best = t_near;
  hit->range_m = t_near;
  hit->reflectivity = b.reflectivity;
  hit->cos_incidence = std::fabs(ld[axis]);
  return true;
}

bool HitCylinder(const VerticalCylinder& cy, const float o[3], const float d[3], float t_min, float* best,
                 RayHit* hit) {
  const float px = o[0] - cy.cx_m, py = o[1] - cy.cy_m;
  const float a = d[0] * d[0] + d[1] * d[1];
  const float r2 = cy.radius_m * cy.radius_m;
  bool found = false;
  if (a > 1e-12f) {
    const float b = px * d[0] + py * d[1];
    const float c = px * px + py * py - r2;
    const float disc = b * b - a * c;
    if (disc >= 0.0f) {
      const float t = (-b - std::sqrt(disc)) / a;  // entry through the side
      const float z = o[2] + t * d[2];
      if (t > t_min && t < *best && z >= cy.z_min_m && z <= cy.z_max_m) {
        *best = t;
        const float nx = (px + t * d[0]) / cy.radius_m, ny = (py + t * d[1]) / cy.radius_m;
        hit->range_m = t;
        hit->reflectivity = cy.reflectivity;
        hit->cos_incidence = std::fabs(nx * d[0] + ny * d[1]);
        found = true;
      }
    }
  }
  // Caps (a ray from above onto the top of a pole, or from below onto a raised cylinder).
  if (std::fabs(d[2]) > 1e-12f) {
    const float cap_z = d[2] < 0 ? cy.z_max_m : cy.z_min_m;
    const float t = (cap_z - o[2]) / d[2];
    if (t > t_min && t < *best) {
      const float qx = px + t * d[0], qy = py + t * d[1];
      if (qx * qx + qy * qy <= r2) {
        *best = t;
        hit->range_m = t;
        hit->reflectivity = cy.reflectivity;
        hit->cos_incidence = std::fabs(d[2]);
        found = true;
      }
    }
  }
  return found;
}

bool HitSphere(const Sphere& s, const float o[3], const float d[3], float t_min, float* best, RayHit* hit) {
  const float px = o[0] - s.cx_m, py = o[1] - s.cy_m, pz = o[2] - s.cz_m;
  const float b = px * d[0] + py * d[1] + pz * d[2];
  const float c = px * px + py * py + pz * pz - s.radius_m * s.radius_m;
  const float disc = b * b - c;
  if (disc < 0.0f) return false;
  const float t = -b - std::sqrt(disc);
  if (!(t > t_min) || !(t < *best)) return false;
  *best = t;
  const float inv_r = 1.0f / s.radius_m;
  const float nx = (px + t * d[0]) * inv_r, ny = (py + t * d[1]) * inv_r, nz = (pz + t * d[2]) * inv_r;
  hit->range_m = t;
  hit->reflectivity = s.reflectivity;
  hit->cos_incidence = std::fabs(nx * d[0] + ny * d[1] + nz * d[2]);
  return true;
}

/// Corners of an oriented box's footprint bounding rectangle.
void BoxBounds(const OrientedBox& b, float* min_x, float* min_y, float* max_x, float* max_y) {
  const float c = std::fabs(std::cos(b.yaw_rad)), s = std::fabs(std::sin(b.yaw_rad));
  const float ex = c * b.half_x_m + s * b.half_y_m, ey = s * b.half_x_m + c * b.half_y_m;
  *min_x = b.cx_m - ex;
  *max_x = b.cx_m + ex;
  *min_y = b.cy_m - ey;
  *max_y = b.cy_m + ey;
}

std::uint32_t HashLattice(std::int32_t x, std::int32_t y, std::int32_t z, std::uint32_t seed) {
  std::uint32_t h = seed * 0x9E3779B1u;
  h ^= static_cast<std::uint32_t>(x) * 0x85EBCA77u;
  h = (h << 13) | (h >> 19);
  h ^= static_cast<std::uint32_t>(y) * 0xC2B2AE3Du;
  h = (h << 17) | (h >> 15);
  h ^= static_cast<std::uint32_t>(z) * 0x27D4EB2Fu;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return h;
}

float LatticeValue(std::int32_t x, std::int32_t y, std::int32_t z, std::uint32_t seed) {
  return static_cast<float>(HashLattice(x, y, z, seed) >> 8) * (2.0f / 16777216.0f) - 1.0f;
}

float Smooth(float t) { return t * t * (3.0f - 2.0f * t); }

/// Smooth value noise in [-1, 1], lattice spacing 1; gradient magnitude <= 1.5 x 2 x sqrt(3).
float ValueNoise(float x, float y, float z, std::uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const auto ix = static_cast<std::int32_t>(fx), iy = static_cast<std::int32_t>(fy), iz = static_cast<std::int32_t>(fz);
  const float u = Smooth(x - fx), v = Smooth(y - fy), w = Smooth(z - fz);
  float acc = 0.0f;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const float weight = (dx ? u : 1 - u) * (dy ? v : 1 - v) * (dz ? w : 1 - w);
    acc += weight * LatticeValue(ix + dx, iy + dy, iz + dz, seed);
  }
  return acc;
}

constexpr float kValueNoiseLipschitz = 5.2f;  // 1.5 (smoothstep slope) x 2 (value range) x sqrt(3)

}  // namespace

void World::CellRange(float min_x, float min_y, float max_x, float max_y, int* i0, int* j0, int* i1, int* j1) const {
  *i0 = std::clamp(static_cast<int>(std::floor((min_x - origin_x_) * inv_cell_)), 0, nx_ - 1);
  *j0 = std::clamp(static_cast<int>(std::floor((min_y - origin_y_) * inv_cell_)), 0, ny_ - 1);
  *i1 = std::clamp(static_cast<int>(std::floor((max_x - origin_x_) * inv_cell_)), 0, nx_ - 1);
  *j1 = std::clamp(static_cast<int>(std::floor((max_y - origin_y_) * inv_cell_)), 0, ny_ - 1);
}

Status World::Build(float cell_size_m) {
  built_ = false;
  if (!(cell_size_m >= 0.5f && cell_size_m <= 1000.0f)) {
    return InvalidArgument("world: grid cell size must be in [0.5, 1000] m, got " + std::to_string(cell_size_m));
  }
  // Validate and collect the XY bounds of every primitive.
  struct Bounds {
    float min_x, min_y, max_x, max_y, max_z;
  };
  std::vector<Bounds> bounds;
  bounds.reserve(boxes_.size() + cylinders_.size() + spheres_.size());
  for (std::size_t i = 0; i < boxes_.size(); ++i) {
    const OrientedBox& b = boxes_[i];
    if (!Finite(b.cx_m) || !Finite(b.cy_m) || !Finite(b.yaw_rad) || !(b.half_x_m > 0) || !(b.half_y_m > 0) ||
        !Finite(b.half_x_m) || !Finite(b.half_y_m) || !Finite(b.z_min_m) || !Finite(b.z_max_m) ||
        !(b.z_max_m > b.z_min_m)) {
      return InvalidArgument("world: box " + std::to_string(i) + " is degenerate or not finite");
    }
    Bounds bb{};
    BoxBounds(b, &bb.min_x, &bb.min_y, &bb.max_x, &bb.max_y);
    bb.max_z = b.z_max_m;
    bounds.push_back(bb);
  }
  for (std::size_t i = 0; i < cylinders_.size(); ++i) {
    const VerticalCylinder& c = cylinders_[i];
    if (!Finite(c.cx_m) || !Finite(c.cy_m) || !(c.radius_m > 0) || !Finite(c.radius_m) || !Finite(c.z_min_m) ||
        !Finite(c.z_max_m) || !(c.z_max_m > c.z_min_m)) {
      return InvalidArgument("world: cylinder " + std::to_string(i) + " is degenerate or not finite");
    }
    bounds.push_back({c.cx_m - c.radius_m, c.cy_m - c.radius_m, c.cx_m + c.radius_m, c.cy_m + c.radius_m, c.z_max_m});
  }
  for (std::size_t i = 0; i < spheres_.size(); ++i) {
    const Sphere& s = spheres_[i];
    if (!Finite(s.cx_m) || !Finite(s.cy_m) || !Finite(s.cz_m) || !(s.radius_m > 0) || !Finite(s.radius_m)) {
      return InvalidArgument("world: sphere " + std::to_string(i) + " is degenerate or not finite");
    }
    bounds.push_back({s.cx_m - s.radius_m, s.cy_m - s.radius_m, s.cx_m + s.radius_m, s.cy_m + s.radius_m,
                      s.cz_m + s.radius_m});
  }
  const float reach = std::max(0.0f, tunnel_noise_.amplitude_m);
  std::vector<Bounds> tunnel_bounds;
  tunnel_bounds.reserve(tunnels_.size());
  for (std::size_t i = 0; i < tunnels_.size(); ++i) {
    const TunnelSegment& t = tunnels_[i];
    if (!Finite(t.ax_m) || !Finite(t.ay_m) || !Finite(t.az_m) || !Finite(t.bx_m) || !Finite(t.by_m) ||
        !Finite(t.bz_m) || !(t.radius_m > 0) || !Finite(t.radius_m)) {
      return InvalidArgument("world: tunnel segment " + std::to_string(i) + " is degenerate or not finite");
    }
    const float r = t.radius_m + reach;
    tunnel_bounds.push_back({std::min(t.ax_m, t.bx_m) - r, std::min(t.ay_m, t.by_m) - r, std::max(t.ax_m, t.bx_m) + r,
                             std::max(t.ay_m, t.by_m) + r, std::max(t.az_m, t.bz_m) + r});
  }
  if (!(tunnel_noise_.amplitude_m >= 0.0f) || !(tunnel_noise_.wavelength_m > 0.0f)) {
    return InvalidArgument("world: tunnel noise needs amplitude >= 0 and wavelength > 0");
  }

  float min_x = kFloatInf, min_y = kFloatInf, max_x = -kFloatInf, max_y = -kFloatInf;
  max_z_ = ground_z_m_;
  for (const auto* list : {&bounds, &tunnel_bounds}) {
    for (const Bounds& b : *list) {
      min_x = std::min(min_x, b.min_x);
      min_y = std::min(min_y, b.min_y);
      max_x = std::max(max_x, b.max_x);
      max_y = std::max(max_y, b.max_y);
      max_z_ = std::max(max_z_, b.max_z);
    }
  }
  if (!(min_x <= max_x)) {  // empty world: one cell
    min_x = min_y = 0.0f;
    max_x = max_y = 1.0f;
  }
  cell_m_ = cell_size_m;
  inv_cell_ = 1.0f / cell_size_m;
  origin_x_ = min_x;
  origin_y_ = min_y;
  const double cells_x = std::floor(static_cast<double>(max_x - min_x) / static_cast<double>(cell_size_m)) + 1.0;
  const double cells_y = std::floor(static_cast<double>(max_y - min_y) / static_cast<double>(cell_size_m)) + 1.0;
  if (cells_x * cells_y > static_cast<double>(1 << 26)) {
    return InvalidArgument("world: the XY grid would need " + std::to_string(cells_x * cells_y) +
                           " cells (extent too large for a " + std::to_string(cell_size_m) + " m cell)");
  }
  nx_ = static_cast<int>(cells_x);
  ny_ = static_cast<int>(cells_y);
  const std::size_t cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);

  // Two passes (count, fill) into compressed rows: cell c holds refs_[cell_begin_[c], cell_begin_[c + 1]).
  auto fill = [&](const std::vector<Bounds>& list, std::vector<std::uint32_t>* begin, std::vector<std::uint32_t>* refs,
                  auto&& ref_of, bool track_z) {
    begin->assign(cells + 1, 0);
    for (const Bounds& b : list) {
      int i0, j0, i1, j1;
      CellRange(b.min_x, b.min_y, b.max_x, b.max_y, &i0, &j0, &i1, &j1);
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) ++(*begin)[static_cast<std::size_t>(j) * nx_ + i + 1];
    }
    for (std::size_t c = 0; c < cells; ++c) (*begin)[c + 1] += (*begin)[c];
    refs->assign((*begin)[cells], 0);
    std::vector<std::uint32_t> cursor(begin->begin(), begin->end() - 1);
    for (std::size_t k = 0; k < list.size(); ++k) {
      const Bounds& b = list[k];
      int i0, j0, i1, j1;
      CellRange(b.min_x, b.min_y, b.max_x, b.max_y, &i0, &j0, &i1, &j1);
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
          const std::size_t c = static_cast<std::size_t>(j) * nx_ + i;
          (*refs)[cursor[c]++] = ref_of(k);
          if (track_z) cell_max_z_[c] = std::max(cell_max_z_[c], b.max_z);
        }
      }
    }
  };
  cell_max_z_.assign(cells, -kFloatInf);
  const std::uint32_t n_boxes = static_cast<std::uint32_t>(boxes_.size());
  const std::uint32_t n_cyl = static_cast<std::uint32_t>(cylinders_.size());
  fill(bounds, &cell_begin_, &refs_,
       [&](std::size_t k) {
         const auto idx = static_cast<std::uint32_t>(k);
         if (idx < n_boxes) return (kKindBox << 30) | idx;
         if (idx < n_boxes + n_cyl) return (kKindCylinder << 30) | (idx - n_boxes);
         return (kKindSphere << 30) | (idx - n_boxes - n_cyl);
       },
       true);
  fill(tunnel_bounds, &tunnel_begin_, &tunnel_refs_, [](std::size_t k) { return static_cast<std::uint32_t>(k); },
       false);
  tunnel_pre_.resize(tunnel_refs_.size());
  for (std::size_t k = 0; k < tunnel_refs_.size(); ++k) {
    const TunnelSegment& t = tunnels_[tunnel_refs_[k]];
    const float ex = t.bx_m - t.ax_m, ey = t.by_m - t.ay_m, ez = t.bz_m - t.az_m;
    const float len2 = ex * ex + ey * ey + ez * ez;
    tunnel_pre_[k] = {t.ax_m, t.ay_m, t.az_m, ex, ey, ez, len2 > 0.0f ? 1.0f / len2 : 0.0f, t.radius_m};
  }
  built_ = true;
  return Status::Ok();
}

WorldStats World::stats() const {
  WorldStats s;
  s.boxes = boxes_.size();
  s.cylinders = cylinders_.size();
  s.spheres = spheres_.size();
  s.tunnel_segments = tunnels_.size();
  s.grid_cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  s.grid_references = refs_.size() + tunnel_refs_.size();
  s.memory_bytes = boxes_.size() * sizeof(OrientedBox) + cylinders_.size() * sizeof(VerticalCylinder) +
                   spheres_.size() * sizeof(Sphere) + tunnels_.size() * sizeof(TunnelSegment) +
                   (cell_begin_.size() + refs_.size() + tunnel_begin_.size() + tunnel_refs_.size()) * 4 +
                   cell_max_z_.size() * 4;
  return s;
}

float World::TunnelField(const float p[3], int cell_i, int cell_j, int* nearest) const {
  // s0 = min over the cell's capsules of (distance to the axis segment - radius): 1-Lipschitz.
  float s0 = kFloatInf;
  *nearest = -1;
  if (cell_i < 0 || cell_j < 0 || cell_i >= nx_ || cell_j >= ny_) return kFloatInf;
  const std::size_t c = static_cast<std::size_t>(cell_j) * nx_ + cell_i;
  for (std::uint32_t k = tunnel_begin_[c]; k < tunnel_begin_[c + 1]; ++k) {
    const TunnelPre& t = tunnel_pre_[k];
    const float px = p[0] - t.ax, py = p[1] - t.ay, pz = p[2] - t.az;
    const float u = std::clamp((px * t.ex + py * t.ey + pz * t.ez) * t.inv_len2, 0.0f, 1.0f);
    const float qx = px - u * t.ex, qy = py - u * t.ey, qz = pz - u * t.ez;
    const float q2 = qx * qx + qy * qy + qz * qz;
    const float limit = s0 + t.radius;  // this capsule lowers the minimum only when |q| < s0 + radius
    if (limit <= 0.0f || q2 >= limit * limit) continue;
    const float s = std::sqrt(q2) - t.radius;
    if (s < s0) {
      s0 = s;
      *nearest = static_cast<int>(tunnel_refs_[k]);
    }
  }
  return s0;
}

float World::TunnelSignedDistance(const float p[3]) const {
  if (tunnels_.empty() || !built_) return kFloatInf;
  const int i = static_cast<int>(std::floor((p[0] - origin_x_) * inv_cell_));
  const int j = static_cast<int>(std::floor((p[1] - origin_y_) * inv_cell_));
  int nearest = -1;
  const float s0 = TunnelField(p, i, j, &nearest);
  if (!std::isfinite(s0)) return kFloatInf;
  const float a = tunnel_noise_.amplitude_m;
  if (a <= 0.0f) return s0;
  const float inv_w = 1.0f / tunnel_noise_.wavelength_m;
  return s0 - a * ValueNoise(p[0] * inv_w, p[1] * inv_w, p[2] * inv_w, tunnel_noise_.seed);
}

bool World::CastTunnel(const float o[3], const float d[3], float t_min, float t_max, RayHit* hit) const {
  // Sphere tracing inside the free space (s < 0) until the wall (s >= 0). Far from the walls the bound
  // -(s0 + amplitude) (no noise evaluation, s0 is 1-Lipschitz) gives the step; near them the full field
  // divided by its Lipschitz constant.
  const float a = tunnel_noise_.amplitude_m;
  const float inv_w = 1.0f / tunnel_noise_.wavelength_m;
  const float lipschitz = 1.0f + a * kValueNoiseLipschitz * inv_w;
  constexpr float kSurfaceEps = 0.01f;
  constexpr float kMinStep = 0.02f;
  // Over-relaxed steps (omega > 1, Keinert et al., "Enhanced Sphere Tracing", 2014) are undone, and relaxation
  // switched off, when the bounding spheres of two consecutive points stop overlapping or a wall is reached.
  float t = std::max(t_min, 0.0f);
  float omega = 1.6f, prev_radius = 0.0f, step = 0.0f;
  int nearest = -1;
  for (int iter = 0; iter < 4096 && t <= t_max; ++iter) {
    const float p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    const int ci = static_cast<int>(std::floor((p[0] - origin_x_) * inv_cell_));
    const int cj = static_cast<int>(std::floor((p[1] - origin_y_) * inv_cell_));
    const float s0 = TunnelField(p, ci, cj, &nearest);
    float radius;  // a lower bound of the distance to the wall
    bool wall = false;
    if (s0 < -a - kSurfaceEps) {
      radius = -(s0 + a);
    } else {
      const float s = a > 0 ? s0 - a * ValueNoise(p[0] * inv_w, p[1] * inv_w, p[2] * inv_w, tunnel_noise_.seed) : s0;
      wall = s >= -kSurfaceEps;
      radius = -s / lipschitz;
    }
    if (omega > 1.0f && step > 0.0f && (wall || radius + prev_radius < step)) {
      t += prev_radius - step;  // back to the last safe point
      step = prev_radius;
      omega = 1.0f;
      continue;
    }
    if (wall) {
      if (iter == 0) return false;  // the ray starts in the rock
      hit->range_m = t;
      hit->reflectivity = 0.35f;
      hit->cos_incidence = 1.0f;
      if (nearest >= 0) {  // normal ~ direction from the nearest capsule axis
        const TunnelSegment& ts = tunnels_[static_cast<std::size_t>(nearest)];
        const float ex = ts.bx_m - ts.ax_m, ey = ts.by_m - ts.ay_m, ez = ts.bz_m - ts.az_m;
        const float px = p[0] - ts.ax_m, py = p[1] - ts.ay_m, pz = p[2] - ts.az_m;
        const float len2 = ex * ex + ey * ey + ez * ez;
        const float u = std::clamp(len2 > 0 ? (px * ex + py * ey + pz * ez) / len2 : 0.0f, 0.0f, 1.0f);
        const float nx = px - u * ex, ny = py - u * ey, nz = pz - u * ez;
        const float n = std::sqrt(nx * nx + ny * ny + nz * nz);
        if (n > 1e-6f) hit->cos_incidence = std::max(0.05f, std::fabs(nx * d[0] + ny * d[1] + nz * d[2]) / n);
      }
      return true;
    }
    step = std::max(radius * omega, kMinStep);
    prev_radius = radius;
    t += step;
  }
  return false;
}

bool World::CastRay(const float o[3], const float d[3], float min_range_m, float max_range_m, RayWorkspace* ws,
                    RayHit* hit) const {
  const float t_min = std::max(min_range_m, kMinHitT);
  float best = max_range_m;
  bool found = false;
  // Ground and ceiling planes bound the ray.
  if (d[2] < -1e-9f) {
    const float t = (ground_z_m_ - o[2]) / d[2];
    if (t > t_min && t < best) {
      best = t;
      hit->range_m = t;
      hit->reflectivity = 0.25f;
      hit->cos_incidence = -d[2];
      found = true;
    }
  } else if (has_ceiling_ && d[2] > 1e-9f) {
    const float t = (ceiling_z_m_ - o[2]) / d[2];
    if (t > t_min && t < best) {
      best = t;
      hit->range_m = t;
      hit->reflectivity = 0.6f;
      hit->cos_incidence = d[2];
      found = true;
    }
  }
  if (!tunnels_.empty()) {
    RayHit th;
    if (CastTunnel(o, d, t_min, best, &th) && th.range_m < best) {
      best = th.range_m;
      *hit = th;
      found = true;
    }
  }
  if (refs_.empty()) return found;

  const std::size_t n_prims = boxes_.size() + cylinders_.size() + spheres_.size();
  if (ws->stamp_.size() != n_prims) {
    ws->stamp_.assign(n_prims, 0);
    ws->ray_id_ = 0;
  }
  if (++ws->ray_id_ == 0) {
    std::fill(ws->stamp_.begin(), ws->stamp_.end(), 0);
    ws->ray_id_ = 1;
  }
  const std::uint32_t ray_id = ws->ray_id_;
  const std::size_t cyl_offset = boxes_.size(), sphere_offset = boxes_.size() + cylinders_.size();

  // 2-D DDA over the grid cells crossed by the ray's XY projection (Amanatides & Woo 1987).
  const float gx0 = origin_x_, gy0 = origin_y_;
  const float gx1 = origin_x_ + static_cast<float>(nx_) * cell_m_, gy1 = origin_y_ + static_cast<float>(ny_) * cell_m_;
  float t_enter = 0.0f, t_exit = best;
  for (int a = 0; a < 2; ++a) {  // clip to the grid rectangle
    const float lo = a == 0 ? gx0 : gy0, hi = a == 0 ? gx1 : gy1;
    if (std::fabs(d[a]) < 1e-12f) {
      if (o[a] < lo || o[a] >= hi) return found;
      continue;
    }
    float t0 = (lo - o[a]) / d[a], t1 = (hi - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit) return found;
  const float sx = o[0] + t_enter * d[0], sy = o[1] + t_enter * d[1];
  int i = std::clamp(static_cast<int>(std::floor((sx - gx0) * inv_cell_)), 0, nx_ - 1);
  int j = std::clamp(static_cast<int>(std::floor((sy - gy0) * inv_cell_)), 0, ny_ - 1);
  const int step_i = d[0] > 0 ? 1 : -1, step_j = d[1] > 0 ? 1 : -1;
  const float dt_x = std::fabs(d[0]) > 1e-12f ? cell_m_ / std::fabs(d[0]) : kFloatInf;
  const float dt_y = std::fabs(d[1]) > 1e-12f ? cell_m_ / std::fabs(d[1]) : kFloatInf;
  float t_next_x =
      std::fabs(d[0]) > 1e-12f ? (gx0 + static_cast<float>(i + (d[0] > 0 ? 1 : 0)) * cell_m_ - o[0]) / d[0] : kFloatInf;
  float t_next_y =
      std::fabs(d[1]) > 1e-12f ? (gy0 + static_cast<float>(j + (d[1] > 0 ? 1 : 0)) * cell_m_ - o[1]) / d[1] : kFloatInf;
  float t_cell_enter = t_enter;
  while (true) {
    const float t_cell_exit = std::min({t_next_x, t_next_y, t_exit});
    // Lowest z of the ray inside this cell: skip the cell when everything in it is below.
    const float z_a = o[2] + t_cell_enter * d[2], z_b = o[2] + std::min(t_cell_exit, best) * d[2];
    const std::size_t c = static_cast<std::size_t>(j) * nx_ + i;
    if (std::min(z_a, z_b) <= cell_max_z_[c]) {
      for (std::uint32_t k = cell_begin_[c]; k < cell_begin_[c + 1]; ++k) {
        const std::uint32_t ref = refs_[k];
        const std::uint32_t kind = ref >> 30, idx = ref & kIndexMask;
        const std::size_t global = kind == kKindBox ? idx : (kind == kKindCylinder ? cyl_offset + idx : sphere_offset + idx);
        if (ws->stamp_[global] == ray_id) continue;
        ws->stamp_[global] = ray_id;
        if (kind == kKindBox) {
          found |= HitBox(boxes_[idx], o, d, t_min, &best, hit);
        } else if (kind == kKindCylinder) {
          found |= HitCylinder(cylinders_[idx], o, d, t_min, &best, hit);
        } else {
          found |= HitSphere(spheres_[idx], o, d, t_min, &best, hit);
        }
      }
    }
    if (best <= t_cell_exit || t_cell_exit >= t_exit) break;
    if (d[2] > 0 && o[2] + t_cell_exit * d[2] > max_z_) break;  // above everything, going up
    t_cell_enter = t_cell_exit;
    if (t_next_x < t_next_y) {
      i += step_i;
      t_next_x += dt_x;
      if (i < 0 || i >= nx_) break;
    } else {
      j += step_j;
      t_next_y += dt_y;
      if (j < 0 || j >= ny_) break;
    }
  }
  return found;
}

World WorldFromBoxScene(const BoxScene& scene) {
  World world;
  world.set_ground_z_m(scene.ground_z_m);
  for (const Box& b : scene.boxes) {
    OrientedBox ob;
    ob.cx_m = 0.5f * (b.min_x + b.max_x);
    ob.cy_m = 0.5f * (b.min_y + b.max_y);
    ob.half_x_m = 0.5f * (b.max_x - b.min_x);
    ob.half_y_m = 0.5f * (b.max_y - b.min_y);
    ob.z_min_m = b.min_z;
    ob.z_max_m = b.max_z;
    ob.yaw_rad = 0.0f;
    world.AddBox(ob);
  }
  return world;
}

}  // namespace commerge
