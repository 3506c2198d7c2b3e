// SPDX-License-Identifier: BSD-3-Clause
// commerge: a ray-castable 3-D world for the LiDAR simulator: a ground plane, an optional ceiling plane,
// analytic primitives (oriented boxes, vertical cylinders, spheres) and an optional tunnel network (free space
// = union of noisy capsules, for caves), indexed by a uniform 2-D grid over the XY plane so that a ray only
// visits the cells it crosses (cost ~ cells crossed x primitives per cell, not O(primitives)).
//
// Frame: the simulation's ground-truth frame gt, x, y horizontal, z up [m]; the ground is the plane z = ground_z_m.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/status.hpp"
#include "core/sim/synthetic_scan.hpp"

namespace commerge {

/// Box with vertical sides rotated by `yaw_rad` about z: centre (cx, cy), half extents along its own x / y
/// axes, vertical extent [z_min, z_max]. Buildings, cars, walls, cabinets.
struct OrientedBox {
  float cx_m = 0, cy_m = 0;
  float half_x_m = 0.5f, half_y_m = 0.5f;
  float z_min_m = 0, z_max_m = 1;
  float yaw_rad = 0;
  float reflectivity = 0.5f;  ///< Lambertian reflectivity in [0, 1] (intensity = reflectivity x |cos incidence|)
};

/// Vertical cylinder (pole, tree trunk): axis (cx, cy), radius, vertical extent [z_min, z_max], capped.
struct VerticalCylinder {
  float cx_m = 0, cy_m = 0;
  float radius_m = 0.1f;
  float z_min_m = 0, z_max_m = 1;
  float reflectivity = 0.5f;
};

/// Sphere (tree-crown lobe, boulder).
struct Sphere {
  float cx_m = 0, cy_m = 0, cz_m = 0;
  float radius_m = 1;
  float reflectivity = 0.5f;
};

/// One capsule of a tunnel network's free space: points within radius_m (+ the wall noise) of the segment
/// a-b are inside the tunnel. The rock is everything outside the union of all capsules (and below the ground).
struct TunnelSegment {
  float ax_m = 0, ay_m = 0, az_m = 0;
  float bx_m = 0, by_m = 0, bz_m = 0;
  float radius_m = 3;
};

/// Wall irregularity of a tunnel network: the capsule radius is perturbed by amplitude_m x n(p), n a smooth
/// deterministic 3-D noise in [-1, 1] with features of about wavelength_m.
struct TunnelWallNoise {
  float amplitude_m = 0.0f;
  float wavelength_m = 4.0f;
  std::uint32_t seed = 1;
};

/// One ray hit.
struct RayHit {
  float range_m = 0;        ///< distance along the unit ray
  float reflectivity = 0;   ///< of the surface hit
  float cos_incidence = 1;  ///< |cos| of the angle between the ray and the surface normal
};

/// Per-thread scratch of the ray caster (mailbox stamps so a primitive spanning several cells is tested once
/// per ray). Not thread-safe: one per thread. Sized lazily to the world's primitive count.
class RayWorkspace {
 public:
  RayWorkspace() = default;

 private:
  friend class World;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t ray_id_ = 0;
};

/// Counters of a built world.
struct WorldStats {
  std::size_t boxes = 0, cylinders = 0, spheres = 0, tunnel_segments = 0;
  std::size_t grid_cells = 0;        ///< cells of the XY grid
  std::size_t grid_references = 0;   ///< primitive references stored in the cells
  std::size_t memory_bytes = 0;      ///< primitives + grid
};

/// A world under construction (Add*) and then, after Build(), a ray-castable one (CastRay). Adding after
/// Build() requires another Build().
class World {
 public:
  World() = default;

  void set_ground_z_m(float z) { ground_z_m_ = z; }
  float ground_z_m() const { return ground_z_m_; }
  /// A horizontal ceiling plane at `z` (indoor worlds); rays going up hit it.
  void set_ceiling_z_m(float z) {
    has_ceiling_ = true;
    ceiling_z_m_ = z;
  }
  bool has_ceiling() const { return has_ceiling_; }
  float ceiling_z_m() const { return ceiling_z_m_; }

