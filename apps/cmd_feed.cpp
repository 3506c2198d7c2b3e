// SPDX-License-Identifier: BSD-3-Clause
// `commerge feed`: plays the role of a robot's odometry stack for tests and demos. It reads a KITTI-layout
// directory and publishes, in wall-clock time, every scan as lidar_scan_t and the trajectory as odometry_t samples
// at their own (higher) rate, interpolated between the directory's poses (core/agent/scan_odometry_sync.hpp:
// InterpolatePose). Scan time stamps come from times.txt scaled so the mean rate is --rate-hz (uniform without
// times.txt); odometry samples lie on their own grid, so `commerge robot` has to interpolate them to the scans.
// With --loop it replays the directory until interrupted, each pass continuing the odometry where the previous
// one ended (time keeps increasing; the trajectory repeats, moved by the end pose).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "core/agent/live_input.hpp"
#include "core/agent/scan_odometry_sync.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_reader.hpp"
#include "platform/lcm/input_codec.hpp"
#include "platform/lcm/lcm_bus.hpp"

namespace commerge::app {

namespace {

struct FeedOptions {
  std::string data;
  double rate_hz = 10.0;
  double odometry_rate_hz = 0.0;  // 0 = 2 x rate_hz
  std::string scan_channel = platform::kLidarScanChannel;
  std::string odometry_channel = platform::kOdometryChannel;
  std::string lcm_url = platform::kDefaultInputLcmUrl;
  std::string sensor_frame = "lidar";
  std::string odom_frame = "odom";
  bool loop = false;
  bool quiet = false;
};

// Scan times of one pass [s from the pass start]: times.txt scaled to a mean rate of rate_hz, else uniform.
Result<std::vector<double>> ScanTimes(const platform::RobotDataset& data, double rate_hz) {
  const std::size_t n = data.scan_files.size();
  std::vector<double> t(n);
  for (std::size_t k = 0; k < n; ++k) t[k] = static_cast<double>(k) / rate_hz;
  if (data.times_s.size() != n || n < 2) return t;
  for (std::size_t k = 1; k < n; ++k) {
    if (!(data.times_s[k] > data.times_s[k - 1])) {
      return InvalidArgument("times.txt: time " + std::to_string(k) + " (" + std::to_string(data.times_s[k]) +
                             " s) is not after the previous one");
    }
  }
  const double span_s = data.times_s[n - 1] - data.times_s[0];
  const double scale = static_cast<double>(n - 1) / (rate_hz * span_s);
  for (std::size_t k = 0; k < n; ++k) t[k] = (data.times_s[k] - data.times_s[0]) * scale;
  return t;
}

// The pose at time `t_s` of the pass, between the scans' poses (clamped to the first and last).
Eigen::Isometry3d PoseAt(const std::vector<double>& times_s, const std::vector<Eigen::Isometry3d>& poses, double t_s) {
  if (t_s <= times_s.front()) return InterpolatePose(poses.front(), poses.front(), 0.0);
  if (t_s >= times_s.back()) return InterpolatePose(poses.back(), poses.back(), 0.0);
  // The first scan time at or after t_s (k + 1), and the one before it (k).
  const std::size_t k =
      static_cast<std::size_t>(std::lower_bound(times_s.begin(), times_s.end(), t_s) - times_s.begin()) - 1;
  return InterpolatePose(poses[k], poses[k + 1], (t_s - times_s[k]) / (times_s[k + 1] - times_s[k]));
}

int RunFeed(const FeedOptions& o) {
  const char* tag = "commerge feed";
  auto spec = platform::ParseRobotDatasetSpec(o.data);
  if (!spec.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, spec.status().message().c_str());
    return kExitUsage;
  }
  auto data = platform::OpenRobotDataset(*spec, /*gt_from_poses=*/false);
  if (!data.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, data.status().message().c_str());
    return kExitFailure;
  }
  if (data->scan_files.empty()) {
    std::fprintf(stderr, "%s: %s has no scans\n", tag, o.data.c_str());
    return kExitFailure;
  }
  auto scan_times = ScanTimes(*data, o.rate_hz);
  if (!scan_times.ok()) {
    std::fprintf(stderr, "%s: %s: %s\n", tag, o.data.c_str(), scan_times.status().message().c_str());
    return kExitFailure;
  }
  const std::vector<double>& times = *scan_times;
  const double odometry_rate_hz = o.odometry_rate_hz > 0.0 ? o.odometry_rate_hz : 2.0 * o.rate_hz;
  // Odometry times of one pass: a grid at odometry_rate_hz, plus the last scan's time so every scan is covered.
  // (Compared in whole microseconds, the resolution of the time stamps.)
  auto to_us = [](double t_s) { return std::llround(t_s * 1e6); };
  std::vector<double> odometry_times;
  for (std::size_t j = 0;; ++j) {
    const double t = static_cast<double>(j) / odometry_rate_hz;
    if (to_us(t) >= to_us(times.back())) break;
    odometry_times.push_back(t);
  }
  odometry_times.push_back(times.back());
  // The receiving robot rejects odometry moving faster than 30 m/s (ScanOdometrySyncParams::max_speed_mps):
  // playing faster than the data's own rate raises the apparent speed.
  double max_speed_mps = 0.0;
  for (std::size_t k = 0; k + 1 < times.size(); ++k) {
    const double d_m = (data->poses[k + 1].translation() - data->poses[k].translation()).norm();
    max_speed_mps = std::max(max_speed_mps, d_m / (times[k + 1] - times[k]));
  }
  const double robot_max_speed_mps = ScanOdometrySyncParams{}.max_speed_mps;
  if (max_speed_mps > robot_max_speed_mps) {
    std::fprintf(stderr, "%s: warning: at %.2f Hz the trajectory moves up to %.1f m/s; `commerge robot` rejects "
                 "odometry faster than %.0f m/s (lower --rate-hz)\n", tag, o.rate_hz, max_speed_mps,
                 robot_max_speed_mps);
  }
  const double pass_s = times.back() + 1.0 / o.rate_hz;  // the next pass starts one scan period later

