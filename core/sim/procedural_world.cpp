// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/procedural_world.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/sim/courtyard.hpp"
#include "core/sim/sim_random.hpp"

namespace commerge {

namespace {

/// An oriented rectangle on the ground (footprint of an object).
struct Footprint {
  double cx, cy, hx, hy, yaw;
};

double PointRectDistance(double px, double py, double hx, double hy) {
  const double dx = std::max(std::fabs(px) - hx, 0.0), dy = std::max(std::fabs(py) - hy, 0.0);
  return std::hypot(dx, dy);
}

double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double u = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + u * ab)).norm();
}

/// Distance between a segment and a footprint (0 when they intersect).
double SegmentFootprintDistance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Footprint& f) {
  const double c = std::cos(f.yaw), s = std::sin(f.yaw);
  auto local = [&](const Eigen::Vector2d& p) {
    const double x = p.x() - f.cx, y = p.y() - f.cy;
    return Eigen::Vector2d(c * x + s * y, -s * x + c * y);
  };
  const Eigen::Vector2d la = local(a), lb = local(b);
  // Liang-Barsky clip: does the segment cross the rectangle?
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d d = lb - la;
  bool crosses = true;
  for (int axis = 0; axis < 2 && crosses; ++axis) {
    const double h = axis == 0 ? f.hx : f.hy;
    const double p0 = la[axis], dp = d[axis];
    if (std::fabs(dp) < 1e-12) {
      if (p0 < -h || p0 > h) crosses = false;
      continue;
    }
    double u0 = (-h - p0) / dp, u1 = (h - p0) / dp;
    if (u0 > u1) std::swap(u0, u1);
    t0 = std::max(t0, u0);
    t1 = std::min(t1, u1);
    if (t0 > t1) crosses = false;
  }
  if (crosses) return 0.0;
  double best = std::min(PointRectDistance(la.x(), la.y(), f.hx, f.hy), PointRectDistance(lb.x(), lb.y(), f.hx, f.hy));
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d corner((k & 1) ? f.hx : -f.hx, (k & 2) ? f.hy : -f.hy);
    best = std::min(best, PointSegmentDistance(corner, la, lb));
  }
  return best;
}

/// Separating-axis test of two footprints grown by `margin`.
bool FootprintsOverlap(const Footprint& p, const Footprint& q, double margin) {
  const Footprint* fs[2] = {&p, &q};
  for (int owner = 0; owner < 2; ++owner) {
    for (int axis = 0; axis < 2; ++axis) {
      const double yaw = fs[owner]->yaw + (axis ? kPi / 2 : 0.0);
      const double ux = std::cos(yaw), uy = std::sin(yaw);
      double extent[2], centre[2];
      for (int k = 0; k < 2; ++k) {
        const Footprint& f = *fs[k];
        const double c = std::cos(f.yaw), s = std::sin(f.yaw);
        extent[k] = f.hx * std::fabs(c * ux + s * uy) + f.hy * std::fabs(-s * ux + c * uy) + margin * 0.5;
        centre[k] = f.cx * ux + f.cy * uy;
      }
      if (std::fabs(centre[0] - centre[1]) > extent[0] + extent[1]) return false;
    }
  }
  return true;
}

/// Spatial hashes of the corridors to keep clear (segments) and of the footprints placed so far.
class Placer {
 public:
  explicit Placer(double cell_m) : cell_(cell_m) {}

