// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/scan_session.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>

#include "platform/io/file_util.hpp"
#include "platform/io/poses.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::platform {

namespace scan_session_impl {

namespace fs = std::filesystem;
using io_detail::LineError;

constexpr double kQuaternionTolerance = 1e-2;  ///< as TUM files (poses.hpp)
constexpr double kMinQuaternionNorm = 1e-6;

std::string Lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
  return out;
}

bool IsComment(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t");
  return first != std::string_view::npos && line[first] == '#';
}

bool IsSkipped(std::string_view line) { return io_detail::IsBlank(line) || IsComment(line); }

std::string_view Trim(std::string_view s, const char* chars) {
  const std::size_t first = s.find_first_not_of(chars);
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(chars) - first + 1);
}

/// Fields of a CSV line: split on `delimiter` (',') and trimmed, or split on spaces and tabs (delimiter 0).
void SplitFields(std::string_view line, char delimiter, std::vector<std::string_view>* fields) {
  if (delimiter == 0) {
    io_detail::SplitTokens(line, fields);
    return;
  }
  fields->clear();
  for (std::size_t start = 0;;) {
    const std::size_t end = line.find(delimiter, start);
    fields->push_back(Trim(line.substr(start, end == std::string_view::npos ? end : end - start), " \t"));
    if (end == std::string_view::npos) return;
    start = end + 1;
  }
}

// ---- format detection ---------------------------------------------------------------------------------------

Result<PoseFileFormat> DetectFormat(const std::string& path, const std::string& text) {
  io_detail::LineCursor lines(text);
  std::string_view line;
  while (lines.Next(&line)) {
    if (IsSkipped(line)) continue;
    std::vector<std::string_view> tokens;
    io_detail::SplitTokens(line, &tokens);
    double value = 0.0;
    const bool numeric = std::all_of(tokens.begin(), tokens.end(),
                                     [&value](std::string_view t) { return io_detail::ParseNumber(t, &value); });
    if (line.find(',') != std::string_view::npos || !numeric) return PoseFileFormat::kCsv;
    if (tokens.size() == 12) return PoseFileFormat::kKitti;
    if (tokens.size() == 8) return PoseFileFormat::kTum;
    return DataLoss(LineError(path, lines.line_number(),
                              std::to_string(tokens.size()) + " numbers: not a pose file format commerge knows (KITTI: "
                              "12 numbers per line; TUM: 8, t x y z qx qy qz qw; CSV: a header line naming the columns)"));
  }
  return DataLoss(path + ": holds no pose (only blank or '#' lines)");
}

// ---- CSV ----------------------------------------------------------------------------------------------------

enum CsvColumn { kX, kY, kZ, kQx, kQy, kQz, kQw, kRoll, kPitch, kYaw, kTime, kNumCsvColumns };

struct CsvAlias {
  const char* name;
  CsvColumn column;
  double scale;  ///< to SI units (time in ns -> s)
};

constexpr CsvAlias kCsvAliases[] = {
    {"x", kX, 1},         {"tx", kX, 1},           {"pos_x", kX, 1},           {"position_x", kX, 1},
    {"y", kY, 1},         {"ty", kY, 1},           {"pos_y", kY, 1},           {"position_y", kY, 1},
    {"z", kZ, 1},         {"tz", kZ, 1},           {"pos_z", kZ, 1},           {"position_z", kZ, 1},
    {"qx", kQx, 1},       {"qy", kQy, 1},          {"qz", kQz, 1},             {"qw", kQw, 1},
    {"roll", kRoll, 1},   {"pitch", kPitch, 1},    {"yaw", kYaw, 1},           {"t", kTime, 1},
    {"time", kTime, 1},   {"timestamp", kTime, 1}, {"time_s", kTime, 1},       {"timestamp_s", kTime, 1},
    {"t_ns", kTime, 1e-9}, {"time_ns", kTime, 1e-9}, {"timestamp_ns", kTime, 1e-9}};

/// Where each used column is (-1: absent), the delimiter (0: spaces/tabs) and the number of fields per row.
struct CsvLayout {
  int index[kNumCsvColumns];
  double time_scale = 1.0;
  char delimiter = 0;
  std::size_t fields = 0;
  bool quaternion = false;  ///< else roll pitch yaw
};

