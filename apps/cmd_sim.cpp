// SPDX-License-Identifier: BSD-3-Clause
// `commerge sim`: writes a simulated multi-robot LiDAR dataset in KITTI layout (see
// platform/io/kitti_dataset_writer.hpp for the files and core/sim/multi_robot_mission.hpp for the frames).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/app_memory.hpp"
#include "apps/cmd_sim.hpp"
#include "apps/commands.hpp"
#include "core/common/bytes.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/lidar_models.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/procedural_world.hpp"
#include "platform/io/kitti_dataset_writer.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::app {

namespace {

using Clock = std::chrono::steady_clock;

std::string Seconds(double s) {
  char text[32];
  if (s < 120) {
    std::snprintf(text, sizeof(text), "%.0f s", s);
  } else {
    std::snprintf(text, sizeof(text), "%dm%02ds", static_cast<int>(s / 60), static_cast<int>(s) % 60);
  }
  return text;
}

/// One progress line on stderr: rewritten in place on a terminal, a new line every 10 s otherwise.
class Progress {
 public:
  explicit Progress(std::size_t total) : total_(total), tty_(isatty(2) != 0), start_(Clock::now()), last_(start_) {}
  void Update(std::size_t done, bool final = false) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    if (!final && since < (tty_ ? 0.5 : 10.0)) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
    const double eta = rate > 0 ? static_cast<double>(total_ - done) / rate : 0.0;
    std::fprintf(stderr, "%scommerge sim: %zu / %zu scans (%.1f %%), %.1f scans/s, elapsed %s, ETA %s%s",
                 tty_ ? "\r" : "", done, total_, total_ ? 100.0 * static_cast<double>(done) / static_cast<double>(total_) : 100.0,
                 rate, Seconds(elapsed).c_str(), Seconds(eta).c_str(), tty_ && !final ? "   " : "\n");
    std::fflush(stderr);
  }

 private:
  std::size_t total_;
  bool tty_;
  Clock::time_point start_, last_;
  std::mutex mutex_;
};

/// A float parameter as written in the configuration ("0.015", not its binary expansion).
std::string FloatText(float v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.7g", static_cast<double>(v));
  return text;
}

std::string Join(const std::vector<float>& v) {
  std::string out;
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? " " : "") + FloatText(v[i]);
  return out;
}