  void AddClearSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const int id = static_cast<int>(segments_.size());
    segments_.push_back({a, b});
    ForCells(std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::max(a.x(), b.x()), std::max(a.y(), b.y()),
             [&](long long key) { segment_cells_[key].push_back(id); });
  }

  /// True when the footprint keeps at least `min_dist` from every clear segment.
  bool Clear(const Footprint& f, double min_dist) const {
    const double r = std::hypot(f.hx, f.hy) + min_dist;
    bool ok = true;
    ForCells(f.cx - r, f.cy - r, f.cx + r, f.cy + r, [&](long long key) {
      if (!ok) return;
      auto it = segment_cells_.find(key);
      if (it == segment_cells_.end()) return;
      for (int id : it->second) {
        const auto& s = segments_[static_cast<std::size_t>(id)];
        if (SegmentFootprintDistance(s.first, s.second, f) < min_dist) {
          ok = false;
          return;
        }
      }
    });
    return ok;
  }

  /// True when the footprint (grown by margin) overlaps nothing placed.
  bool Free(const Footprint& f, double margin) const {
    const double r = std::hypot(f.hx, f.hy) + margin;
    bool ok = true;
    ForCells(f.cx - r, f.cy - r, f.cx + r, f.cy + r, [&](long long key) {
      if (!ok) return;
      auto it = occupied_cells_.find(key);
      if (it == occupied_cells_.end()) return;
      for (int id : it->second) {
        if (FootprintsOverlap(f, occupied_[static_cast<std::size_t>(id)], margin)) {
          ok = false;
          return;
        }
      }
    });
    return ok;
  }

  void Occupy(const Footprint& f) {
    const int id = static_cast<int>(occupied_.size());
    occupied_.push_back(f);
    const double r = std::hypot(f.hx, f.hy);
    ForCells(f.cx - r, f.cy - r, f.cx + r, f.cy + r, [&](long long key) {
      auto& v = occupied_cells_[key];
      if (v.empty() || v.back() != id) v.push_back(id);
    });
  }

  bool TryPlace(const Footprint& f, double clearance, double margin) {
    if (!Clear(f, clearance) || !Free(f, margin)) return false;
    Occupy(f);
    return true;
  }

 private:
  template <class F>
  void ForCells(double x0, double y0, double x1, double y1, F&& fn) const {
    const long long i0 = static_cast<long long>(std::floor(x0 / cell_)), i1 = static_cast<long long>(std::floor(x1 / cell_));
    const long long j0 = static_cast<long long>(std::floor(y0 / cell_)), j1 = static_cast<long long>(std::floor(y1 / cell_));
    for (long long j = j0; j <= j1; ++j)
      for (long long i = i0; i <= i1; ++i)
        fn(static_cast<long long>((static_cast<unsigned long long>(i) << 32) ^ (static_cast<unsigned long long>(j) & 0xFFFFFFFFull)));
  }

  double cell_;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> segments_;
  std::unordered_map<long long, std::vector<int>> segment_cells_;
  std::vector<Footprint> occupied_;
  std::unordered_map<long long, std::vector<int>> occupied_cells_;
};

/// Arc-length parametrisation of an edge polyline.
class EdgePath {
 public:
  explicit EdgePath(const std::vector<Eigen::Vector2d>& poly) : poly_(poly), arc_(poly.size(), 0.0) {
    for (std::size_t i = 1; i < poly_.size(); ++i) arc_[i] = arc_[i - 1] + (poly_[i] - poly_[i - 1]).norm();
  }
  double length() const { return arc_.back(); }
  /// Point and unit direction at arc length s (clamped).
  void At(double s, Eigen::Vector2d* p, Eigen::Vector2d* dir) const {
    s = std::clamp(s, 0.0, length());
    std::size_t i = static_cast<std::size_t>(std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin());
    i = std::clamp<std::size_t>(i, 1, poly_.size() - 1);
    const double span = arc_[i] - arc_[i - 1];
    const double u = span > 0 ? (s - arc_[i - 1]) / span : 0.0;
    *p = poly_[i - 1] + u * (poly_[i] - poly_[i - 1]);
    *dir = span > 0 ? Eigen::Vector2d((poly_[i] - poly_[i - 1]) / span) : Eigen::Vector2d(1.0, 0.0);
  }

 private:
  const std::vector<Eigen::Vector2d>& poly_;
  std::vector<double> arc_;
};

Footprint FootprintAt(const EdgePath& path, double s, double side, double offset, double hx, double hy) {
  Eigen::Vector2d p, dir;
  path.At(s, &p, &dir);
  const Eigen::Vector2d left(-dir.y(), dir.x());
  const Eigen::Vector2d c = p + side * offset * left;
  return {c.x(), c.y(), hx, hy, std::atan2(dir.y(), dir.x())};
}

