// SPDX-License-Identifier: BSD-3-Clause
#include "apps/import_session.hpp"

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "apps/app_common.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/kitti_dataset_writer.hpp"
#include "platform/io/point_cloud_file.hpp"
#include "platform/io/poses.hpp"
#include "platform/io/scan_session.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::app {

namespace session_import_impl {

namespace fs = std::filesystem;

/// The files an import writes into OUT (besides velodyne/); --force removes exactly these.
constexpr const char* kOutputFiles[] = {"poses.txt", "times.txt", "poses_gt.txt", "import_info.txt"};
constexpr std::size_t kMaxListedFiles = 10;  ///< per-file lines in the summary before "... and N more"

std::string Canonical(const std::string& path) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? path : p.lexically_normal().string();
}

/// OUT must not be the session folder, and --force must not remove an input file.
Status CheckOutputIsNotInput(const SessionImportOptions& o) {
  const std::string out = Canonical(o.out);
  if (out == Canonical(o.dir)) return InvalidArgument("--out " + o.out + ": is the scan folder; choose another");
  for (const std::string* input : {&o.poses, &o.gt}) {
    if (input->empty()) continue;
    for (const char* name : kOutputFiles) {
      if (Canonical(*input) == Canonical(o.out + "/" + name)) {
        return InvalidArgument(*input + ": the import would overwrite this input file (it writes " + o.out + "/" +
                               name + "); choose another --out");
      }
    }
  }
  return Status::Ok();
}

std::string FormatName(platform::PoseFileFormat f) {
  switch (f) {
    case platform::PoseFileFormat::kKitti: return "KITTI 3x4";
    case platform::PoseFileFormat::kTum: return "TUM";
    case platform::PoseFileFormat::kCsv: return "CSV";
    case platform::PoseFileFormat::kAuto: break;
  }
  return "auto";
}

/// Point counts of the converted scans.
struct ScanTally {
  std::uint64_t points = 0;
  std::uint64_t dropped_nonfinite = 0;
  std::vector<std::pair<std::string, std::size_t>> files_with_drops;  ///< file name, points dropped
  std::size_t robot_fields = 0;                                       ///< scans whose robot field was left out
};

class SessionImport {
 public:
  SessionImport(const SessionImportOptions& o, platform::ScanSession session, platform::Trajectory gt)
      : o_(o), session_(std::move(session)), gt_(std::move(gt)) {}
  Status Run();
  void PrintSummary() const;

 private:
  Status ConvertScans();
  Status WriteTrajectories();
  Status WriteInfo() const;
  void Progress(std::size_t done, bool last);

  const SessionImportOptions& o_;
  platform::ScanSession session_;
  platform::Trajectory gt_;  ///< empty without --gt
  ScanTally tally_;
  std::chrono::steady_clock::time_point last_progress_ = std::chrono::steady_clock::now();
};

Status SessionImport::Run() {
  if (Status s = ConvertScans(); !s.ok()) return s;
  if (Status s = WriteTrajectories(); !s.ok()) return s;
  return WriteInfo();
}

Status SessionImport::ConvertScans() {
  const std::vector<std::string>& files = session_.scan_files;
  for (std::size_t k = 0; k < files.size(); ++k) {
    auto cloud = platform::ReadPointCloud(files[k]);
    if (!cloud.ok()) return cloud.status();
    const std::string out = o_.out + "/velodyne/" + platform::KittiScanFileName(k);
    if (Status s = platform::WriteKittiBin(out, Span<const PointXYZI>(cloud->points)); !s.ok()) return s;
    tally_.points += cloud->points.size();
    tally_.dropped_nonfinite += cloud->dropped_nonfinite;
    if (cloud->dropped_nonfinite > 0) {
      tally_.files_with_drops.emplace_back(fs::path(files[k]).filename().string(), cloud->dropped_nonfinite);
    }
    if (!cloud->robot_ids.empty()) tally_.robot_fields++;
    Progress(k + 1, k + 1 == files.size());
  }
  return Status::Ok();
}