Status AssignCsvColumn(const std::string& path, std::size_t line_number, std::string_view field, int i,
                       CsvLayout* layout) {
  const std::string name = Lower(Trim(field, " \t\"'"));
  for (const CsvAlias& alias : kCsvAliases) {
    if (name != alias.name) continue;
    if (layout->index[alias.column] >= 0) {
      return DataLoss(LineError(path, line_number, "column '" + name + "' (field " + std::to_string(i + 1) +
                                                       ") names a value an earlier column already gives"));
    }
    layout->index[alias.column] = i;
    if (alias.column == kTime) layout->time_scale = alias.scale;
  }
  return Status::Ok();
}

Result<CsvLayout> ParseCsvHeader(const std::string& path, std::size_t line_number, std::string_view line) {
  CsvLayout layout;
  std::fill(std::begin(layout.index), std::end(layout.index), -1);
  layout.delimiter = line.find(',') != std::string_view::npos ? ',' : 0;
  std::vector<std::string_view> fields;
  SplitFields(line, layout.delimiter, &fields);
  layout.fields = fields.size();
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (Status s = AssignCsvColumn(path, line_number, fields[i], static_cast<int>(i), &layout); !s.ok()) return s;
  }
  const auto has = [&layout](std::initializer_list<CsvColumn> columns) {
    return std::all_of(columns.begin(), columns.end(), [&layout](CsvColumn c) { return layout.index[c] >= 0; });
  };
  layout.quaternion = has({kQx, kQy, kQz, kQw});
  if (!has({kX, kY, kZ}) || (!layout.quaternion && !has({kRoll, kPitch, kYaw}))) {
    return DataLoss(LineError(path, line_number, "CSV header '" + std::string(line) + "' lacks columns: it needs " +
                                                     "x, y, z and qx, qy, qz, qw (or roll, pitch, yaw [rad])"));
  }
  return layout;
}

Result<Eigen::Matrix3d> CsvRotation(const std::string& path, std::size_t line_number, const CsvLayout& layout,
                                    const double* v) {
  if (!layout.quaternion) {
    return Eigen::Matrix3d((Eigen::AngleAxisd(v[kYaw], Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(v[kPitch], Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(v[kRoll], Eigen::Vector3d::UnitX()))
                               .toRotationMatrix());
  }
  const Eigen::Quaterniond q(v[kQw], v[kQx], v[kQy], v[kQz]);
  const double norm = q.norm();
  if (norm < kMinQuaternionNorm || std::abs(norm - 1.0) > kQuaternionTolerance) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.3g", norm);
    return DataLoss(LineError(path, line_number, std::string("quaternion norm ") + text + " is not 1 (tolerance 1e-2)"));
  }
  return q.normalized().toRotationMatrix();
}

Status ParseCsvRow(const std::string& path, std::size_t line_number, const std::vector<std::string_view>& fields,
                   const CsvLayout& layout, Trajectory* out) {
  if (fields.size() != layout.fields) {
    return DataLoss(LineError(path, line_number, io_detail::WrongValueCount(layout.fields, fields.size()) +
                                                     " (as many as the header names)"));
  }
  double v[kNumCsvColumns] = {};
  for (int c = 0; c < kNumCsvColumns; ++c) {
    const int i = layout.index[c];
    if (i < 0) continue;
    const std::string_view token = fields[static_cast<std::size_t>(i)];
    if (!io_detail::ParseNumber(token, &v[c]) || !std::isfinite(v[c])) {
      return DataLoss(LineError(path, line_number, "value " + std::to_string(i + 1) + " '" + std::string(token) +
                                                       "' is not a finite number"));
    }
  }
  auto R = CsvRotation(path, line_number, layout, v);
  if (!R.ok()) return R.status();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = *R;
  T.translation() = Eigen::Vector3d(v[kX], v[kY], v[kZ]);
  out->T_frame_sensor.push_back(T);
  if (layout.index[kTime] >= 0) out->times_s.push_back(v[kTime] * layout.time_scale);
  return Status::Ok();
}

Result<Trajectory> ReadCsv(const std::string& path, const std::string& text) {
  io_detail::LineCursor lines(text);
  std::string_view line;
  std::optional<CsvLayout> layout;
  Trajectory out;
  out.format = PoseFileFormat::kCsv;
  std::vector<std::string_view> fields;
  while (lines.Next(&line)) {
    if (IsSkipped(line)) continue;
    if (!layout) {
      auto header = ParseCsvHeader(path, lines.line_number(), line);
      if (!header.ok()) return header.status();
      layout = *header;
      continue;
    }
    SplitFields(line, layout->delimiter, &fields);
    if (Status s = ParseCsvRow(path, lines.line_number(), fields, *layout, &out); !s.ok()) return s;
  }
  if (!layout) return DataLoss(path + ": no CSV header line");
  return out;
}

// ---- trajectories -------------------------------------------------------------------------------------------

Status CheckTimesIncrease(const std::string& path, const std::vector<double>& times_s) {
  for (std::size_t k = 1; k < times_s.size(); ++k) {
    if (!(times_s[k] > times_s[k - 1])) {
      return DataLoss(path + ": pose " + std::to_string(k) + " has time " + io_detail::NumberText(times_s[k]) +
                      " s, not after pose " + std::to_string(k - 1) + "'s " + io_detail::NumberText(times_s[k - 1]) +
                      " s (poses pair with scans in file order, so times must increase)");
    }
  }
  return Status::Ok();
}

Result<Trajectory> ReadKittiOrTum(const std::string& path, PoseFileFormat format) {
  Trajectory out;
  out.format = format;
  if (format == PoseFileFormat::kKitti) {
    auto poses = ReadKittiPoses(path);
    if (!poses.ok()) return poses.status();
    out.T_frame_sensor = std::move(*poses);
    return out;
  }
  auto poses = ReadTumPoses(path);
  if (!poses.ok()) return poses.status();
  for (const StampedPose& p : *poses) {
    out.T_frame_sensor.push_back(p.T_frame_sensor);
    out.times_s.push_back(p.time_s);
  }
  return out;
}

// ---- scan listing -------------------------------------------------------------------------------------------

/// The number in a file name, as digit strings that compare exactly: integer part without leading zeros, then
/// the fraction without trailing zeros.
struct NameNumber {
  std::string integer, fraction;
  bool operator<(const NameNumber& o) const {
    if (integer.size() != o.integer.size()) return integer.size() < o.integer.size();
    if (integer != o.integer) return integer < o.integer;
    return fraction < o.fraction;
  }
  bool operator==(const NameNumber& o) const { return integer == o.integer && fraction == o.fraction; }
};

bool AllDigits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
}