OrientedBox BoxOf(const Footprint& f, float z0, float z1, float reflectivity) {
  OrientedBox b;
  b.cx_m = static_cast<float>(f.cx);
  b.cy_m = static_cast<float>(f.cy);
  b.half_x_m = static_cast<float>(f.hx);
  b.half_y_m = static_cast<float>(f.hy);
  b.z_min_m = z0;
  b.z_max_m = z1;
  b.yaw_rad = static_cast<float>(f.yaw);
  b.reflectivity = reflectivity;
  return b;
}

/// A tree: trunk cylinder and a crown of overlapping spheres, all above `crown_base_m`.
void AddTree(World* w, SimRandom* rng, double x, double y, double trunk_r, double crown_base_m, double crown_r) {
  VerticalCylinder trunk;
  trunk.cx_m = static_cast<float>(x);
  trunk.cy_m = static_cast<float>(y);
  trunk.radius_m = static_cast<float>(trunk_r);
  trunk.z_min_m = 0.0f;
  trunk.z_max_m = static_cast<float>(crown_base_m + crown_r);
  trunk.reflectivity = 0.3f;
  w->AddCylinder(trunk);
  Sphere main;
  main.cx_m = static_cast<float>(x);
  main.cy_m = static_cast<float>(y);
  main.cz_m = static_cast<float>(crown_base_m + crown_r);
  main.radius_m = static_cast<float>(crown_r);
  main.reflectivity = 0.45f;
  w->AddSphere(main);
  const int lobes = 2 + static_cast<int>(rng->Below(3));
  for (int k = 0; k < lobes; ++k) {
    const double ang = rng->Uniform(0, 2 * kPi), dist = rng->Uniform(0.4, 0.8) * crown_r;
    const double r = rng->Uniform(0.5, 0.8) * crown_r;
    Sphere lobe = main;
    lobe.cx_m = static_cast<float>(x + dist * std::cos(ang));
    lobe.cy_m = static_cast<float>(y + dist * std::sin(ang));
    lobe.cz_m = static_cast<float>(std::max(crown_base_m + r, crown_base_m + crown_r + rng->Uniform(-0.4, 0.6) * crown_r));
    lobe.radius_m = static_cast<float>(r);
    w->AddSphere(lobe);
  }
}