  void AddBox(const OrientedBox& b) { boxes_.push_back(b); }
  void AddCylinder(const VerticalCylinder& c) { cylinders_.push_back(c); }
  void AddSphere(const Sphere& s) { spheres_.push_back(s); }
  /// Tunnel capsules: when any is added, the world is a cave: everything outside the capsules is rock.
  void AddTunnelSegment(const TunnelSegment& s) { tunnels_.push_back(s); }
  void set_tunnel_noise(const TunnelWallNoise& n) { tunnel_noise_ = n; }

  const std::vector<OrientedBox>& boxes() const { return boxes_; }
  const std::vector<VerticalCylinder>& cylinders() const { return cylinders_; }
  const std::vector<Sphere>& spheres() const { return spheres_; }
  const std::vector<TunnelSegment>& tunnel_segments() const { return tunnels_; }

  /// Builds the XY grid (cells of `cell_size_m`) over the primitives' extent. Errors (invalid argument):
  /// cell size not in [0.5, 1000] m, a non-finite or degenerate primitive (named by kind and index), more
  /// than 2^26 cells (world too large for the cell size).
  Status Build(float cell_size_m = 8.0f);
  bool built() const { return built_; }

  /// Casts the ray origin + t dir (dir unit length, frame gt) for t in (min_range_m, max_range_m].
  /// Returns true with the nearest hit. Precondition: built().
  bool CastRay(const float origin[3], const float dir[3], float min_range_m, float max_range_m, RayWorkspace* ws,
               RayHit* hit) const;

  /// Signed distance bound of the tunnel network at p: < 0 inside the free space, >= 0 in rock; +inf when the
  /// world has no tunnels. For tests and for placing objects inside the tunnels.
  float TunnelSignedDistance(const float p[3]) const;

  /// Largest z of any primitive or tunnel (ground and ceiling excluded); valid after Build().
  float max_object_z_m() const { return max_z_; }
  WorldStats stats() const;

 private:
  void CellRange(float min_x, float min_y, float max_x, float max_y, int* i0, int* j0, int* i1, int* j1) const;
  float TunnelField(const float p[3], int cell_i, int cell_j, int* nearest) const;
  bool CastTunnel(const float o[3], const float d[3], float t_min, float t_max, RayHit* hit) const;

  float ground_z_m_ = 0.0f;
  bool has_ceiling_ = false;
  float ceiling_z_m_ = 0.0f;
  std::vector<OrientedBox> boxes_;
  std::vector<VerticalCylinder> cylinders_;
  std::vector<Sphere> spheres_;
  std::vector<TunnelSegment> tunnels_;
  TunnelWallNoise tunnel_noise_;

  bool built_ = false;
  float cell_m_ = 8.0f, inv_cell_ = 0.125f;
  float origin_x_ = 0, origin_y_ = 0;
  int nx_ = 0, ny_ = 0;
  float max_z_ = 0.0f;
  std::vector<std::uint32_t> cell_begin_;   // nx*ny + 1 offsets into refs_
  std::vector<std::uint32_t> refs_;         // kind << 30 | index
  std::vector<float> cell_max_z_;           // highest point of the cell's primitives
  std::vector<std::uint32_t> tunnel_begin_;  // nx*ny + 1 offsets into tunnel_refs_
  std::vector<std::uint32_t> tunnel_refs_;
  struct TunnelPre {  // a, b - a, 1 / |b - a|^2, radius: one copy per cell reference, contiguous per cell
    float ax, ay, az, ex, ey, ez, inv_len2, radius;
  };
  std::vector<TunnelPre> tunnel_pre_;
};

/// The boxes and ground of a BoxScene as a World (for the accelerated caster); call Build() on the result.
World WorldFromBoxScene(const BoxScene& scene);

}  // namespace commerge
