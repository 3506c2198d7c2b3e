// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/ros_messages.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

namespace commerge::platform {

// The helpers live in a named namespace: the platform library is built in unity batches, where the anonymous
// namespaces of several .cpp files merge into one.
namespace ros_msg_impl {
namespace {

constexpr std::size_t kCdrHeaderBytes = 4;
constexpr std::uint32_t kNanosPerSecond = 1000000000u;

/// Reads the primitives of one message, ROS 1 (little-endian, packed) or CDR (aligned, either byte order), and
/// checks every read against the buffer. Errors name the message kind, the field and the byte offset (from the
/// start of the message, the CDR encapsulation header included).
class Cursor {
 public:
  Cursor(RosEncoding encoding, Span<const std::uint8_t> message, RosMessageKind kind) noexcept
      : message_(message), kind_(kind), cdr_(encoding == RosEncoding::kCdr) {}

  /// CDR: checks and skips the encapsulation header (CDR_LE or CDR_BE). ROS 1: nothing.
  Status Start() {
    if (!cdr_) return Status::Ok();
    if (message_.size() < kCdrHeaderBytes) return Truncated(0, "the CDR encapsulation header");
    const std::uint8_t id0 = message_[0], id1 = message_[1];
    if (id0 != 0 || id1 > 1) {
      const char* what = (id0 == 0 && id1 <= 3) ? " (PL_CDR, parameter lists)" : "";
      return InvalidArgument(Prefix() + "CDR encapsulation 0x" + Hex(id0) + Hex(id1) + what +
                             " at byte 0 is not supported; expected CDR_LE (0x0001) or CDR_BE (0x0000)");
    }
    big_endian_ = id1 == 0;
    pos_ = kCdrHeaderBytes;
    return Status::Ok();
  }

  /// Names the array element the next reads belong to ("points[3]."); array null: top-level fields.
  void SetElement(const char* array, std::size_t index) noexcept {
    array_ = array;
    index_ = index;
  }

  /// One primitive (uint8, int32, uint32, uint64, float, double): aligned to its size in CDR.
  template <class T>
  Status Read(const char* field, T* value) {
    const std::uint8_t* bytes = nullptr;
    if (Status s = Take(sizeof(T), sizeof(T), field, &bytes); !s.ok()) return s;
    std::uint8_t copy[sizeof(T)];
    std::memcpy(copy, bytes, sizeof(T));
    if (big_endian_) std::reverse(copy, copy + sizeof(T));
    std::memcpy(value, copy, sizeof(T));
    return Status::Ok();
  }

  /// ROS 1: uint32 length + bytes. CDR: uint32 length including a terminating NUL, the bytes, the NUL (a length
  /// of 0, which some writers use for the empty string, is accepted as "").
  Status ReadString(const char* field, std::string* value) {
    std::uint32_t length = 0;
    if (Status s = Read(field, &length); !s.ok()) return s;
    const std::size_t at = pos_;
    const std::uint8_t* bytes = nullptr;
    if (Status s = Take(1, length, field, &bytes); !s.ok()) return s;
    std::size_t chars = length;
    if (cdr_ && length > 0) {
      if (bytes[length - 1] != 0) {
        return DataLoss(Prefix() + "string " + Name(field) + " of " + std::to_string(length) + " bytes at byte " +
                        std::to_string(at) + " does not end with a NUL");
      }
      chars = length - 1;
    }
    value->assign(reinterpret_cast<const char*>(bytes), chars);
    return Status::Ok();
  }

  /// A sequence's uint32 element count, checked against the bytes left (each element takes at least
  /// min_element_bytes), so that nothing is allocated for elements the message cannot hold.
  Status ReadCount(const char* field, std::size_t min_element_bytes, std::uint32_t* count) {
    if (Status s = Read(field, count); !s.ok()) return s;
    const std::uint64_t needed = std::uint64_t{*count} * min_element_bytes;
    if (needed > remaining()) {
      return DataLoss(Prefix() + Name(field) + " announces " + std::to_string(*count) + " elements at byte " +
                      std::to_string(pos_ - 4) + ", which need at least " + std::to_string(needed) +
                      " bytes, but only " + std::to_string(remaining()) + " remain");
    }
    return Status::Ok();
  }

