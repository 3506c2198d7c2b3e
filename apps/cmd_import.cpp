// SPDX-License-Identifier: BSD-3-Clause
// `commerge import INPUT --out DIR`: a recording or a scan session into the KITTI-layout directory that `run`,
// `robot --data` and `feed` read.
//   * a recording (ROS 1 bag: chunks uncompressed, bz2 or lz4; MCAP; rosbag2 .db3), with --scan-topic and
//     --pose-topic: scans are paired with the odometry by their header stamps through the live input's
//     synchroniser (core/agent/scan_odometry_sync.hpp), the same interpolation and counted discards as
//     `commerge robot --live`; without the topics it lists the recording's topics and says which it would take. It
//     is read one chunk at a time (platform/ros/message_source.hpp);
//   * a folder of .pcd / .ply / .bin scans with --poses (apps/import_session.hpp).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"
#include "apps/import_session.hpp"
#include "core/agent/scan_odometry_sync.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_writer.hpp"
#include "platform/io/poses.hpp"
#include "platform/io/scan_session.hpp"
#include "platform/ros/extrinsic.hpp"
#include "platform/ros/message_source.hpp"
#include "platform/ros/ros_messages.hpp"

namespace commerge::app {

namespace {

using platform::RosMessageKind;

struct ImportOptions {
  std::string bag;
  std::string out;
  std::string scan_topic;
  std::string pose_topic;
  std::string extrinsic;  // "x y z roll pitch yaw" [m, deg]: T_body_sensor
  std::string gt;         // ground truth of the body (TUM / CSV with times: at the scans' stamps; KITTI: per scan)
  std::string gt_format = "auto";
  bool force = false;
  double progress_s = 5.0;
};

// One topic of the bag: its type and the message count, for the listing.
struct TopicCount {
  std::string type;
  RosMessageKind kind = RosMessageKind::kUnsupported;
  std::uint64_t messages = 0;
};

// What a topic's messages became during the import.
struct TopicTally {
  std::uint64_t messages = 0;
  std::uint64_t decoded = 0;
  std::uint64_t malformed = 0;  // dropped: the decoder refused the message
  std::string first_error;
  std::uint64_t non_finite_points = 0;
};

std::string KindText(RosMessageKind kind) {
  if (kind == RosMessageKind::kUnsupported) return "-";
  return std::string(platform::IsScanKind(kind) ? "scan (" : "pose (") + platform::RosMessageKindName(kind) + ")";
}

// The topic a kind's messages would come from: the most messages; Odometry before PoseStamped for poses.
std::string Suggest(const std::map<std::string, TopicCount>& topics, bool scan) {
  std::string best;
  std::uint64_t best_rank = 0;
  for (const auto& [topic, t] : topics) {
    if (t.kind == RosMessageKind::kUnsupported || platform::IsScanKind(t.kind) != scan) continue;
    const std::uint64_t rank = t.messages * 2 + (t.kind == RosMessageKind::kOdometry ? 1 : 0);
    if (best.empty() || rank > best_rank) {
      best = topic;
      best_rank = rank;
    }
  }
  return best;
}

int ListTopics(platform::RosMessageSource* reader, const std::string& bag) {
  std::map<std::string, TopicCount> topics;
  for (;;) {
    auto item = reader->Next();
    if (!item.ok()) {
      std::fprintf(stderr, "commerge import: %s\n", item.status().message().c_str());
      return kExitFailure;
    }
    if (*item == platform::RosMessageSource::Item::kEnd) break;
    if (*item == platform::RosMessageSource::Item::kChannel) {
      const auto& c = reader->channel();
      TopicCount& t = topics[c.topic];
      t.type = c.type;
      t.kind = platform::RosMessageKindOf(c.type);
    } else {
      topics[reader->FindChannel(reader->message().channel_id)->topic].messages++;
    }
  }
  std::uint64_t messages = 0;
  for (const auto& entry : topics) messages += entry.second.messages;
  std::printf("%s (%s): %zu topics, %" PRIu64 " messages\n", bag.c_str(), reader->format(), topics.size(), messages);
  std::printf("  %-40s %-36s %10s  %s\n", "topic", "type", "messages", "commerge reads it as");
  for (const auto& [topic, t] : topics) {
    std::printf("  %-40s %-36s %10" PRIu64 "  %s\n", topic.c_str(), t.type.c_str(), t.messages, KindText(t.kind).c_str());
  }
  const std::string scan = Suggest(topics, true), pose = Suggest(topics, false);
  if (scan.empty() || pose.empty()) {
    std::printf("would take: nothing: the bag has %s\n",
                scan.empty() ? "no point cloud topic (PointCloud2, Livox CustomMsg)"
                             : "no pose topic (Odometry, PoseStamped)");
  } else {
    std::printf("would take: --scan-topic %s --pose-topic %s\n", scan.c_str(), pose.c_str());
  }
  return kExitOk;
}

class BagImport {
 public:
  BagImport(const ImportOptions& o, const Eigen::Isometry3d& T_body_sensor)
      : o_(o), T_body_sensor_(T_body_sensor), sync_(SyncParams()) {}