NameNumber MakeNumber(std::string_view integer, std::string_view fraction) {
  NameNumber n;
  const std::size_t first = integer.find_first_not_of('0');
  n.integer = first == std::string_view::npos ? "" : std::string(integer.substr(first));
  const std::size_t last = fraction.find_last_not_of('0');
  n.fraction = last == std::string_view::npos ? "" : std::string(fraction.substr(0, last + 1));
  return n;
}

std::optional<NameNumber> NumberInName(const std::string& stem) {
  const std::size_t dot = stem.find('.');
  if (dot == std::string::npos ? AllDigits(stem) : AllDigits(stem.substr(0, dot)) && AllDigits(stem.substr(dot + 1))) {
    return MakeNumber(std::string_view(stem).substr(0, dot),
                      dot == std::string::npos ? std::string_view() : std::string_view(stem).substr(dot + 1));
  }
  const std::size_t last = stem.find_last_of("0123456789");
  if (last == std::string::npos) return std::nullopt;
  std::size_t first = last;
  while (first > 0 && std::isdigit(static_cast<unsigned char>(stem[first - 1])) != 0) --first;
  return MakeNumber(std::string_view(stem).substr(first, last - first + 1), {});
}

/// The entries of a session folder: scans by (lower-case) extension, and everything else.
struct Listing {
  std::map<std::string, std::vector<std::string>> scans;
  std::vector<std::string> ignored;
};

Result<Listing> ListDir(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return NotFound(dir + ": no such directory (expected a folder of scans)");
  Listing listing;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::error_code type_ec;
    if (it->is_directory(type_ec)) {
      listing.ignored.push_back(name + "/");
      continue;
    }
    const std::string ext = Lower(it->path().extension().string());
    const bool scan = (ext == ".pcd" || ext == ".ply" || ext == ".bin") && it->is_regular_file(type_ec);
    if (scan) {
      listing.scans[ext].push_back(it->path().string());
    } else {
      listing.ignored.push_back(name);
    }
  }
  if (ec) return IoError(dir + ": cannot list: " + ec.message());
  std::sort(listing.ignored.begin(), listing.ignored.end());
  return listing;
}