void BuildUrban(const MissionPlan& plan, World* w) {
  const RoadNetwork& net = plan.network;
  Placer placer(16.0);
  for (const auto& e : net.edges)
    for (std::size_t i = 1; i < e.polyline.size(); ++i) placer.AddClearSegment(e.polyline[i - 1], e.polyline[i]);
  for (std::size_t ei = 0; ei < net.edges.size(); ++ei) {
    SimRandom rng(MixSeed(plan.params.seed, 0x44ull, ei));
    const EdgePath path(net.edges[ei].polyline);
    const double len = path.length();
    for (int side = -1; side <= 1; side += 2) {
      // Parked cars and poles first (kerb side), then street trees, then buildings behind them.
      for (double s = rng.Uniform(2.0, 8.0); s < len - 2.0; s += rng.Uniform(6.5, 12.0)) {
        if (rng.Uniform() > 0.45) continue;
        const Footprint car = FootprintAt(path, s, side, 3.9, 2.25, 0.9);
        if (!placer.TryPlace(car, 2.9, 0.3)) continue;
        w->AddBox(BoxOf(car, 0.3f, 1.0f, 0.7f));
        Footprint cabin = car;
        cabin.hx = 1.2;
        cabin.hy = 0.8;
        w->AddBox(BoxOf(cabin, 1.0f, 1.5f, 0.3f));
      }
      for (double s = rng.Uniform(0.0, 10.0); s < len; s += rng.Uniform(18.0, 32.0)) {
        const Footprint pole = FootprintAt(path, s, side, 6.2, 0.12, 0.12);
        if (!placer.TryPlace(pole, 4.0, 0.2)) continue;
        VerticalCylinder c;
        c.cx_m = static_cast<float>(pole.cx);
        c.cy_m = static_cast<float>(pole.cy);
        c.radius_m = 0.12f;
        c.z_max_m = static_cast<float>(rng.Uniform(6.0, 9.0));
        c.reflectivity = 0.6f;
        w->AddCylinder(c);
      }
      for (double s = rng.Uniform(0.0, 15.0); s < len; s += rng.Uniform(15.0, 30.0)) {
        if (rng.Uniform() > 0.5) continue;
        const Footprint tree = FootprintAt(path, s, side, 7.2, 0.3, 0.3);
        if (!placer.TryPlace(tree, 5.0, 0.5)) continue;
        AddTree(w, &rng, tree.cx, tree.cy, rng.Uniform(0.15, 0.3), rng.Uniform(2.8, 3.8), rng.Uniform(1.5, 2.4));
      }
      for (double s = rng.Uniform(-4.0, 4.0); s < len;) {
        const double width = rng.Uniform(10.0, 28.0), depth = rng.Uniform(8.0, 20.0);
        const double setback = rng.Uniform(9.0, 13.0);
        const double u = rng.Uniform();
        const double height = 4.0 + 36.0 * u * u;
        if (rng.Uniform() < 0.85) {
          const Footprint b = FootprintAt(path, s + width / 2, side, setback + depth / 2, width / 2, depth / 2);
          if (placer.TryPlace(b, 8.0, 0.5)) {
            w->AddBox(BoxOf(b, 0.0f, static_cast<float>(height), static_cast<float>(rng.Uniform(0.3, 0.8))));
            if (rng.Uniform() < 0.3) {  // a setback upper part
              Footprint top = b;
              top.hx *= 0.6;
              top.hy *= 0.6;
              w->AddBox(BoxOf(top, static_cast<float>(height), static_cast<float>(height + rng.Uniform(3.0, 15.0)), 0.5f));
            }
          }
        }
        s += width + rng.Uniform(1.0, 5.0);
      }
    }
  }
}

void BuildCampus(const MissionPlan& plan, World* w) {
  const RoadNetwork& net = plan.network;
  Placer placer(16.0);
  for (const auto& e : net.edges) {
    if (!e.driven) continue;
    for (std::size_t i = 1; i < e.polyline.size(); ++i) placer.AddClearSegment(e.polyline[i - 1], e.polyline[i]);
  }
  for (std::size_t ei = 0; ei < net.edges.size(); ++ei) {
    if (!net.edges[ei].driven) continue;
    SimRandom rng(MixSeed(plan.params.seed, 0x45ull, ei));
    const EdgePath path(net.edges[ei].polyline);
    const double len = path.length();
    for (int side = -1; side <= 1; side += 2) {
      for (double s = rng.Uniform(0.0, 10.0); s < len; s += rng.Uniform(20.0, 30.0)) {
        const Footprint lamp = FootprintAt(path, s, side, 1.7, 0.07, 0.07);
        if (!placer.TryPlace(lamp, 1.4, 0.2)) continue;
        VerticalCylinder c;
        c.cx_m = static_cast<float>(lamp.cx);
        c.cy_m = static_cast<float>(lamp.cy);
        c.radius_m = 0.07f;
        c.z_max_m = 4.0f;
        c.reflectivity = 0.6f;
        w->AddCylinder(c);
      }
      for (double s = rng.Uniform(5.0, 15.0); s < len; s += rng.Uniform(15.0, 25.0)) {
        if (rng.Uniform() > 0.3) continue;
        const Footprint bench = FootprintAt(path, s, side, 2.1, 0.9, 0.3);
        if (placer.TryPlace(bench, 1.5, 0.3)) w->AddBox(BoxOf(bench, 0.0f, 0.8f, 0.4f));
      }
      for (double s = rng.Uniform(0.0, 6.0); s < len; s += rng.Uniform(5.0, 12.0)) {
        const Footprint trunk = FootprintAt(path, s, side, rng.Uniform(3.0, 7.0), 0.3, 0.3);
        if (!placer.TryPlace(trunk, 2.2, 0.8)) continue;
        AddTree(w, &rng, trunk.cx, trunk.cy, rng.Uniform(0.15, 0.35), rng.Uniform(2.3, 3.5), rng.Uniform(1.4, 2.6));
      }
      for (double s = rng.Uniform(0.0, 20.0); s < len;) {
        const double width = rng.Uniform(20.0, 50.0), depth = rng.Uniform(15.0, 30.0);
        if (rng.Uniform() < 0.35) {
          const Footprint b = FootprintAt(path, s + width / 2, side, rng.Uniform(12.0, 22.0) + depth / 2, width / 2, depth / 2);
          if (placer.TryPlace(b, 10.0, 2.0)) {
            w->AddBox(BoxOf(b, 0.0f, static_cast<float>(rng.Uniform(6.0, 20.0)), 0.5f));
          }
        }
        s += width + rng.Uniform(10.0, 30.0);
      }
      const int lawn_trees = static_cast<int>(len / 15.0);
      for (int k = 0; k < lawn_trees; ++k) {
        const Footprint trunk = FootprintAt(path, rng.Uniform(0.0, len), side, rng.Uniform(8.0, 30.0), 0.3, 0.3);
        if (!placer.TryPlace(trunk, 3.0, 2.0)) continue;
        AddTree(w, &rng, trunk.cx, trunk.cy, rng.Uniform(0.2, 0.45), rng.Uniform(2.0, 4.0), rng.Uniform(1.8, 3.2));
      }
    }
  }
}

