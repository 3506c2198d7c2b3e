// SPDX-License-Identifier: BSD-3-Clause
// A scan session as offline mergers store one (LT-mapper, LAMM, KISS-Matcher examples): a folder of scans
// (NNNNNN.pcd, .ply or KITTI .bin; the sensor frame) and a pose file with one sensor pose per scan, in one of
//   KITTI   12 numbers per line: the row-major 3x4 [R|t] of T_frame_sensor (platform/io/poses.hpp);
//   TUM     "t x y z qx qy qz qw" per line, '#' comment lines (platform/io/poses.hpp);
//   CSV     a header line naming the columns, then one row per pose (ReadTrajectory below).
// Scans and poses are paired by index: scan k (in the session's order) has pose k, so their counts must match.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/status.hpp"

namespace commerge::platform {

enum class PoseFileFormat { kAuto, kKitti, kTum, kCsv };

/// "auto", "kitti", "tum", "csv".
const char* PoseFileFormatName(PoseFileFormat format);
/// The inverse of PoseFileFormatName; an invalid argument naming `text` and the choices otherwise.
Result<PoseFileFormat> ParsePoseFileFormat(const std::string& text);

/// One pose per line of a pose file, in file order.
struct Trajectory {
  PoseFileFormat format = PoseFileFormat::kAuto;  ///< the format read (never kAuto)
  std::vector<Eigen::Isometry3d> T_frame_sensor;
  std::vector<double> times_s;  ///< one per pose (TUM, CSV with a time column), else empty
};

/// Reads a trajectory. kAuto decides by the first line that is neither blank nor a '#' comment: a line with a
/// ',' or a token that is not a number is a CSV header; 12 numbers are KITTI; 8 numbers are TUM; anything else is
/// an error naming the file and line.
///
/// CSV: the header's delimiter is ',' when it has one (rows must then use ','), else spaces/tabs. Column names are
/// matched case-insensitively after trimming spaces and quotes:
///   x | tx | pos_x | position_x (same for y, z)              required, [m]
///   qx qy qz qw                                               a unit quaternion (normalised; |norm - 1| <= 1e-2)
///   roll pitch yaw                                            [rad], R = Rz(yaw) Ry(pitch) Rx(roll); used when the
///                                                             quaternion columns are absent (one of the two sets
///                                                             is required)
///   t | time | timestamp | time_s | timestamp_s               optional time [s]
///   t_ns | time_ns | timestamp_ns                             optional time [ns] (converted to s)
/// Other columns are ignored (an index, covariances, text). Blank and '#' lines are skipped. Every row has the
/// header's number of fields; a used value that is not a finite number is an error.
/// Errors (data loss; not found for a missing file) name the file and the 1-based line. Times, when present,
/// must increase strictly (poses are paired with scans in file order).
Result<Trajectory> ReadTrajectory(const std::string& path, PoseFileFormat format = PoseFileFormat::kAuto);

struct ScanSessionOptions {
  PoseFileFormat pose_format = PoseFileFormat::kAuto;
};

struct ScanSession {
  std::string dir;
  std::string pose_file;
  std::string scan_extension;           ///< ".pcd", ".ply" or ".bin" (lower case)
  bool ordered_by_number = false;       ///< true: by the number in the file name; false: by name
  std::vector<std::string> scan_files;  ///< paths, in session order
  Trajectory trajectory;                ///< one pose (and time, when the file has times) per scan
  std::vector<std::string> ignored;     ///< other entries of `dir` (file names; folders end with '/')
};

/// Lists the scans of `dir` (not recursive): the regular files ending in .pcd, .ply or .bin (any case), all of
/// one kind (a mix is an invalid argument naming the counts). Order: by the number in the file name when every
/// name has one and no two are equal, else by name. The number of a name is its stem when the stem is a decimal
/// number ("000123", "1565432123.123456"), else the stem's last run of digits ("scan_12" -> 12); numbers compare
/// exactly (any length). Then reads `pose_file` (ReadTrajectory) and pairs pose k with scan k: the counts must
/// match (an invalid argument naming both counts). Other entries of `dir` are listed in `ignored`. Errors name
/// the directory or file.
Result<ScanSession> OpenScanSession(const std::string& dir, const std::string& pose_file,
                                    const ScanSessionOptions& options = {});

}  // namespace commerge::platform