  platform::LcmBusParams bus_params;
  bus_params.url = o.lcm_url;
  auto bus = platform::OpenLcmBus(bus_params, {});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", tag, bus.status().message().c_str());
    return kExitFailure;
  }
  InstallStopSignalHandlers();
  if (!o.quiet) {
    std::fprintf(stderr, "%s: %zu scans from %s at %.2f Hz (%s), odometry at %.2f Hz, on %s and %s via %s%s\n", tag,
                 data->scan_files.size(), o.data.c_str(), o.rate_hz,
                 data->times_s.empty() ? "uniform" : "times.txt scaled", odometry_rate_hz, o.scan_channel.c_str(),
                 o.odometry_channel.c_str(), o.lcm_url.c_str(), o.loop ? ", looping" : "");
  }

  const std::int64_t start_wall_us = platform::WallTimeUs();
  const std::int64_t start_mono_us = platform::MonotonicUs();
  // Waits until `at_s` after the start; false when interrupted.
  auto wait_until = [&](double at_s) {
    const std::int64_t due = start_mono_us + static_cast<std::int64_t>(std::llround(at_s * 1e6));
    for (;;) {
      if (StopSignalCount() > 0) return false;
      const std::int64_t left = due - platform::MonotonicUs();
      if (left <= 0) return true;
      std::this_thread::sleep_for(std::chrono::microseconds(left < 50000 ? left : 50000));
    }
  };
  auto stamp = [&](double at_s) { return start_wall_us + static_cast<std::int64_t>(std::llround(at_s * 1e6)); };

  std::uint64_t scans = 0, samples = 0, points = 0, bytes = 0;
  std::size_t largest = 0;
  std::vector<std::uint8_t> buffer;
  LidarScan scan;
  scan.frame = o.sensor_frame;
  OdometrySample odometry;
  odometry.odom_frame = o.odom_frame;
  odometry.sensor_frame = o.sensor_frame;
  Eigen::Isometry3d T_odom_passodom = Eigen::Isometry3d::Identity();  // where this pass's trajectory starts
  const Eigen::Isometry3d T_pass_step = data->poses.back() * data->poses.front().inverse();
  auto publish = [&](const std::string& channel) {
    if (Status st = (*bus)->Publish(channel, buffer); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", tag, st.message().c_str());
      return false;
    }
    bytes += buffer.size();
    return true;
  };

  for (std::uint64_t pass = 0; StopSignalCount() == 0; ++pass) {
    const double offset_s = static_cast<double>(pass) * pass_s;
    std::size_t k = 0, j = 0;
    while (StopSignalCount() == 0 && (k < times.size() || j < odometry_times.size())) {
      // Time order; a scan before the odometry sample of the same time (a LiDAR odometry stack publishes a
      // scan's pose after the scan).
      const bool next_is_scan = k < times.size() && (j >= odometry_times.size() || times[k] <= odometry_times[j]);
      if (next_is_scan) {
        auto cloud = platform::ReadKittiBin(data->scan_files[k]);  // read and encode before the due time
        if (!cloud.ok()) {
          std::fprintf(stderr, "%s: %s\n", tag, cloud.status().message().c_str());
          return kExitFailure;
        }
        scan.utime_us = stamp(offset_s + times[k]);
        scan.points = std::move(cloud->points);
        if (Status st = platform::EncodeLidarScan(scan, &buffer); !st.ok()) {
          std::fprintf(stderr, "%s: %s: %s\n", tag, data->scan_files[k].c_str(), st.message().c_str());
          return kExitFailure;
        }
        if (!wait_until(offset_s + times[k])) break;
        if (!publish(o.scan_channel)) return kExitFailure;
        ++scans;
        points += scan.points.size();
        if (buffer.size() > largest) largest = buffer.size();
        ++k;
      } else {
        odometry.utime_us = stamp(offset_s + odometry_times[j]);
        odometry.T_odom_sensor = T_odom_passodom * PoseAt(times, data->poses, odometry_times[j]);
        if (Status st = platform::EncodeOdometry(odometry, &buffer); !st.ok()) {
          std::fprintf(stderr, "%s: pose at %.3f s: %s\n", tag, odometry_times[j], st.message().c_str());
          return kExitFailure;
        }
        if (!wait_until(offset_s + odometry_times[j])) break;
        if (!publish(o.odometry_channel)) return kExitFailure;
        ++samples;
        ++j;
      }
    }
    if (!o.loop) break;
    T_odom_passodom = T_odom_passodom * T_pass_step;
    if (!o.quiet && StopSignalCount() == 0) {
      std::fprintf(stderr, "%s: pass %llu done, %llu scans so far\n", tag, static_cast<unsigned long long>(pass + 1),
                   static_cast<unsigned long long>(scans));
    }
  }
  const double elapsed_s = static_cast<double>(platform::MonotonicUs() - start_mono_us) * 1e-6;
  std::printf("feed: %llu scans (%llu points, largest message %zu bytes) and %llu odometry samples published in "
              "%.1f s, %llu bytes; %s / %s on %s%s\n",
              static_cast<unsigned long long>(scans), static_cast<unsigned long long>(points), largest,
              static_cast<unsigned long long>(samples), elapsed_s, static_cast<unsigned long long>(bytes),
              o.scan_channel.c_str(), o.odometry_channel.c_str(), o.lcm_url.c_str(),
              StopSignalCount() > 0 ? " (interrupted)" : "");
  return kExitOk;
}

}  // namespace