void BuildIndoor(const MissionPlan& plan, World* w) {
  const RoadNetwork& net = plan.network;
  w->set_ceiling_z_m(kIndoorCeilingM);
  Placer placer(8.0);
  for (const auto& e : net.edges)
    for (std::size_t i = 1; i < e.polyline.size(); ++i) placer.AddClearSegment(e.polyline[i - 1], e.polyline[i]);
  const double hw = static_cast<double>(kIndoorCorridorHalfWidthM);
  const double wall_t = 0.2, door_w = 1.0, door_pitch = 6.0, room_depth = 4.0;
  const double wall_c = hw + wall_t / 2;  // wall centre line offset
  const float ceiling = kIndoorCeilingM;
  for (std::size_t ei = 0; ei < net.edges.size(); ++ei) {
    SimRandom rng(MixSeed(plan.params.seed, 0x46ull, ei));
    const EdgePath path(net.edges[ei].polyline);
    const double len = path.length();
    const double s0 = hw + wall_t, s1 = len - hw - wall_t;  // leave the junctions open
    if (s1 <= s0) continue;
    for (int side = -1; side <= 1; side += 2) {
      double s = s0;
      for (double door = s0 + door_pitch / 2; s < s1; door += door_pitch) {
        const double door_a = std::min(door - door_w / 2, s1), door_b = std::min(door + door_w / 2, s1);
        if (door_a > s) {  // wall piece up to the door
          const Footprint piece = FootprintAt(path, 0.5 * (s + door_a), side, wall_c, 0.5 * (door_a - s), wall_t / 2);
          w->AddBox(BoxOf(piece, 0.0f, ceiling, 0.55f));
          placer.Occupy(piece);
          if (rng.Uniform() < 0.08 && door_a - s > 1.6) {  // a cabinet against the wall
            const Footprint cab = FootprintAt(path, 0.5 * (s + door_a), side, hw - 0.25, 0.5, 0.25);
            if (placer.Clear(cab, 0.8)) w->AddBox(BoxOf(cab, 0.0f, 1.8f, 0.7f));
          }
        }
        if (door_b <= door_a) break;
        if (door_b < s1 && rng.Uniform() < 0.6) {  // closed door, slightly recessed
          const Footprint leaf = FootprintAt(path, door, side, wall_c + 0.08, door_w / 2, 0.03);
          w->AddBox(BoxOf(leaf, 0.0f, 2.1f, 0.4f));
          const Footprint lintel = FootprintAt(path, door, side, wall_c, door_w / 2, wall_t / 2);
          w->AddBox(BoxOf(lintel, 2.1f, ceiling, 0.55f));
        } else if (door_b < s1) {  // open door onto a small room
          const double room_half = 0.5 * (door_pitch - 1.0);
          const Footprint back = FootprintAt(path, door, side, wall_c + room_depth, room_half, wall_t / 2);
          const Footprint left = FootprintAt(path, door - room_half, side, wall_c + room_depth / 2, wall_t / 2, room_depth / 2);
          const Footprint right = FootprintAt(path, door + room_half, side, wall_c + room_depth / 2, wall_t / 2, room_depth / 2);
          for (const Footprint& f : {back, left, right}) {
            if (placer.Clear(f, hw + 0.05)) w->AddBox(BoxOf(f, 0.0f, ceiling, 0.5f));
          }
          const Footprint lintel = FootprintAt(path, door, side, wall_c, door_w / 2, wall_t / 2);
          w->AddBox(BoxOf(lintel, 2.1f, ceiling, 0.55f));
        }
        s = door_b;
      }
    }
  }
}