std::string InfoText(const SimOptions& o, const MissionPlan& plan, const LidarModel& lidar, const OverlapReport& overlap,
                     const WorldStats& world) {
  const MissionParams& p = plan.params;
  std::string t;
  auto line = [&](const std::string& key, const std::string& value) { t += key + ": " + value + "\n"; };
  auto num = [](double v) { return platform::io_detail::NumberText(v); };
  t += "# commerge sim dataset (commerge " CM_VERSION ")\n";
  t += "# Frames: robot_<r>/poses_gt.txt line k = true T_robotstart_sensor(k), the sensor pose of keyframe k in the\n"
       "# robot's start frame (= its sensor frame at keyframe 0, line 0 = identity); robot_<r>/poses.txt = the same\n"
       "# as the robot's own odometry reports it (drifting, line 0 = identity); start_transforms.txt line r =\n"
       "# T_gt_robotstart (the true start pose in the common ground-truth frame, z up, ground z = 0). Scans are in\n"
       "# the sensor frame (x forward, y left, z up): p_gt = T_gt_robotstart * poses_gt[k] * p_scan.\n";
  line("format", "commerge-sim 1");
  line("world", WorldKindName(p.world));
  line("overlap", OverlapModeName(p.overlap));
  line("robots", std::to_string(p.robots));
  line("keyframes_per_robot", std::to_string(p.keyframes_per_robot));
  line("keyframe_spacing_m", num(p.keyframe_spacing_m));
  line("seed", std::to_string(p.seed));
  line("scans_written", o.poses_only ? "no" : "yes");
  line("lidar", LidarKindName(lidar.kind));
  line("solid_preset", SolidPresetNameFor(lidar.kind));
  line("lidar_pattern", lidar.pattern == LidarPattern::kSpinning ? "spinning" : "rosette");
  if (lidar.pattern == LidarPattern::kSpinning) {
    line("lidar_beams", std::to_string(lidar.elevation_deg.size()));
    line("lidar_azimuth_steps", std::to_string(lidar.azimuth_steps));
    line("lidar_elevation_deg", Join(lidar.elevation_deg));
  } else {
    line("lidar_points_per_frame", std::to_string(lidar.points_per_frame));
    line("lidar_fov_half_angle_deg", FloatText(lidar.fov_half_angle_deg));
  }
  line("lidar_min_range_m", FloatText(lidar.min_range_m));
  line("lidar_max_range_m", FloatText(lidar.max_range_m));
  line("lidar_range_noise_std_m", FloatText(lidar.range_noise_std_m));
  line("lidar_detection_reference_reflectivity", FloatText(lidar.detection_reference_reflectivity));
  line("sensor_height_m", num(plan.sensor_height_m));
  line("lane_offset_m", num(plan.lane_offset_m));
  line("direction", p.same_direction ? "same" : "alternate");
  line("roll_pitch_wobble_deg", num(p.roll_pitch_wobble_deg));
  line("block_size_m", num(plan.network.block_m));
  line("grid_nodes", std::to_string(plan.network.nx) + " x " + std::to_string(plan.network.ny));
  line("world_primitives", std::to_string(world.boxes) + " boxes, " + std::to_string(world.cylinders) + " cylinders, " +
                               std::to_string(world.spheres) + " spheres, " + std::to_string(world.tunnel_segments) +
                               " tunnel segments");
  const DriftParams& d = p.drift;
  line("drift_scale", num(d.scale));
  line("drift_translation_noise_frac", num(d.translation_noise_frac));
  line("drift_z_noise_frac", num(d.z_noise_frac));
  line("drift_scale_bias_std", num(d.scale_bias_std));
  line("drift_yaw_noise_deg_per_sqrt_m", num(d.yaw_noise_deg_per_sqrt_m));
  line("drift_yaw_bias_std_deg_per_m", num(d.yaw_bias_std_deg_per_m));
  line("drift_roll_pitch_noise_deg_per_sqrt_m", num(d.roll_pitch_noise_deg_per_sqrt_m));
  line("overlap_radius_m", num(overlap.radius_m));
  for (std::size_t r = 0; r < plan.robots.size(); ++r) {
    const RobotMission& robot = plan.robots[r];
    std::string row;
    for (std::size_t j = 0; j < overlap.fraction[r].size(); ++j) row += (j ? " " : "") + num(std::round(overlap.fraction[r][j] * 1000) / 1000);
    line("overlap_fraction_robot_" + std::to_string(r), row);
    line("odometry_scale_bias_robot_" + std::to_string(r), num(robot.scale_bias));
    line("odometry_yaw_bias_deg_per_m_robot_" + std::to_string(r), num(robot.yaw_bias_rad_per_m * kRadToDeg));
  }
  return t;
}

struct ScanCasting {
  std::size_t scans = 0, points = 0;
  double seconds = 0.0;
};

// Casts every robot's keyframe scans in the world (o.threads workers) and writes them as they come.
Status CastScans(const SimOptions& o, const MissionParams& params, const MissionPlan& plan, const World& world,
                 const LidarModel& lidar, platform::KittiDatasetWriter* writer, ScanCasting* cast) {
  const std::size_t per_robot = static_cast<std::size_t>(params.keyframes_per_robot);
  const std::size_t total = per_robot * plan.robots.size();
  Progress progress(total);
  std::atomic<std::size_t> next{0}, done{0}, points{0};
  std::atomic<bool> failed{false};
  std::mutex error_mutex;
  Status error;
  const auto t1 = Clock::now();
  auto worker = [&]() {
    LidarScanWorkspace ws;
    std::vector<PointXYZI> scan;
    while (!failed.load()) {
      const std::size_t job = next.fetch_add(1);
      if (job >= total) return;
      const int r = static_cast<int>(job / per_robot);
      const std::size_t k = job % per_robot;
      const RobotMission& robot = plan.robots[static_cast<std::size_t>(r)];
      Status st = SimulateLidarScan(world, lidar, robot.T_gt_sensor(k), ScanNoiseSeed(params, r, k), k, &ws, &scan);
      if (st.ok()) st = writer->WriteScan(r, k, Span<const PointXYZI>(scan));
      if (!st.ok()) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!failed.exchange(true)) error = st;
        return;
      }
      points += scan.size();
      progress.Update(++done);
    }
  };
  const int threads = std::max(1, o.threads);
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  if (failed) return error;
  progress.Update(done, /*final=*/true);
  cast->scans = done;
  cast->points = points;
  cast->seconds = std::chrono::duration<double>(Clock::now() - t1).count();
  return Status::Ok();
}

}  // namespace