  // The live input's rules, with room for the largest scan the live input carries (one 128 x 2048 scan): the
  // robot that reads the import applies its own budget's limit.
  static ScanOdometrySyncParams SyncParams() {
    ScanOdometrySyncParams p;
    p.max_points_per_scan = kMaxLidarScanPoints;
    return p;
  }

  int Run(platform::RosMessageSource* reader);

 private:
  Status OnChannel(const platform::RosChannel& c);
  Status OnMessage(const platform::RosRecord& m);
  Status Drain();
  void HoldPointTimes(std::int64_t utime_us);
  Status WritePointTimes(std::int64_t utime_us, std::size_t k, std::size_t points);
  void Progress(const platform::RosMessageSource& reader, bool last);
  Status Finish();
  Status WriteGroundTruth() const;
  void PrintSummary() const;

  const ImportOptions& o_;
  Eigen::Isometry3d T_body_sensor_;
  ScanOdometrySync sync_;
  // Channel id -> its message kind and encoding.
  std::map<std::uint32_t, std::pair<RosMessageKind, platform::RosEncoding>> scan_channels_, pose_channels_;
  std::string scan_type_, pose_type_;
  TopicTally scans_, poses_;
  platform::RosScan scan_;
  // Per-point times of the scans the synchroniser holds, by stamp (at most max_pending_scans + 1 entries).
  std::map<std::int64_t, std::vector<float>> point_times_;
  std::string point_time_field_;
  std::size_t point_time_files_ = 0;
  platform::RosPose pose_;
  std::vector<Eigen::Isometry3d> T_odom_sensor_;
  std::vector<double> times_s_;
  std::int64_t first_utime_us_ = 0;
  std::chrono::steady_clock::time_point last_progress_ = std::chrono::steady_clock::now();
};

Status BagImport::OnChannel(const platform::RosChannel& c) {
  const bool scan = c.topic == o_.scan_topic, pose = c.topic == o_.pose_topic;
  if (!scan && !pose) return Status::Ok();
  const RosMessageKind kind = platform::RosMessageKindOf(c.type);
  if (scan && !platform::IsScanKind(kind)) {
    return InvalidArgument("--scan-topic " + c.topic + ": type " + c.type +
                           " is not a point cloud commerge reads (sensor_msgs/PointCloud2, livox_ros_driver/CustomMsg, "
                           "livox_ros_driver2/CustomMsg)");
  }
  if (pose && (kind == RosMessageKind::kUnsupported || platform::IsScanKind(kind))) {
    return InvalidArgument("--pose-topic " + c.topic + ": type " + c.type +
                           " is not a pose commerge reads (nav_msgs/Odometry, geometry_msgs/PoseStamped)");
  }
  (scan ? scan_channels_ : pose_channels_)[c.id] = {kind, c.encoding};
  (scan ? scan_type_ : pose_type_) = c.type;
  return Status::Ok();
}

Status BagImport::OnMessage(const platform::RosRecord& m) {
  if (auto it = scan_channels_.find(m.channel_id); it != scan_channels_.end()) {
    const auto [kind, enc] = it->second;
    scans_.messages++;
    const Status st = kind == RosMessageKind::kPointCloud2
                          ? platform::DecodePointCloud2(enc, m.data, platform::RosScanLimits{}, &scan_)
                          : platform::DecodeLivoxCustomMsg(enc, m.data, platform::RosScanLimits{}, &scan_);
    if (!st.ok()) {
      if (scans_.malformed++ == 0) scans_.first_error = "message " + std::to_string(m.index) + ": " + st.message();
      return Status::Ok();
    }
    scans_.decoded++;
    scans_.non_finite_points += scan_.non_finite_dropped;
    sync_.PushScan(scan_.stamp_ns / 1000, Span<const PointXYZI>(scan_.points));
    HoldPointTimes(scan_.stamp_ns / 1000);
    return Drain();
  }
  if (auto it = pose_channels_.find(m.channel_id); it != pose_channels_.end()) {
    const auto [kind, enc] = it->second;
    poses_.messages++;
    const Status st = kind == RosMessageKind::kOdometry ? platform::DecodeOdometry(enc, m.data, &pose_)
                                                              : platform::DecodePoseStamped(enc, m.data, &pose_);
    if (!st.ok()) {
      if (poses_.malformed++ == 0) poses_.first_error = "message " + std::to_string(m.index) + ": " + st.message();
      return Status::Ok();
    }
    poses_.decoded++;
    sync_.PushOdometry(pose_.stamp_ns / 1000, pose_.T_parent_child * T_body_sensor_);
    return Drain();
  }
  return Status::Ok();
}

Status BagImport::Drain() {
  SyncedScan s;
  while (sync_.PopReady(&s)) {
    if (T_odom_sensor_.empty()) first_utime_us_ = s.utime_us;
    const std::string path = o_.out + "/velodyne/" + platform::KittiScanFileName(T_odom_sensor_.size());
    if (Status st = platform::WriteKittiBin(path, s.points); !st.ok()) return st;
    if (Status st = WritePointTimes(s.utime_us, T_odom_sensor_.size(), s.points.size()); !st.ok()) return st;
    T_odom_sensor_.push_back(s.T_odom_sensor);
    times_s_.push_back(1e-6 * static_cast<double>(s.utime_us - first_utime_us_));
  }
  return Status::Ok();
}

// The cloud's per-point times (Ouster t, Velodyne time, Hesai timestamp, Livox offset_time) are kept beside the
// scan, in point_times/<k>.bin (float32 seconds after the scan's stamp, one per point of velodyne/<k>.bin): the
// KITTI record has no field for them.
void BagImport::HoldPointTimes(std::int64_t utime_us) {
  if (scan_.point_time_s.empty()) return;
  point_time_field_ = scan_.point_time_field;
  point_times_[utime_us] = scan_.point_time_s;
  while (point_times_.size() > ScanOdometrySyncParams{}.max_pending_scans + 1) point_times_.erase(point_times_.begin());
}

Status BagImport::WritePointTimes(std::int64_t utime_us, std::size_t k, std::size_t points) {
  auto it = point_times_.find(utime_us);
  if (it == point_times_.end()) return Status::Ok();
  std::vector<float> times = std::move(it->second);
  point_times_.erase(point_times_.begin(), std::next(it));
  if (times.size() != points) return Status::Ok();  // another scan of the same stamp: not this one's times
  const std::string dir = o_.out + "/point_times";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string path = dir + "/" + platform::KittiScanFileName(k);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return IoError(path + ": cannot write");
  const bool ok = std::fwrite(times.data(), sizeof(float), times.size(), f) == times.size();
  if (std::fclose(f) != 0 || !ok) return IoError(path + ": cannot write");
  ++point_time_files_;
  return Status::Ok();
}

void BagImport::Progress(const platform::RosMessageSource& reader, bool last) {
  const auto now = std::chrono::steady_clock::now();
  if (!last && std::chrono::duration<double>(now - last_progress_).count() < o_.progress_s) return;
  last_progress_ = now;
  const double size = static_cast<double>(reader.size());
  std::fprintf(stderr, "commerge import: %5.1f %% of %.1f MB read, %zu scans written\n",
               size > 0.0 ? 100.0 * static_cast<double>(reader.position()) / size : 100.0, size / 1e6,
               T_odom_sensor_.size());
}

Status BagImport::Finish() {
  sync_.DropWaiting();
  if (Status st = Drain(); !st.ok()) return st;
  if (scan_type_.empty()) return NotFound(o_.bag + ": no topic " + o_.scan_topic + " (run without topics to list them)");
  if (pose_type_.empty()) return NotFound(o_.bag + ": no topic " + o_.pose_topic + " (run without topics to list them)");
  if (Status st = platform::WriteKittiPoses(o_.out + "/poses.txt", Span<const Eigen::Isometry3d>(T_odom_sensor_));
      !st.ok()) {
    return st;
  }
  if (Status st = platform::WriteTimes(o_.out + "/times.txt", Span<const double>(times_s_)); !st.ok()) return st;
  if (Status st = WriteGroundTruth(); !st.ok()) return st;
  std::FILE* f = std::fopen((o_.out + "/import_info.txt").c_str(), "w");
  if (f == nullptr) return Status(StatusCode::kIoError, o_.out + "/import_info.txt: cannot write");
  std::fprintf(f, "source: %s\nscan_topic: %s (%s)\npose_topic: %s (%s)\nextrinsic_T_body_sensor: %s\n",
               o_.bag.c_str(), o_.scan_topic.c_str(), scan_type_.c_str(), o_.pose_topic.c_str(), pose_type_.c_str(),
               o_.extrinsic.empty() ? "identity" : o_.extrinsic.c_str());
  std::fprintf(f, "first_scan_stamp_us: %" PRId64 "\nscans: %zu\n", first_utime_us_, T_odom_sensor_.size());
  if (point_time_files_ > 0) {
    std::fprintf(f, "point_times: %zu scans, from field %s (float32 s after the stamp)\n", point_time_files_,
                 point_time_field_.c_str());
  }
  if (std::fclose(f) != 0) return Status(StatusCode::kIoError, o_.out + "/import_info.txt: cannot write");
  return Status::Ok();
}

// --gt: the body's ground truth as poses_gt.txt, one T_gt_sensor = T_gt_body * T_body_sensor per written scan. A
// file with times (TUM, CSV with a time column; the clock of the header stamps) is interpolated at each scan's stamp
// (linear, slerp), and every scan must lie within its span; a file without times (KITTI) has one pose per scan.
Status BagImport::WriteGroundTruth() const {
  if (o_.gt.empty()) return Status::Ok();
  auto format = platform::ParsePoseFileFormat(o_.gt_format);
  if (!format.ok()) return format.status();
  auto gt = platform::ReadTrajectory(o_.gt, *format);
  if (!gt.ok()) return gt.status();
  const std::vector<Eigen::Isometry3d>& T = gt->T_frame_sensor;
  if (T.empty()) return InvalidArgument("--gt " + o_.gt + ": no pose");
  std::vector<Eigen::Isometry3d> T_gt_sensor;
  T_gt_sensor.reserve(times_s_.size());
  for (std::size_t k = 0; k < times_s_.size(); ++k) {
    if (gt->times_s.empty()) {
      if (T.size() != times_s_.size()) {
        return InvalidArgument("--gt " + o_.gt + ": " + std::to_string(T.size()) + " poses without times for " +
                               std::to_string(times_s_.size()) + " scans (give times, TUM or CSV, or one pose per scan)");
      }
      T_gt_sensor.push_back(T[k] * T_body_sensor_);
      continue;
    }
    // Stamps travel in microseconds here: a scan within 1 ms of either end takes the end pose.
    const auto& ts = gt->times_s;
    const double t = 1e-6 * static_cast<double>(first_utime_us_) + times_s_[k];
    if (!(t >= ts.front() - 1e-3 && t <= ts.back() + 1e-3)) {
      char text[160];
      std::snprintf(text, sizeof(text), ": scan %zu at %.6f s lies outside its times %.6f .. %.6f s", k, t,
                    ts.front(), ts.back());
      return InvalidArgument("--gt " + o_.gt + text);
    }
    const double t_in = std::clamp(t, ts.front(), ts.back());
    const std::size_t b = static_cast<std::size_t>(std::lower_bound(ts.begin(), ts.end(), t_in) - ts.begin());
    const std::size_t a = ts[b] == t_in ? b : b - 1;
    const double fraction = a == b ? 0.0 : (t_in - ts[a]) / (ts[b] - ts[a]);
    T_gt_sensor.push_back(InterpolatePose(T[a], T[b], fraction) * T_body_sensor_);
  }
  return platform::WriteKittiPoses(o_.out + "/poses_gt.txt", Span<const Eigen::Isometry3d>(T_gt_sensor));
}

void BagImport::PrintSummary() const {
  const ScanOdometrySyncStats& s = sync_.stats();
  std::printf("%s -> %s: %zu scans with poses (velodyne/*.bin, poses.txt, times.txt)\n", o_.bag.c_str(),
              o_.out.c_str(), T_odom_sensor_.size());
  if (point_time_files_ > 0) {
    std::printf("  per-point times of %zu scans (field %s) in point_times/*.bin\n", point_time_files_,
                point_time_field_.c_str());
  }
  std::printf("  %s (%s): %" PRIu64 " messages, %" PRIu64 " malformed (dropped), %" PRIu64
              " non-finite points dropped\n",
              o_.scan_topic.c_str(), scan_type_.c_str(), scans_.messages, scans_.malformed, scans_.non_finite_points);
  std::printf("  %s (%s): %" PRIu64 " messages, %" PRIu64 " malformed (dropped)\n", o_.pose_topic.c_str(),
              pose_type_.c_str(), poses_.messages, poses_.malformed);
  for (const TopicTally* t : {&scans_, &poses_}) {
    if (t->malformed > 0) std::printf("  first malformed: %s\n", t->first_error.c_str());
  }
  std::printf("  scans dropped by the synchroniser: %" PRIu64 " (before the first pose %" PRIu64 ", pose gap %" PRIu64
              ", time not increasing %" PRIu64 ", too many points %" PRIu64 ", queue full %" PRIu64
              ", no pose after them %" PRIu64 ")\n",
              s.scans_dropped(), s.scans_dropped_before_odometry, s.scans_dropped_odometry_gap,
              s.scans_dropped_time_not_increasing, s.scans_dropped_too_many_points, s.scans_dropped_queue_full,
              s.scans_dropped_at_end);
  std::printf("  poses rejected: %" PRIu64 " (not a rigid transform %" PRIu64 ", time not increasing %" PRIu64
              ", faster than %.0f m/s %" PRIu64 ")\n",
              s.odometry_rejected(), s.odometry_rejected_invalid, s.odometry_rejected_time_not_increasing,
              ScanOdometrySyncParams{}.max_speed_mps, s.odometry_rejected_speed);
}

int BagImport::Run(platform::RosMessageSource* reader) {
  Status st = Status::Ok();
  for (;;) {
    auto item = reader->Next();
    if (!item.ok()) {
      st = item.status();
      break;
    }
    if (*item == platform::RosMessageSource::Item::kEnd) break;
    st = *item == platform::RosMessageSource::Item::kChannel ? OnChannel(reader->channel())
                                                              : OnMessage(reader->message());
    if (!st.ok()) break;
    Progress(*reader, false);
  }
  if (st.ok()) st = Finish();
  if (!st.ok()) {
    std::fprintf(stderr, "commerge import: %s\n", st.message().c_str());
    return st.code() == StatusCode::kInvalidArgument ? kExitUsage : kExitFailure;
  }
  Progress(*reader, true);
  PrintSummary();
  if (T_odom_sensor_.empty()) {
    std::fprintf(stderr, "commerge import: %s: no scan could be paired with a pose (see the counts above)\n",
                 o_.bag.c_str());
    return kExitFailure;
  }
  return kExitOk;
}

int RunImport(const ImportOptions& o, const SessionImportOptions& session) {
  std::error_code ec;
  if (std::filesystem::is_directory(o.bag, ec)) {
    if (!o.scan_topic.empty() || !o.pose_topic.empty() || !o.extrinsic.empty()) {
      std::fprintf(stderr, "commerge import: %s is a folder of scans: --scan-topic, --pose-topic and --extrinsic "
                           "apply to recordings; give --poses\n", o.bag.c_str());
      return kExitUsage;
    }
    SessionImportOptions s = session;
    s.dir = o.bag;
    s.out = o.out;
    s.force = o.force;
    s.progress_s = o.progress_s;
    return RunSessionImport(s);
  }
  if (!session.poses.empty()) {
    std::fprintf(stderr, "commerge import: %s is a recording: --poses applies to a folder of scans; give "
                         "--pose-topic\n", o.bag.c_str());
    return kExitUsage;
  }
  ImportOptions with_gt = o;
  with_gt.gt = session.gt;
  with_gt.gt_format = session.gt_format;
  auto T_body_sensor = platform::ParseExtrinsic(o.extrinsic);
  if (!T_body_sensor.ok()) {
    std::fprintf(stderr, "commerge import: %s\n", T_body_sensor.status().message().c_str());
    return kExitUsage;
  }
  auto reader = platform::OpenRosMessageSource(o.bag);
  if (!reader.ok()) {
    std::fprintf(stderr, "commerge import: %s\n", reader.status().message().c_str());
    return kExitFailure;
  }
  if (o.scan_topic.empty() && o.pose_topic.empty()) return ListTopics(reader->get(), o.bag);
  if (o.scan_topic.empty() || o.pose_topic.empty() || o.out.empty()) {
    std::fprintf(stderr, "commerge import: give --scan-topic, --pose-topic and --out (or no topic, to list them)\n");
    return kExitUsage;
  }
  if (Status st = PrepareImportOutput(o.out, o.force); !st.ok()) {
    std::fprintf(stderr, "commerge import: %s\n", st.message().c_str());
    return kExitFailure;
  }
  auto job = std::make_unique<BagImport>(with_gt, *T_body_sensor);
  return job->Run(reader->get());
}

}  // namespace

Command AddImportCommand(CLI::App& root) {
  auto o = std::make_shared<ImportOptions>();
  auto session = std::make_shared<SessionImportOptions>();
  CLI::App* cmd = root.add_subcommand(
      "import",
      "Convert a ROS recording (ROS 1 bag, MCAP, rosbag2 .db3) or a folder of scans with a pose file into a "
      "KITTI-layout directory for run, robot --data and feed; a recording without topics: list its topics");
  cmd->add_option("input", o->bag,
                  "A recording (ROS 1 bag: chunks uncompressed, bz2 or lz4; MCAP: chunks none, lz4 or zstd; rosbag2 "
                  ".db3), or a folder of .pcd / .ply / .bin scans")
      ->required();
  cmd->add_option("--out", o->out,
                  "Output directory (velodyne/*.bin, poses.txt, times.txt, import_info.txt; point_times/ when the "
                  "clouds carry per-point times; poses_gt.txt with --gt)");
  cmd->add_option("--scan-topic", o->scan_topic,
                  "Recording: point clouds in the sensor (or body) frame: sensor_msgs/PointCloud2, "
                  "livox_ros_driver/CustomMsg or livox_ros_driver2/CustomMsg");
  cmd->add_option("--pose-topic", o->pose_topic,
                  "Recording: odometry of the body: nav_msgs/Odometry or geometry_msgs/PoseStamped; scans get the pose "
                  "interpolated at their header stamp");
  cmd->add_option("--extrinsic", o->extrinsic,
                  "Recording: T_body_sensor as \"x y z roll pitch yaw\" [m, deg] (default identity: the clouds are in "
                  "the pose's body frame)");
  cmd->add_option("--poses", session->poses,
                  "Folder of scans: one pose per scan, paired by index (KITTI 3x4, TUM, or CSV with a header line)");
  cmd->add_option("--pose-format", session->pose_format, "Format of --poses")
      ->check(CLI::IsMember({"auto", "kitti", "tum", "csv"}))
      ->capture_default_str();
  cmd->add_option("--gt", session->gt,
                  "Ground truth, written as poses_gt.txt: folder of scans: one pose per scan; recording: the body's "
                  "poses with times (TUM, CSV) interpolated at the scans' stamps, or one per imported scan (KITTI)");
  cmd->add_option("--gt-format", session->gt_format, "Format of --gt")
      ->check(CLI::IsMember({"auto", "kitti", "tum", "csv"}))
      ->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace an earlier import in --out");
  cmd->add_option("--progress-s", o->progress_s, "Seconds between progress lines on stderr")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  return {cmd, [o, session]() -> int { return RunImport(*o, *session); }};
}

}  // namespace commerge::app