void BuildCave(const MissionPlan& plan, World* w) {
  const RoadNetwork& net = plan.network;
  TunnelWallNoise noise;
  noise.amplitude_m = 0.5f;
  noise.wavelength_m = 5.0f;
  noise.seed = static_cast<std::uint32_t>(MixSeed(plan.params.seed, 0x47ull, 1));
  w->set_tunnel_noise(noise);
  constexpr float kAxisZ = 1.2f;
  std::vector<double> node_radius(net.node_xy.size(), 0.0);
  Placer placer(16.0);
  for (const auto& e : net.edges) {
    if (!e.driven) continue;
    for (std::size_t i = 1; i < e.polyline.size(); ++i) placer.AddClearSegment(e.polyline[i - 1], e.polyline[i]);
  }
  for (std::size_t ei = 0; ei < net.edges.size(); ++ei) {
    const auto& e = net.edges[ei];
    if (!e.driven) continue;
    SimRandom rng(MixSeed(plan.params.seed, 0x48ull, ei));
    const double radius = rng.Uniform(2.6, 3.6);
    node_radius[static_cast<std::size_t>(e.a)] = std::max(node_radius[static_cast<std::size_t>(e.a)], radius);
    node_radius[static_cast<std::size_t>(e.b)] = std::max(node_radius[static_cast<std::size_t>(e.b)], radius);
    const EdgePath path(e.polyline);
    const double len = path.length();
    const int pieces = std::max(1, static_cast<int>(std::ceil(len / 8.0)));
    Eigen::Vector2d prev, dir;
    path.At(0.0, &prev, &dir);
    for (int k = 1; k <= pieces; ++k) {
      Eigen::Vector2d p;
      path.At(len * k / pieces, &p, &dir);
      TunnelSegment seg;
      seg.ax_m = static_cast<float>(prev.x());
      seg.ay_m = static_cast<float>(prev.y());
      seg.bx_m = static_cast<float>(p.x());
      seg.by_m = static_cast<float>(p.y());
      seg.az_m = seg.bz_m = kAxisZ;
      seg.radius_m = static_cast<float>(radius);
      w->AddTunnelSegment(seg);
      prev = p;
    }
    const int boulders = static_cast<int>(len / 12.0);
    for (int k = 0; k < boulders; ++k) {
      const double s = rng.Uniform(8.0, std::max(8.0, len - 8.0));
      const double r = rng.Uniform(0.3, 0.9);
      const double side = rng.Uniform() < 0.5 ? -1.0 : 1.0;
      const Footprint f = FootprintAt(path, s, side, rng.Uniform(1.9, 2.8), r, r);
      if (!placer.TryPlace(f, 1.5, 0.2)) continue;
      Sphere b;
      b.cx_m = static_cast<float>(f.cx);
      b.cy_m = static_cast<float>(f.cy);
      b.cz_m = static_cast<float>(0.3 * r);
      b.radius_m = static_cast<float>(r);
      b.reflectivity = 0.3f;
      w->AddSphere(b);
    }
  }
  for (std::size_t n = 0; n < net.node_xy.size(); ++n) {  // junction chambers
    if (node_radius[n] <= 0.0) continue;
    SimRandom rng(MixSeed(plan.params.seed, 0x49ull, n));
    TunnelSegment chamber;
    chamber.ax_m = chamber.bx_m = static_cast<float>(net.node_xy[n].x());
    chamber.ay_m = chamber.by_m = static_cast<float>(net.node_xy[n].y());
    chamber.az_m = chamber.bz_m = kAxisZ + 0.3f;
    chamber.radius_m = static_cast<float>(node_radius[n] + rng.Uniform(0.5, 2.0));
    w->AddTunnelSegment(chamber);
  }
}