  /// n raw bytes (uint8[] contents), not aligned.
  Status ReadBytes(const char* field, std::size_t n, Span<const std::uint8_t>* bytes) {
    const std::uint8_t* data = nullptr;
    if (Status s = Take(1, n, field, &data); !s.ok()) return s;
    *bytes = Span<const std::uint8_t>(data, n);
    return Status::Ok();
  }

  /// The message must end here: ROS 1 exactly; CDR allows up to 3 bytes of padding to a multiple of 4.
  Status Finish() const {
    const std::size_t left = remaining();
    if (left == 0 || (cdr_ && left < 4)) return Status::Ok();
    return DataLoss(Prefix() + std::to_string(left) + " bytes left after the message's last field at byte " +
                    std::to_string(pos_) + " (message has " + std::to_string(message_.size()) +
                    " bytes): not a " + RosMessageKindName(kind_) + " of this encoding");
  }

  bool cdr() const noexcept { return cdr_; }
  std::size_t offset() const noexcept { return pos_; }
  std::size_t remaining() const noexcept { return message_.size() - pos_; }
  /// "PointCloud2: ".
  std::string Prefix() const { return std::string(RosMessageKindName(kind_)) + ": "; }
  /// The full name of a field read at the current element: "fields[2].offset".
  std::string Name(const char* field) const {
    if (array_ == nullptr) return field;
    std::string name = std::string(array_) + "[" + std::to_string(index_) + "]";
    if (field[0] != '\0') name += std::string(".") + field;
    return name;
  }

 private:
  /// Aligns to `align` (CDR, relative to the end of the encapsulation header), then takes n bytes.
  Status Take(std::size_t align, std::size_t n, const char* field, const std::uint8_t** bytes) {
    std::size_t at = pos_;
    if (cdr_ && align > 1) at += (align - (at - kCdrHeaderBytes) % align) % align;
    if (at > message_.size() || n > message_.size() - at) return Truncated(at, Name(field));
    *bytes = message_.data() + at;
    pos_ = at + n;
    return Status::Ok();
  }

  Status Truncated(std::size_t at, const std::string& what) const {
    return DataLoss(Prefix() + "truncated at byte " + std::to_string(at) + " reading " + what + " (message has " +
                    std::to_string(message_.size()) + " bytes)");
  }

  static std::string Hex(std::uint8_t b) {
    static constexpr char kDigits[] = "0123456789abcdef";
    return {kDigits[b >> 4], kDigits[b & 15]};
  }