Status CheckOneKind(const std::string& dir, const Listing& listing) {
  if (listing.scans.empty()) {
    std::error_code ec;
    const bool kitti = fs::is_directory(fs::path(dir) / "velodyne", ec);
    return NotFound(dir + ": holds no scan (.pcd, .ply or .bin files)" +
                    (kitti ? std::string("; it has velodyne/: a KITTI-layout directory, which commerge run reads as it is")
                           : std::string()));
  }
  if (listing.scans.size() == 1) return Status::Ok();
  std::string counts;
  for (const auto& [ext, files] : listing.scans) {
    counts += (counts.empty() ? "" : " and ") + std::to_string(files.size()) + " " + ext;
  }
  return InvalidArgument(dir + ": holds " + counts + " files; a session's scans are of one kind (move the others away)");
}

/// Sorts `files` by the number in their names when every name has a distinct one, else by name.
bool OrderScans(std::vector<std::string>* files) {
  std::sort(files->begin(), files->end());
  std::vector<std::pair<NameNumber, std::string>> keyed;
  for (const std::string& file : *files) {
    const std::optional<NameNumber> number = NumberInName(fs::path(file).stem().string());
    if (!number) return false;
    keyed.emplace_back(*number, file);
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t i = 1; i < keyed.size(); ++i) {
    if (keyed[i].first == keyed[i - 1].first) return false;
  }
  for (std::size_t i = 0; i < keyed.size(); ++i) (*files)[i] = keyed[i].second;
  return true;
}

}  // namespace scan_session_impl

const char* PoseFileFormatName(PoseFileFormat format) {
  switch (format) {
    case PoseFileFormat::kAuto: return "auto";
    case PoseFileFormat::kKitti: return "kitti";
    case PoseFileFormat::kTum: return "tum";
    case PoseFileFormat::kCsv: return "csv";
  }
  return "?";
}

Result<PoseFileFormat> ParsePoseFileFormat(const std::string& text) {
  for (const PoseFileFormat f : {PoseFileFormat::kAuto, PoseFileFormat::kKitti, PoseFileFormat::kTum,
                                 PoseFileFormat::kCsv}) {
    if (scan_session_impl::Lower(text) == PoseFileFormatName(f)) return f;
  }
  return InvalidArgument("pose file format '" + text + "': expected auto, kitti, tum or csv");
}

Result<Trajectory> ReadTrajectory(const std::string& path, PoseFileFormat format) {
  auto text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  if (format == PoseFileFormat::kAuto) {
    auto detected = scan_session_impl::DetectFormat(path, *text);
    if (!detected.ok()) return detected.status();
    format = *detected;
  }
  auto trajectory = format == PoseFileFormat::kCsv ? scan_session_impl::ReadCsv(path, *text)
                                                   : scan_session_impl::ReadKittiOrTum(path, format);
  if (!trajectory.ok()) return trajectory.status();
  if (Status s = scan_session_impl::CheckTimesIncrease(path, trajectory->times_s); !s.ok()) return s;
  return trajectory;
}

Result<ScanSession> OpenScanSession(const std::string& dir, const std::string& pose_file,
                                    const ScanSessionOptions& options) {
  auto listing = scan_session_impl::ListDir(dir);
  if (!listing.ok()) return listing.status();
  if (Status s = scan_session_impl::CheckOneKind(dir, *listing); !s.ok()) return s;
  ScanSession session;
  session.dir = dir;
  session.pose_file = pose_file;
  session.scan_extension = listing->scans.begin()->first;
  session.scan_files = std::move(listing->scans.begin()->second);
  session.ignored = std::move(listing->ignored);
  session.ordered_by_number = scan_session_impl::OrderScans(&session.scan_files);
  auto trajectory = ReadTrajectory(pose_file, options.pose_format);
  if (!trajectory.ok()) return trajectory.status();
  session.trajectory = std::move(*trajectory);
  const std::size_t poses = session.trajectory.T_frame_sensor.size(), scans = session.scan_files.size();
  if (poses != scans) {
    return InvalidArgument(pose_file + ": " + std::to_string(poses) + " poses for the " + std::to_string(scans) + " " +
                           session.scan_extension + " scans in " + dir +
                           " (scans pair with poses by index, so the counts must match)");
  }
  return session;
}

}  // namespace commerge::platform