Command AddFeedCommand(CLI::App& root) {
  auto o = std::make_shared<FeedOptions>();
  CLI::App* cmd = root.add_subcommand(
      "feed", "play a robot's odometry stack: publish a KITTI-layout directory as lidar_scan_t scans and "
              "odometry_t poses on LCM, in wall-clock time (the live input of `commerge robot`)");
  cmd->add_option("--data", o->data, "KITTI-layout directory (velodyne/*.bin, poses.txt, optional times.txt), or "
                                     "DIR:FIRST-LAST")
      ->required();
  cmd->add_option("--rate-hz", o->rate_hz, "scans published per second (times.txt is scaled to this mean rate)")
      ->check(CLI::Range(0.1, 1000.0))
      ->capture_default_str();
  cmd->add_option("--odometry-rate-hz", o->odometry_rate_hz,
                  "odometry samples per second on their own grid (0 = 2 x --rate-hz); keep samples <= 0.5 s apart, "
                  "the robot drops scans between samples further apart")
      ->check(CLI::Range(0.0, 10000.0))
      ->capture_default_str();
  cmd->add_option("--scan-channel", o->scan_channel, "channel of the lidar_scan_t messages")->capture_default_str();
  cmd->add_option("--odometry-channel", o->odometry_channel, "channel of the odometry_t messages")
      ->capture_default_str();
  cmd->add_option("--lcm-url", o->lcm_url, "LCM provider URL; ttl=0 keeps the scans on this board")
      ->capture_default_str();
  cmd->add_option("--sensor-frame", o->sensor_frame, "frame name of the scans and the odometry's child frame")
      ->capture_default_str();
  cmd->add_option("--odom-frame", o->odom_frame, "frame name of the odometry's fixed frame")->capture_default_str();
  cmd->add_flag("--loop", o->loop, "replay the directory until interrupted; each pass continues the odometry "
                                   "where the previous one ended");
  cmd->add_flag("--quiet", o->quiet, "no progress lines on stderr");
  cmd->footer(
      "Poses are published as they are in poses.txt (T_odom_sensor, the odometry frame being the directory's), "
      "interpolated to the odometry grid. Playing faster than the data's own rate raises the apparent speed: "
      "the robot rejects odometry faster than 30 m/s.\n"
      "A scan is 16 bytes per point (a 64-beam scan about 2 MB): far more than one UDP datagram. LCM fragments it, "
      "which is fine on one board (loopback, ttl=0), but the receiver's kernel buffer must hold whole scans or "
      "they are lost: the default URL asks for 16 MiB (recv_buf_size), which the kernel caps at "
      "net.core.rmem_max (raise it: sysctl -w net.core.rmem_max=16777216). Never publish scans on the radio "
      "link: give the robot's live input its own board-local URL.\n"
      "Example: commerge feed --data kitti/00:0-1000 --rate-hz 10 --odometry-rate-hz 50");
  return {cmd, [o]() { return RunFeed(*o); }};
}

}  // namespace commerge::app