int RunSim(const SimOptions& o) {
  const char* tag = o.tag.c_str();
  auto world_kind = WorldKindFromName(o.world);
  auto overlap_mode = OverlapModeFromName(o.overlap);
  auto lidar_kind = LidarKindFromName(o.lidar);
  for (const Status* st : {&world_kind.status(), &overlap_mode.status(), &lidar_kind.status()}) {
    if (!st->ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st->message().c_str());
      return kExitUsage;
    }
  }
  MissionParams params;
  params.world = *world_kind;
  params.overlap = *overlap_mode;
  params.robots = o.robots;
  params.keyframes_per_robot = o.keyframes;
  params.seed = o.seed;
  params.drift.scale = o.drift;
  params.roll_pitch_wobble_deg = o.wobble_deg;
  params.same_direction = o.direction == "same";
  if (Status st = ValidateMissionParams(params); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitUsage;
  }
  LidarModel lidar = MakeLidarModel(*lidar_kind);
  if (o.azimuth_steps > 0) {
    if (lidar.pattern != LidarPattern::kSpinning) {
      std::fprintf(stderr, "%s: --azimuth-steps applies to spinning lidars, not %s\n", tag, LidarKindName(lidar.kind));
      return kExitUsage;
    }
    lidar.azimuth_steps = o.azimuth_steps;
  }
  if (o.livox_points > 0) {
    if (lidar.pattern != LidarPattern::kRosette) {
      std::fprintf(stderr, "%s: --livox-points applies to --lidar livox only\n", tag);
      return kExitUsage;
    }
    lidar.points_per_frame = o.livox_points;
  }
  lidar.detection_reference_reflectivity = o.detection_reflectivity;

  auto writer = platform::KittiDatasetWriter::Create(o.out_dir, o.robots, o.force);
  if (!writer.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, writer.status().message().c_str());
    return writer.status().code() == StatusCode::kInvalidArgument ? kExitUsage : kExitFailure;
  }

  const auto t0 = Clock::now();
  auto plan = PlanMission(params);
  if (!plan.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, plan.status().message().c_str());
    return kExitFailure;
  }
  auto world = BuildMissionWorld(*plan);
  if (!world.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, world.status().message().c_str());
    return kExitFailure;
  }
  const double setup_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const OverlapReport overlap = MeasureOverlap(*plan);
  const WorldStats stats = world->stats();
  std::printf("%s: %s world, %d robots, %s overlap, %d keyframes each, lidar %s (%d rays/frame), seed %llu\n", tag,
              WorldKindName(params.world), params.robots, OverlapModeName(params.overlap), params.keyframes_per_robot,
              LidarKindName(lidar.kind), lidar.rays_per_frame(), static_cast<unsigned long long>(params.seed));
  std::printf("  world: %zu boxes, %zu cylinders, %zu spheres, %zu tunnel segments, grid %zu cells (%s); planned in %.2f s\n",
              stats.boxes, stats.cylinders, stats.spheres, stats.tunnel_segments, stats.grid_cells,
              FormatBytes(static_cast<std::int64_t>(stats.memory_bytes)).c_str(), setup_s);

  // Trajectories first (cheap), then the scans.
  std::vector<Eigen::Isometry3d> starts;
  for (const RobotMission& r : plan->robots) {
    starts.push_back(r.T_gt_robotstart);
    if (Status st = writer->WriteTrajectory(r.id, r.odometry, r.gt, r.times_s, r.T_gt_robotstart); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      return kExitFailure;
    }
  }
  if (Status st = writer->WriteStartTransforms(starts); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitFailure;
  }
  if (Status st = writer->WriteInfo(InfoText(o, *plan, lidar, overlap, stats)); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
    return kExitFailure;
  }

  ScanCasting cast;
  if (!o.poses_only) {
    if (Status st = CastScans(o, params, *plan, *world, lidar, &*writer, &cast); !st.ok()) {
      std::fprintf(stderr, "\n%s: %s\n", tag, st.message().c_str());
      return kExitFailure;
    }
  }
  for (const RobotMission& r : plan->robots) {
    const Eigen::Vector3d end_gt = r.gt.back().translation(), end_odo = r.odometry.back().translation();
    double path_m = 0.0;
    for (std::size_t k = 1; k < r.gt.size(); ++k) path_m += (r.gt[k].translation() - r.gt[k - 1].translation()).norm();
    double shared = 0.0;
    for (std::uint8_t s : r.on_shared_tour) shared += s;
    std::printf("  robot %d: %.0f m driven, %.0f %% on the shared tour, overlap with the others %.0f %%, odometry "
                "end error %.1f m (%.2f %% of the path)\n",
                r.id, path_m, 100.0 * shared / static_cast<double>(r.on_shared_tour.size()), 100.0 * overlap.any[static_cast<std::size_t>(r.id)],
                (end_odo - end_gt).norm(), path_m > 0 ? 100.0 * (end_odo - end_gt).norm() / path_m : 0.0);
  }
  if (!o.poses_only) {
    std::printf("  scans: %zu in %.1f s (%.1f scans/s, %d thread%s), %.0f points/scan, %s of .bin files\n", cast.scans,
                cast.seconds, cast.seconds > 0 ? static_cast<double>(cast.scans) / cast.seconds : 0.0, std::max(1, o.threads),
                o.threads > 1 ? "s" : "", cast.scans ? static_cast<double>(cast.points) / static_cast<double>(cast.scans) : 0.0,
                FormatBytes(static_cast<std::int64_t>(cast.points * sizeof(PointXYZI))).c_str());
  }
  std::printf("  wrote %s (sim_info.txt, start_transforms.txt, robot_0..robot_%d)\n", o.out_dir.c_str(), params.robots - 1);
  std::printf("  %s\n", PeakRssLine().c_str());
  return kExitOk;
}


