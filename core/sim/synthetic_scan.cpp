// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/synthetic_scan.hpp"

#include <cmath>
#include <random>

#include "core/geometry/angles.hpp"

namespace commerge {

namespace {

/// Ray/box slab test; returns the entry distance in (0, best) or best unchanged.
float IntersectBox(const Box& b, const float o[3], const float d[3], float best) {
  const float lo[3] = {b.min_x, b.min_y, b.min_z};
  const float hi[3] = {b.max_x, b.max_y, b.max_z};
  float t_near = 0.0f;
  float t_far = best;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(d[a]) < 1e-9f) {
      if (o[a] < lo[a] || o[a] > hi[a]) return best;
      continue;
    }
    float t0 = (lo[a] - o[a]) / d[a];
    float t1 = (hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) t_near = t0;
    if (t1 < t_far) t_far = t1;
    if (t_near > t_far) return best;
  }
  return t_near > 1e-3f && t_near < best ? t_near : best;
}

}  // namespace

BoxScene MakeStreetScene(std::uint32_t seed, float length_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  BoxScene scene;
  scene.ground_z_m = 0.0f;
  for (int side = -1; side <= 1; side += 2) {
    float x = -length_m / 2;
    while (x < length_m / 2) {
      const float w = 8.0f + 17.0f * u(rng);    // facade length along the road
      const float setback = 7.0f + 6.0f * u(rng);  // distance from the road axis
      const float depth = 8.0f + 10.0f * u(rng);
      const float height = 4.0f + 16.0f * u(rng);
      if (u(rng) > 0.15f) {  // gaps between buildings
        const float y0 = side > 0 ? setback : -setback - depth;
        scene.boxes.push_back({x, y0, 0.0f, x + w, y0 + depth, height});
      }
      // a pole every ~15 m and a parked car now and then, on the kerb
      if (u(rng) > 0.4f) {
        const float py = side * (setback - 1.0f);
        scene.boxes.push_back({x + 1.0f, py - 0.15f, 0.0f, x + 1.3f, py + 0.15f, 5.0f});
      }
      if (u(rng) > 0.5f) {
        const float cy = side * (setback - 3.0f);
        scene.boxes.push_back({x + 3.0f, cy - 0.9f, 0.0f, x + 7.5f, cy + 0.9f, 1.5f});
      }
      x += w + 1.0f + 4.0f * u(rng);
    }
  }
  return scene;
}

BoxScene MakeBlockLoopScene(std::uint32_t seed, float width_m, float height_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  BoxScene scene;
  // Buildings along each side of the rectangle, on both sides of the road (outside: ring; inside: block).
  struct Side {
    float x0, y0, x1, y1;  // road segment
    float nx, ny;          // outward normal
  };
  const Side sides[] = {{0, 0, width_m, 0, 0, -1},
                        {width_m, 0, width_m, height_m, 1, 0},
                        {width_m, height_m, 0, height_m, 0, 1},
                        {0, height_m, 0, 0, -1, 0}};
  for (const Side& side : sides) {
    const float length = std::hypot(side.x1 - side.x0, side.y1 - side.y0);
    const float dx = (side.x1 - side.x0) / length, dy = (side.y1 - side.y0) / length;
    for (int out = 0; out < 2; ++out) {
      const float sign = out ? 1.0f : -1.0f;  // outside the block or inside it
      float s = -8.0f;
      while (s < length + 8.0f) {
        const float w = 4.0f + 8.0f * u(rng);
        const float setback = 6.0f + 4.0f * u(rng);
        const float depth = 4.0f + 6.0f * u(rng);
        const float height = 3.0f + 12.0f * u(rng);
        if (u(rng) > 0.2f && (out == 1 || (setback + depth) < 0.5f * std::min(width_m, height_m))) {
          const float ax = side.x0 + dx * s + sign * side.nx * setback;
          const float ay = side.y0 + dy * s + sign * side.ny * setback;
          const float bx = side.x0 + dx * (s + w) + sign * side.nx * (setback + depth);
          const float by = side.y0 + dy * (s + w) + sign * side.ny * (setback + depth);
          scene.boxes.push_back({std::min(ax, bx), std::min(ay, by), 0.0f, std::max(ax, bx), std::max(ay, by), height});
        }
        if (u(rng) > 0.5f) {
          const float px = side.x0 + dx * s + sign * side.nx * 4.0f;
          const float py = side.y0 + dy * s + sign * side.ny * 4.0f;
          scene.boxes.push_back({px - 0.15f, py - 0.15f, 0.0f, px + 0.15f, py + 0.15f, 4.0f + 2.0f * u(rng)});
        }
        s += w + 1.0f + 3.0f * u(rng);
      }
    }
  }
  return scene;
}

void CastScan(const BoxScene& scene, const SpinningLidar& lidar, float x_m, float y_m, float z_m, float yaw_rad,
              std::uint32_t seed, std::vector<PointXYZI>* out) {
  out->clear();
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, lidar.range_noise_std_m > 0 ? lidar.range_noise_std_m : 1e-9f);
  const float o[3] = {x_m, y_m, z_m};
  const float cy = std::cos(yaw_rad), sy = std::sin(yaw_rad);
  for (int beam = 0; beam < lidar.beams; ++beam) {
    const float frac = lidar.beams > 1 ? static_cast<float>(beam) / static_cast<float>(lidar.beams - 1) : 0.5f;
    const float elev = (lidar.min_elevation_deg + frac * (lidar.max_elevation_deg - lidar.min_elevation_deg)) * kPiF / 180;
    const float ce = std::cos(elev), se = std::sin(elev);
    for (int step = 0; step < lidar.azimuth_steps; ++step) {
      const float az = 2.0f * kPiF * static_cast<float>(step) / static_cast<float>(lidar.azimuth_steps);
      const float ds[3] = {ce * std::cos(az), ce * std::sin(az), se};  // sensor frame
      const float dw[3] = {cy * ds[0] - sy * ds[1], sy * ds[0] + cy * ds[1], ds[2]};
      float t = lidar.max_range_m;
      if (dw[2] < -1e-6f) {
        const float tg = (scene.ground_z_m - o[2]) / dw[2];
        if (tg > 0 && tg < t) t = tg;
      }
      for (const Box& b : scene.boxes) t = IntersectBox(b, o, dw, t);
      if (!(t < lidar.max_range_m)) continue;
      const float r = t + noise(rng);
      out->push_back(PointXYZI{r * ds[0], r * ds[1], r * ds[2], 1.0f / (1.0f + r)});
    }
  }
}

}  // namespace commerge