  Span<const std::uint8_t> message_;
  RosMessageKind kind_;
  bool cdr_;
  bool big_endian_ = false;
  std::size_t pos_ = 0;
  const char* array_ = nullptr;
  std::size_t index_ = 0;
};

struct Header {
  std::int64_t stamp_ns = 0;
  std::string frame_id;
};

/// std_msgs/Header: ROS 1 {uint32 seq, uint32 sec, uint32 nsec, string frame_id}; ROS 2 {int32 sec,
/// uint32 nanosec, string frame_id}. nsec must be below 1e9.
Status ReadHeader(Cursor* c, Header* header) {
  std::int64_t sec = 0;
  if (!c->cdr()) {
    std::uint32_t seq = 0, sec32 = 0;
    if (Status s = c->Read("header.seq", &seq); !s.ok()) return s;
    if (Status s = c->Read("header.stamp.sec", &sec32); !s.ok()) return s;
    sec = sec32;
  } else {
    std::int32_t sec32 = 0;
    if (Status s = c->Read("header.stamp.sec", &sec32); !s.ok()) return s;
    sec = sec32;
  }
  const char* nsec_name = c->cdr() ? "header.stamp.nanosec" : "header.stamp.nsec";
  std::uint32_t nsec = 0;
  if (Status s = c->Read(nsec_name, &nsec); !s.ok()) return s;
  if (nsec >= kNanosPerSecond) {
    return DataLoss(c->Prefix() + nsec_name + " " + std::to_string(nsec) + " ending at byte " +
                    std::to_string(c->offset()) + " is not below 1e9");
  }
  header->stamp_ns = sec * kNanosPerSecond + nsec;
  return c->ReadString("header.frame_id", &header->frame_id);
}

// ---------------------------------------------------------------------------------------------------------------
// PointCloud2

enum PointDatatype : std::uint8_t { kInt8 = 1, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::size_t DatatypeSize(std::uint8_t datatype) noexcept {
  static constexpr std::size_t kSizes[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
  return datatype >= kInt8 && datatype <= kFloat64 ? kSizes[datatype] : 0;
}

template <class T>
double LoadAs(const std::uint8_t* p) noexcept {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<double>(v);
}

/// One little-endian value of a valid datatype, as a double.
double LoadScalar(const std::uint8_t* p, std::uint8_t datatype) noexcept {
  switch (datatype) {
    case kInt8: return LoadAs<std::int8_t>(p);
    case kUint8: return LoadAs<std::uint8_t>(p);
    case kInt16: return LoadAs<std::int16_t>(p);
    case kUint16: return LoadAs<std::uint16_t>(p);
    case kInt32: return LoadAs<std::int32_t>(p);
    case kUint32: return LoadAs<std::uint32_t>(p);
    case kFloat32: return LoadAs<float>(p);
    default: return LoadAs<double>(p);
  }
}

/// double -> float without undefined behaviour: beyond float's range is +-inf, NaN stays NaN.
float ToFloat(double v) noexcept {
  constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
  if (v > kMax) return std::numeric_limits<float>::infinity();
  if (v < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

/// A coordinate (float32 or float64, checked earlier) as float.
float LoadCoordinate(const std::uint8_t* p, std::uint8_t datatype) noexcept {
  if (datatype == kFloat32) {
    float v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
  return ToFloat(LoadAs<double>(p));
}

struct PointFieldInfo {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 0;
};

struct Cloud2 {
  Header header;
  std::uint32_t height = 0, width = 0;
  std::vector<PointFieldInfo> fields;
  std::uint8_t is_bigendian = 0;
  std::uint32_t point_step = 0, row_step = 0;
  Span<const std::uint8_t> data;
  std::size_t data_offset = 0;  ///< where data's bytes start in the message
};

/// The smallest PointField on the wire: an empty name (4), offset (4), datatype (1), count (4).
constexpr std::size_t kMinPointFieldBytes = 13;

Status ReadPointFields(Cursor* c, std::vector<PointFieldInfo>* fields) {
  std::uint32_t count = 0;
  if (Status s = c->ReadCount("fields", kMinPointFieldBytes, &count); !s.ok()) return s;
  fields->resize(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    PointFieldInfo& f = (*fields)[i];
    c->SetElement("fields", i);
    if (Status s = c->ReadString("name", &f.name); !s.ok()) return s;
    if (Status s = c->Read("offset", &f.offset); !s.ok()) return s;
    if (Status s = c->Read("datatype", &f.datatype); !s.ok()) return s;
    if (Status s = c->Read("count", &f.count); !s.ok()) return s;
  }
  c->SetElement(nullptr, 0);
  return Status::Ok();
}

Status ReadCloud2(Cursor* c, Cloud2* m) {
  if (Status s = c->Start(); !s.ok()) return s;
  if (Status s = ReadHeader(c, &m->header); !s.ok()) return s;
  if (Status s = c->Read("height", &m->height); !s.ok()) return s;
  if (Status s = c->Read("width", &m->width); !s.ok()) return s;
  if (Status s = ReadPointFields(c, &m->fields); !s.ok()) return s;
  if (Status s = c->Read("is_bigendian", &m->is_bigendian); !s.ok()) return s;
  if (Status s = c->Read("point_step", &m->point_step); !s.ok()) return s;
  if (Status s = c->Read("row_step", &m->row_step); !s.ok()) return s;
  std::uint32_t data_bytes = 0;
  if (Status s = c->ReadCount("data", 1, &data_bytes); !s.ok()) return s;
  m->data_offset = c->offset();
  if (Status s = c->ReadBytes("data", data_bytes, &m->data); !s.ok()) return s;
  std::uint8_t is_dense = 0;
  if (Status s = c->Read("is_dense", &is_dense); !s.ok()) return s;
  return c->Finish();
}

/// A field the conversion reads: its byte offset in a point and datatype (first element when count > 1).
struct FieldUse {
  const PointFieldInfo* field = nullptr;  ///< null: absent
};

/// The first field called `name`, checked: a known datatype, count >= 1, offset + size * count <= point_step.
Status FindField(const Cloud2& m, const char* name, FieldUse* use) {
  use->field = nullptr;
  const auto it = std::find_if(m.fields.begin(), m.fields.end(),
                               [name](const PointFieldInfo& f) { return f.name == name; });
  if (it == m.fields.end()) return Status::Ok();
  const std::string what = std::string("PointCloud2: field '") + name + "'";
  const std::size_t size = DatatypeSize(it->datatype);
  if (size == 0) {
    return InvalidArgument(what + " has datatype " + std::to_string(it->datatype) +
                           "; known: 1..8 (INT8, UINT8, INT16, UINT16, INT32, UINT32, FLOAT32, FLOAT64)");
  }
  if (it->count == 0) return InvalidArgument(what + " has count 0: no value to read");
  const std::uint64_t bytes = std::uint64_t{size} * it->count;
  if (std::uint64_t{it->offset} + bytes > m.point_step) {
    return DataLoss(what + " at offset " + std::to_string(it->offset) + " + " + std::to_string(bytes) +
                    " bytes ends past point_step " + std::to_string(m.point_step));
  }
  use->field = &*it;
  return Status::Ok();
}

/// How a time field's values become seconds relative to header.stamp.
enum class TimeRule { kNanosRelative, kSecondsRelative, kAbsolute };

struct CloudLayout {
  FieldUse xyz[3];
  FieldUse intensity;
  FieldUse time;
  TimeRule time_rule = TimeRule::kSecondsRelative;
};

Status ResolveLayout(const Cloud2& m, CloudLayout* layout) {
  static constexpr const char* kAxes[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (Status s = FindField(m, kAxes[a], &layout->xyz[a]); !s.ok()) return s;
    const PointFieldInfo* f = layout->xyz[a].field;
    if (f == nullptr) return InvalidArgument(std::string("PointCloud2: the cloud has no field '") + kAxes[a] + "'");
    if (f->datatype != kFloat32 && f->datatype != kFloat64) {
      return InvalidArgument(std::string("PointCloud2: field '") + kAxes[a] + "' has datatype " +
                             std::to_string(f->datatype) + "; coordinates must be FLOAT32 (7) or FLOAT64 (8)");
    }
  }
  for (const char* name : {"intensity", "reflectivity"}) {
    if (Status s = FindField(m, name, &layout->intensity); !s.ok()) return s;
    if (layout->intensity.field != nullptr) break;
  }
  struct TimeField {
    const char* name;
    TimeRule rule;
  };
  static constexpr TimeField kTimeFields[] = {{"t", TimeRule::kNanosRelative},
                                              {"time", TimeRule::kSecondsRelative},
                                              {"timestamp", TimeRule::kAbsolute},
                                              {"offset_time", TimeRule::kNanosRelative}};
  for (const TimeField& t : kTimeFields) {
    if (Status s = FindField(m, t.name, &layout->time); !s.ok()) return s;
    if (layout->time.field == nullptr) continue;
    layout->time_rule = t.rule;
    break;
  }
  return Status::Ok();
}

/// Rows of row_step bytes, each holding width points of point_step bytes; data = row_step * height exactly.
Status CheckCloudSize(const Cloud2& m, const RosScanLimits& limits) {
  if (m.is_bigendian != 0) {
    return InvalidArgument("PointCloud2: is_bigendian is set; big-endian point data is not supported");
  }
  const std::uint64_t points = std::uint64_t{m.width} * m.height;
  if (points > limits.max_points) {
    return InvalidArgument("PointCloud2: width x height = " + std::to_string(m.width) + " x " +
                           std::to_string(m.height) + " = " + std::to_string(points) +
                           " points, more than the limit of " + std::to_string(limits.max_points));
  }
  const std::uint64_t row_bytes = std::uint64_t{m.width} * m.point_step;
  if (row_bytes > m.row_step) {
    return DataLoss("PointCloud2: width " + std::to_string(m.width) + " x point_step " +
                    std::to_string(m.point_step) + " = " + std::to_string(row_bytes) + " bytes exceeds row_step " +
                    std::to_string(m.row_step));
  }
  const std::uint64_t expected = std::uint64_t{m.row_step} * m.height;
  if (expected != m.data.size()) {
    return DataLoss("PointCloud2: data at byte " + std::to_string(m.data_offset) + " has " +
                    std::to_string(m.data.size()) + " bytes, but row_step " + std::to_string(m.row_step) +
                    " x height " + std::to_string(m.height) + " = " + std::to_string(expected));
  }
  return Status::Ok();
}

/// Converts one time value to seconds relative to the stamp (see TimeRule and the header's rule).
float RelativeTime(double value, TimeRule rule, std::int64_t stamp_ns) noexcept {
  switch (rule) {
    case TimeRule::kNanosRelative: return ToFloat(value * 1e-9);
    case TimeRule::kSecondsRelative: return ToFloat(value);
    case TimeRule::kAbsolute: break;
  }
  if (std::fabs(value) > 1e14) return ToFloat((value - static_cast<double>(stamp_ns)) * 1e-9);
  const std::int64_t whole = stamp_ns / kNanosPerSecond;
  const std::int64_t frac = stamp_ns % kNanosPerSecond;
  return ToFloat((value - static_cast<double>(whole)) - static_cast<double>(frac) * 1e-9);
}

void ConvertPoints(const Cloud2& m, const CloudLayout& layout, RosScan* scan) {
  const std::size_t total = static_cast<std::size_t>(m.width) * m.height;
  scan->points.reserve(total);
  const PointFieldInfo* fx = layout.xyz[0].field;
  const PointFieldInfo* fy = layout.xyz[1].field;
  const PointFieldInfo* fz = layout.xyz[2].field;
  const PointFieldInfo* fi = layout.intensity.field;
  const PointFieldInfo* ft = layout.time.field;
  if (ft != nullptr) {
    scan->point_time_s.reserve(total);
    scan->point_time_field = ft->name;
  }
  for (std::uint32_t row = 0; row < m.height; ++row) {
    const std::uint8_t* p = m.data.data() + static_cast<std::size_t>(row) * m.row_step;
    for (std::uint32_t col = 0; col < m.width; ++col, p += m.point_step) {
      PointXYZI q;
      q.x = LoadCoordinate(p + fx->offset, fx->datatype);
      q.y = LoadCoordinate(p + fy->offset, fy->datatype);
      q.z = LoadCoordinate(p + fz->offset, fz->datatype);
      if (!IsFinite(q)) {
        ++scan->non_finite_dropped;
        continue;
      }
      if (fi != nullptr) q.intensity = ToFloat(LoadScalar(p + fi->offset, fi->datatype));
      scan->points.push_back(q);
      if (ft != nullptr) {
        const double t = LoadScalar(p + ft->offset, ft->datatype);
        scan->point_time_s.push_back(RelativeTime(t, layout.time_rule, scan->stamp_ns));
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Livox CustomMsg

/// A CustomPoint on the wire: offset_time, x, y, z (4 bytes each), reflectivity, tag, line (1 byte each).
constexpr std::size_t kMinLivoxPointBytes = 19;

Status ReadLivoxPoint(Cursor* c, std::int64_t base_ns, RosScan* scan) {
  std::uint32_t offset_time = 0;
  PointXYZI q;
  std::uint8_t reflectivity = 0, tag = 0, line = 0;
  if (Status s = c->Read("offset_time", &offset_time); !s.ok()) return s;
  if (Status s = c->Read("x", &q.x); !s.ok()) return s;
  if (Status s = c->Read("y", &q.y); !s.ok()) return s;
  if (Status s = c->Read("z", &q.z); !s.ok()) return s;
  if (Status s = c->Read("reflectivity", &reflectivity); !s.ok()) return s;
  if (Status s = c->Read("tag", &tag); !s.ok()) return s;
  if (Status s = c->Read("line", &line); !s.ok()) return s;
  if (!IsFinite(q)) {
    ++scan->non_finite_dropped;
    return Status::Ok();
  }
  q.intensity = reflectivity;
  scan->points.push_back(q);
  scan->point_time_s.push_back(ToFloat((static_cast<double>(base_ns) + offset_time) * 1e-9));
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------------------------------
// Poses

/// The seven float64 of a geometry_msgs/Pose: position x, y, z, orientation x, y, z, w.
using PoseFieldNames = const char* const[7];

constexpr PoseFieldNames kOdometryPoseNames = {
    "pose.pose.position.x",    "pose.pose.position.y",    "pose.pose.position.z",   "pose.pose.orientation.x",
    "pose.pose.orientation.y", "pose.pose.orientation.z", "pose.pose.orientation.w"};
constexpr PoseFieldNames kPoseStampedNames = {"pose.position.x",    "pose.position.y",    "pose.position.z",
                                              "pose.orientation.x", "pose.orientation.y", "pose.orientation.z",
                                              "pose.orientation.w"};

/// Reads a Pose and checks it: finite values, a quaternion within 1e-3 of unit norm (then normalised).
Status ReadPose(Cursor* c, PoseFieldNames names, Eigen::Isometry3d* pose) {
  double v[7];
  std::size_t orientation_at = 0;
  for (int i = 0; i < 7; ++i) {
    if (Status s = c->Read(names[i], &v[i]); !s.ok()) return s;
    if (i == 3) orientation_at = c->offset() - 8;
    if (!std::isfinite(v[i])) {
      return DataLoss(c->Prefix() + names[i] + " at byte " + std::to_string(c->offset() - 8) + " is " +
                      std::to_string(v[i]));
    }
  }
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  const double norm = q.norm();
  if (std::fabs(norm - 1.0) > 1e-3) {
    std::string orientation(names[3]);
    orientation.resize(orientation.size() - 2);  // drop ".x"
    return DataLoss(c->Prefix() + orientation + " at byte " + std::to_string(orientation_at) + " has norm " +
                    std::to_string(norm) + "; a rotation quaternion must have norm 1 (within 1e-3)");
  }
  *pose = Eigen::Isometry3d::Identity();
  pose->linear() = q.normalized().toRotationMatrix();
  pose->translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return Status::Ok();
}

/// n float64 read and discarded (covariances, twists): the message must still hold them.
Status SkipDoubles(Cursor* c, const char* array, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    c->SetElement(array, i);
    double unused = 0.0;
    if (Status s = c->Read("", &unused); !s.ok()) return s;
  }
  c->SetElement(nullptr, 0);
  return Status::Ok();
}

Status ReadTwist(Cursor* c) {
  static constexpr const char* kNames[] = {"twist.twist.linear.x",  "twist.twist.linear.y",
                                           "twist.twist.linear.z",  "twist.twist.angular.x",
                                           "twist.twist.angular.y", "twist.twist.angular.z"};
  for (const char* name : kNames) {
    double unused = 0.0;
    if (Status s = c->Read(name, &unused); !s.ok()) return s;
  }
  return SkipDoubles(c, "twist.covariance", 36);
}

// ---------------------------------------------------------------------------------------------------------------
// The decoders

Status DecodeCloud2Message(RosEncoding encoding, Span<const std::uint8_t> message, const RosScanLimits& limits,
                           RosScan* out) {
  Cursor c(encoding, message, RosMessageKind::kPointCloud2);
  Cloud2 m;
  if (Status s = ReadCloud2(&c, &m); !s.ok()) return s;
  CloudLayout layout;
  if (Status s = ResolveLayout(m, &layout); !s.ok()) return s;
  if (Status s = CheckCloudSize(m, limits); !s.ok()) return s;
  RosScan scan;
  scan.stamp_ns = m.header.stamp_ns;
  scan.frame_id = std::move(m.header.frame_id);
  ConvertPoints(m, layout, &scan);
  *out = std::move(scan);
  return Status::Ok();
}

Status DecodeLivoxMessage(RosEncoding encoding, Span<const std::uint8_t> message, const RosScanLimits& limits,
                          RosScan* out) {
  Cursor c(encoding, message, RosMessageKind::kLivoxCustom);
  RosScan scan;
  Header header;
  std::uint64_t timebase = 0;
  std::uint32_t point_num = 0, count = 0;
  std::uint8_t lidar_id = 0, rsvd = 0;
  if (Status s = c.Start(); !s.ok()) return s;
  if (Status s = ReadHeader(&c, &header); !s.ok()) return s;
  if (Status s = c.Read("timebase", &timebase); !s.ok()) return s;
  if (Status s = c.Read("point_num", &point_num); !s.ok()) return s;
  if (Status s = c.Read("lidar_id", &lidar_id); !s.ok()) return s;
  for (const char* name : {"rsvd[0]", "rsvd[1]", "rsvd[2]"}) {
    if (Status s = c.Read(name, &rsvd); !s.ok()) return s;
  }
  const std::size_t count_at = c.offset();
  if (Status s = c.ReadCount("points", kMinLivoxPointBytes, &count); !s.ok()) return s;
  if (count != point_num) {
    return DataLoss(c.Prefix() + "point_num " + std::to_string(point_num) + " differs from the " +
                    std::to_string(count) + " points of the array at byte " + std::to_string(count_at));
  }
  if (count > limits.max_points) {
    return InvalidArgument(c.Prefix() + std::to_string(count) + " points, more than the limit of " +
                           std::to_string(limits.max_points));
  }
  scan.stamp_ns = header.stamp_ns;
  scan.frame_id = std::move(header.frame_id);
  scan.point_time_field = "offset_time";
  scan.points.reserve(count);
  scan.point_time_s.reserve(count);
  // timebase - stamp in ns, modulo 2^64 (exact whenever the true difference fits in 63 bits).
  const auto base_ns = static_cast<std::int64_t>(timebase - static_cast<std::uint64_t>(header.stamp_ns));
  for (std::uint32_t i = 0; i < count; ++i) {
    c.SetElement("points", i);
    if (Status s = ReadLivoxPoint(&c, base_ns, &scan); !s.ok()) return s;
  }
  c.SetElement(nullptr, 0);
  if (Status s = c.Finish(); !s.ok()) return s;
  *out = std::move(scan);
  return Status::Ok();
}

Status DecodeOdometryMessage(RosEncoding encoding, Span<const std::uint8_t> message, RosPose* out) {
  Cursor c(encoding, message, RosMessageKind::kOdometry);
  RosPose pose;
  Header header;
  if (Status s = c.Start(); !s.ok()) return s;
  if (Status s = ReadHeader(&c, &header); !s.ok()) return s;
  if (Status s = c.ReadString("child_frame_id", &pose.child_frame_id); !s.ok()) return s;
  if (Status s = ReadPose(&c, kOdometryPoseNames, &pose.T_parent_child); !s.ok()) return s;
  if (Status s = SkipDoubles(&c, "pose.covariance", 36); !s.ok()) return s;
  if (Status s = ReadTwist(&c); !s.ok()) return s;
  if (Status s = c.Finish(); !s.ok()) return s;
  pose.stamp_ns = header.stamp_ns;
  pose.frame_id = std::move(header.frame_id);
  *out = std::move(pose);
  return Status::Ok();
}

Status DecodePoseStampedMessage(RosEncoding encoding, Span<const std::uint8_t> message, RosPose* out) {
  Cursor c(encoding, message, RosMessageKind::kPoseStamped);
  RosPose pose;
  Header header;
  if (Status s = c.Start(); !s.ok()) return s;
  if (Status s = ReadHeader(&c, &header); !s.ok()) return s;
  if (Status s = ReadPose(&c, kPoseStampedNames, &pose.T_parent_child); !s.ok()) return s;
  if (Status s = c.Finish(); !s.ok()) return s;
  pose.stamp_ns = header.stamp_ns;
  pose.frame_id = std::move(header.frame_id);
  *out = std::move(pose);
  return Status::Ok();
}

}  // namespace
}  // namespace ros_msg_impl

RosMessageKind RosMessageKindOf(const std::string& type) {
  struct Name {
    const char* package;
    const char* type;
    RosMessageKind kind;
  };
  static constexpr Name kNames[] = {{"sensor_msgs", "PointCloud2", RosMessageKind::kPointCloud2},
                                    {"nav_msgs", "Odometry", RosMessageKind::kOdometry},
                                    {"geometry_msgs", "PoseStamped", RosMessageKind::kPoseStamped},
                                    {"livox_ros_driver", "CustomMsg", RosMessageKind::kLivoxCustom},
                                    {"livox_ros_driver2", "CustomMsg", RosMessageKind::kLivoxCustom}};
  for (const Name& n : kNames) {
    const std::string package(n.package);
    if (type == package + "/" + n.type || type == package + "/msg/" + n.type) return n.kind;
  }
  return RosMessageKind::kUnsupported;
}

const char* RosMessageKindName(RosMessageKind kind) noexcept {
  switch (kind) {
    case RosMessageKind::kPointCloud2: return "PointCloud2";
    case RosMessageKind::kLivoxCustom: return "Livox CustomMsg";
    case RosMessageKind::kOdometry: return "Odometry";
    case RosMessageKind::kPoseStamped: return "PoseStamped";
    case RosMessageKind::kUnsupported: break;
  }
  return "unsupported";
}

bool IsScanKind(RosMessageKind kind) noexcept {
  return kind == RosMessageKind::kPointCloud2 || kind == RosMessageKind::kLivoxCustom;
}

Status DecodePointCloud2(RosEncoding encoding, Span<const std::uint8_t> message, const RosScanLimits& limits,
                         RosScan* out) {
  return ros_msg_impl::DecodeCloud2Message(encoding, message, limits, out);
}

Status DecodeLivoxCustomMsg(RosEncoding encoding, Span<const std::uint8_t> message, const RosScanLimits& limits,
                            RosScan* out) {
  return ros_msg_impl::DecodeLivoxMessage(encoding, message, limits, out);
}

Status DecodeOdometry(RosEncoding encoding, Span<const std::uint8_t> message, RosPose* out) {
  return ros_msg_impl::DecodeOdometryMessage(encoding, message, out);
}

Status DecodePoseStamped(RosEncoding encoding, Span<const std::uint8_t> message, RosPose* out) {
  return ros_msg_impl::DecodePoseStampedMessage(encoding, message, out);
}

}  // namespace commerge::platform