Status SessionImport::WriteTrajectories() {
  const platform::Trajectory& t = session_.trajectory;
  Status s = platform::WriteKittiPoses(o_.out + "/poses.txt", Span<const Eigen::Isometry3d>(t.T_frame_sensor));
  if (s.ok() && !t.times_s.empty()) s = platform::WriteTimes(o_.out + "/times.txt", Span<const double>(t.times_s));
  if (s.ok() && !o_.gt.empty()) {
    s = platform::WriteKittiPoses(o_.out + "/poses_gt.txt", Span<const Eigen::Isometry3d>(gt_.T_frame_sensor));
  }
  return s;
}

Status SessionImport::WriteInfo() const {
  std::string text = "source: " + session_.dir + "\nscans: " + std::to_string(session_.scan_files.size()) + " " +
                     session_.scan_extension + "\norder: " +
                     (session_.ordered_by_number ? "by the number in the file name" : "by file name") +
                     "\nposes: " + session_.pose_file + " (" + FormatName(session_.trajectory.format) + ")\n";
  if (!o_.gt.empty()) text += "ground_truth: " + o_.gt + " (" + FormatName(gt_.format) + ")\n";
  text += "points: " + std::to_string(tally_.points) + "\nnon_finite_points_dropped: " +
          std::to_string(tally_.dropped_nonfinite) + "\n";
  return platform::io_detail::WriteTextFile(o_.out + "/import_info.txt", text);
}

void SessionImport::Progress(std::size_t done, bool last) {
  const auto now = std::chrono::steady_clock::now();
  if (!last && std::chrono::duration<double>(now - last_progress_).count() < o_.progress_s) return;
  last_progress_ = now;
  const std::size_t total = session_.scan_files.size();
  std::fprintf(stderr, "commerge import: %zu of %zu scans (%.1f %%), %" PRIu64 " points\n", done, total,
               100.0 * static_cast<double>(done) / static_cast<double>(total), tally_.points);
}

/// "a, b, c ... and N more" of at most kMaxListedFiles names.
std::string ListNames(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t i = 0; i < names.size() && i < kMaxListedFiles; ++i) text += (i ? ", " : "") + names[i];
  if (names.size() > kMaxListedFiles) text += " ... and " + std::to_string(names.size() - kMaxListedFiles) + " more";
  return text;
}

/// The largest |t_gt - t_pose| over the scans, when both files have times; negative otherwise.
double MaxTimeDifference(const platform::Trajectory& a, const platform::Trajectory& b) {
  if (a.times_s.empty() || b.times_s.size() != a.times_s.size()) return -1.0;
  double worst = 0.0;
  for (std::size_t k = 0; k < a.times_s.size(); ++k) worst = std::max(worst, std::abs(a.times_s[k] - b.times_s[k]));
  return worst;
}

void SessionImport::PrintSummary() const {
  const platform::Trajectory& t = session_.trajectory;
  std::printf("%s -> %s: %zu scans (%s, ordered %s), %" PRIu64 " points (velodyne/*.bin, poses.txt%s%s)\n",
              session_.dir.c_str(), o_.out.c_str(), session_.scan_files.size(), session_.scan_extension.c_str(),
              session_.ordered_by_number ? "by the number in the file name" : "by file name", tally_.points,
              t.times_s.empty() ? "" : ", times.txt", o_.gt.empty() ? "" : ", poses_gt.txt");
  std::printf("  poses: %s (%s, %zu poses%s)\n", session_.pose_file.c_str(), FormatName(t.format).c_str(),
              t.T_frame_sensor.size(), t.times_s.empty() ? ", no times" : "");
  if (!o_.gt.empty()) {
    std::printf("  ground truth: %s (%s, %zu poses)\n", o_.gt.c_str(), FormatName(gt_.format).c_str(),
                gt_.T_frame_sensor.size());
    const double dt = MaxTimeDifference(t, gt_);
    if (dt >= 0.0) std::printf("  ground-truth times differ from the poses' by at most %.6g s\n", dt);
  }
  std::printf("  non-finite points dropped: %" PRIu64 " in %zu files\n", tally_.dropped_nonfinite,
              tally_.files_with_drops.size());
  for (std::size_t i = 0; i < tally_.files_with_drops.size() && i < kMaxListedFiles; ++i) {
    std::printf("    %s: %zu\n", tally_.files_with_drops[i].first.c_str(), tally_.files_with_drops[i].second);
  }
  if (tally_.files_with_drops.size() > kMaxListedFiles) {
    std::printf("    ... and %zu more files\n", tally_.files_with_drops.size() - kMaxListedFiles);
  }
  if (tally_.robot_fields > 0) std::printf("  robot field left out (KITTI .bin has none): %zu scans\n", tally_.robot_fields);
  if (!session_.ignored.empty()) {
    std::printf("  skipped, not %s scans: %zu (%s)\n", session_.scan_extension.c_str(), session_.ignored.size(),
                ListNames(session_.ignored).c_str());
  }
}