/// The facades of a courtyard share one style, as the ranges of a college quad do: one eaves height (each
/// range within 0.6 m of it), one bay pitch, window sills and thin pilasters that stand out of the wall by
/// less than a metre.
struct CourtyardStyle {
  double height_m = 12.0;
  double bay_m = 3.0;
  double floor_m = 3.2;
};

/// One side of the courtyard from `a` to `b` (the courtyard on its left): ranges of 8-20 m, each a body behind
/// the facade line with a pilaster per bay and a sill under every window; a passage of 3.5 m (floors above it
/// from 4 m) at `passage_at_m` (< 0: none).
void AddCourtyardSide(World* w, SimRandom* rng, const CourtyardStyle& style, const Eigen::Vector2d& a,
                      const Eigen::Vector2d& b, double passage_at_m) {
  const std::vector<Eigen::Vector2d> poly{a, b};
  const EdgePath side(poly);
  const double len = side.length();
  constexpr double kDepthM = 8.0, kPassageM = 3.5;
  auto body = [&](double from, double to, double z0, double height, float reflect) {
    if (to - from < 0.5) return;
    w->AddBox(BoxOf(FootprintAt(side, 0.5 * (from + to), -1, kDepthM / 2, 0.5 * (to - from), kDepthM / 2),
                    static_cast<float>(z0), static_cast<float>(height), reflect));
  };
  const double p0 = passage_at_m - kPassageM / 2, p1 = passage_at_m + kPassageM / 2;
  for (double s = 0.0; s < len;) {
    double width = std::min(rng->Uniform(8.0, 20.0), len - s);
    if (len - s - width < 4.0) width = len - s;  // no sliver at the end
    const double height = style.height_m + rng->Uniform(-0.6, 0.6);
    const float reflect = static_cast<float>(rng->Uniform(0.3, 0.8));
    if (passage_at_m >= s && passage_at_m < s + width) {
      body(s, std::max(s, p0), 0.0, height, reflect);
      body(std::min(s + width, p1), s + width, 0.0, height, reflect);
      body(std::max(s, p0), std::min(s + width, p1), 4.0, height, reflect);
    } else {
      body(s, s + width, 0.0, height, reflect);
    }
    s += width;
  }
  // Bays: a pilaster between bays, a sill under each window of each floor.
  for (double u = 0.5 * style.bay_m; u < len - 0.3; u += style.bay_m) {
    if (passage_at_m >= 0 && u > p0 - 0.4 && u < p1 + 0.4) continue;
    w->AddBox(BoxOf(FootprintAt(side, u, 1, 0.05, 0.15, 0.05), 0.0f, static_cast<float>(style.height_m - 0.6), 0.5f));
    for (double z = 0.9; z < style.height_m - 1.5; z += style.floor_m) {
      w->AddBox(BoxOf(FootprintAt(side, u + 0.5 * style.bay_m, 1, 0.08, 0.6, 0.08), static_cast<float>(z),
                      static_cast<float>(z + 0.1), 0.6f));
    }
  }
}