Command AddSimCommand(CLI::App& root) {
  auto o = std::make_shared<SimOptions>();
  CLI::App* cmd = root.add_subcommand(
      "sim", "Write a simulated multi-robot LiDAR dataset (KITTI layout per robot, ground truth, drifting odometry)");
  cmd->add_option("--world", o->world, "World: urban, campus, indoor (repetitive corridors), cave or courtyard (a small scene walked with a handheld sensor)")
      ->check(CLI::IsMember({"urban", "campus", "indoor", "cave", "courtyard"}, CLI::ignore_case))
      ->capture_default_str();
  cmd->add_option("--robots", o->robots, "Number of robots")->check(CLI::Range(2, 5))->capture_default_str();
  cmd->add_option("--overlap", o->overlap, "Path overlap: complete (~100 %), moderate (~50 %) or partial (~15 %)")
      ->check(CLI::IsMember({"complete", "moderate", "partial"}, CLI::ignore_case))
      ->capture_default_str();
  cmd->add_option("--keyframes", o->keyframes, "Keyframes per robot (one per metre of travel)")
      ->check(CLI::Range(2, 1000000))
      ->capture_default_str();
  cmd->add_option("--lidar", o->lidar, "Sensor: vlp16, hdl64, os128 (OS1-128), os2-128, os0-128 (wide field) or livox (Mid-70-like)")
      ->check(CLI::IsMember({"vlp16", "hdl64", "os128", "os2-128", "os0-128", "livox"}, CLI::ignore_case))
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the world, the routes, the noise and the drift")->capture_default_str();
  cmd->add_option("--direction", o->direction,
                  "Shared laps: alternate (odd robots drive the other way round, on the other lane) or same")
      ->check(CLI::IsMember({"alternate", "same"}))
      ->capture_default_str();
  cmd->add_option("--wobble-deg", o->wobble_deg, "Amplitude of the vehicle's true roll and pitch [deg]")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  cmd->add_option("--drift", o->drift, "Odometry drift scale (0 = perfect odometry, 1 = default model)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--out", o->out_dir, "Output directory")->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace the dataset in a non-empty output directory");
  cmd->add_flag("--poses-only", o->poses_only, "Write poses, times and transforms but no scans");
  cmd->add_option("--threads", o->threads, "Threads casting scans (the output does not depend on it)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--azimuth-steps", o->azimuth_steps, "Columns per revolution of a spinning lidar (default: the model's)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--livox-points", o->livox_points, "Points per frame of the livox model (default 10000)")
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--detection-reflectivity", o->detection_reflectivity,
                  "Reflectivity at which the lidar reaches its max range; weaker or grazing returns fade sooner "
                  "(range limit = max range x sqrt(reflectivity x cos incidence / this); 0 = every hit returns)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  return {cmd, [o]() -> int { return RunSim(*o); }};
}

}  // namespace commerge::app