int Fail(const Status& st) {
  std::fprintf(stderr, "commerge import: %s\n", st.message().c_str());
  return st.code() == StatusCode::kInvalidArgument ? kExitUsage : kExitFailure;
}

/// The ground truth of --gt, one pose per scan (empty without --gt).
Result<platform::Trajectory> ReadGroundTruth(const SessionImportOptions& o, const platform::ScanSession& session) {
  if (o.gt.empty()) return platform::Trajectory{};
  auto format = platform::ParsePoseFileFormat(o.gt_format);
  if (!format.ok()) return InvalidArgument("--gt-format: " + format.status().message());
  auto gt = platform::ReadTrajectory(o.gt, *format);
  if (!gt.ok()) return gt.status();
  if (gt->T_frame_sensor.size() != session.scan_files.size()) {
    return InvalidArgument(o.gt + ": " + std::to_string(gt->T_frame_sensor.size()) + " ground-truth poses for the " +
                           std::to_string(session.scan_files.size()) + " scans in " + session.dir +
                           " (paired by index, so the counts must match)");
  }
  return gt;
}

}  // namespace session_import_impl

Status PrepareImportOutput(const std::string& out, bool force) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_empty(out, ec)) {
    if (!force) return InvalidArgument(out + ": exists and is not empty (--force replaces an import)");
    fs::remove_all(out + "/velodyne", ec);
    fs::remove_all(out + "/point_times", ec);
    for (const char* f : session_import_impl::kOutputFiles) fs::remove(out + "/" + f, ec);
  }
  fs::create_directories(out + "/velodyne", ec);
  if (ec) return Status(StatusCode::kIoError, out + "/velodyne: cannot create: " + ec.message());
  return Status::Ok();
}

int RunSessionImport(const SessionImportOptions& o) {
  using namespace session_import_impl;
  if (o.dir.empty() || o.poses.empty() || o.out.empty()) {
    return Fail(InvalidArgument("a scan folder needs --poses FILE and --out DIR (and optionally --gt FILE)"));
  }
  auto format = platform::ParsePoseFileFormat(o.pose_format);
  if (!format.ok()) return Fail(InvalidArgument("--pose-format: " + format.status().message()));
  if (Status st = CheckOutputIsNotInput(o); !st.ok()) return Fail(st);
  platform::ScanSessionOptions session_options;
  session_options.pose_format = *format;
  auto session = platform::OpenScanSession(o.dir, o.poses, session_options);
  if (!session.ok()) return Fail(session.status());
  auto gt = ReadGroundTruth(o, *session);
  if (!gt.ok()) return Fail(gt.status());
  if (Status st = PrepareImportOutput(o.out, o.force); !st.ok()) {
    std::fprintf(stderr, "commerge import: %s\n", st.message().c_str());
    return kExitFailure;
  }
  SessionImport job(o, std::move(*session), std::move(*gt));
  if (Status st = job.Run(); !st.ok()) {
    std::fprintf(stderr, "commerge import: %s\n", st.message().c_str());
    return kExitFailure;
  }
  job.PrintSummary();
  return kExitOk;
}

}  // namespace commerge::app