void BuildCourtyard(const MissionPlan& plan, World* w) {
  const CourtyardGeometry g = CourtyardOf(plan.params);
  SimRandom rng(MixSeed(plan.params.seed, 0xC0A9ull, 2));
  const double hx = 0.5 * g.width_m, hy = 0.5 * g.length_m;
  CourtyardStyle style;
  style.height_m = rng.Uniform(8.0, 14.0);
  style.bay_m = rng.Uniform(2.5, 4.0);
  const int passage_side = static_cast<int>(rng.Below(4));
  const Eigen::Vector2d c[4] = {{hx, -hy}, {hx, hy}, {-hx, hy}, {-hx, -hy}};
  for (int k = 0; k < 4; ++k) {
    const double len = (c[(k + 1) % 4] - c[k]).norm();
    AddCourtyardSide(w, &rng, style, c[k], c[(k + 1) % 4], k == passage_side ? rng.Uniform(0.25, 0.75) * len : -1.0);
  }
  // Furniture at random places clear of the walking loop (the carrier wanders up to 0.7 m off it).
  const double loop_inner = g.walk_inset_m;
  auto place = [&](double clearance_m, double* x, double* y) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      *x = rng.Uniform(-hx + 0.8, hx - 0.8);
      *y = rng.Uniform(-hy + 0.8, hy - 0.8);
      if (CourtyardLoopDistance(g, *x, *y) > 0.9 + clearance_m) return true;
    }
    return false;
  };
  double x = 0, y = 0;
  // The fountain: inside the loop, off centre.
  VerticalCylinder fountain;
  fountain.cx_m = static_cast<float>(rng.Uniform(-0.3, 0.3) * (hx - loop_inner));
  fountain.cy_m = static_cast<float>(rng.Uniform(-0.4, 0.4) * (hy - loop_inner));
  fountain.radius_m = static_cast<float>(rng.Uniform(1.2, 2.0));
  fountain.z_max_m = 0.7f;
  fountain.reflectivity = 0.6f;
  if (CourtyardLoopDistance(g, static_cast<double>(fountain.cx_m), static_cast<double>(fountain.cy_m)) > static_cast<double>(fountain.radius_m) + 1.2) w->AddCylinder(fountain);
  const int trees = 1 + static_cast<int>(rng.Below(3));
  for (int t = 0; t < trees; ++t) {
    if (place(0.6, &x, &y)) AddTree(w, &rng, x, y, rng.Uniform(0.12, 0.25), rng.Uniform(2.0, 3.0), rng.Uniform(1.2, 2.2));
  }
  const int benches = 2 + static_cast<int>(rng.Below(3));
  for (int k = 0; k < benches; ++k) {
    if (!place(0.9, &x, &y)) continue;
    w->AddBox(BoxOf({x, y, 0.9, 0.3, rng.Uniform(0.0, kPi)}, 0.0f, 0.45f, 0.5f));
  }
  const int planters = static_cast<int>(rng.Below(3));
  for (int k = 0; k < planters; ++k) {
    if (!place(0.8, &x, &y)) continue;
    w->AddBox(BoxOf({x, y, rng.Uniform(0.4, 0.8), rng.Uniform(0.4, 0.8), rng.Uniform(0.0, kPi)}, 0.0f,
                    static_cast<float>(rng.Uniform(0.5, 1.0)), 0.4f));
  }
  const int bollards = static_cast<int>(rng.Below(5));
  for (int k = 0; k < bollards; ++k) {
    if (!place(0.2, &x, &y)) continue;
    VerticalCylinder bollard;
    bollard.cx_m = static_cast<float>(x);
    bollard.cy_m = static_cast<float>(y);
    bollard.radius_m = 0.1f;
    bollard.z_max_m = 0.9f;
    bollard.reflectivity = 0.7f;
    w->AddCylinder(bollard);
  }
}
}  // namespace

Result<World> BuildMissionWorld(const MissionPlan& plan) {
  World world;
  world.set_ground_z_m(0.0f);
  float cell_m = 8.0f;
  switch (plan.params.world) {
    case WorldKind::kUrban: BuildUrban(plan, &world); break;
    case WorldKind::kCampus: BuildCampus(plan, &world); break;
    case WorldKind::kIndoor:
      BuildIndoor(plan, &world);
      cell_m = 4.0f;
      break;
    case WorldKind::kCave: BuildCave(plan, &world); break;
    case WorldKind::kCourtyard:
      BuildCourtyard(plan, &world);
      cell_m = 4.0f;
      break;
  }
  if (Status st = world.Build(cell_m); !st.ok()) return st;
  return world;
}

}  // namespace commerge
