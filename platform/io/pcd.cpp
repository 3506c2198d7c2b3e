// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/pcd.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <string_view>
#include <vector>

#include "platform/io/file_util.hpp"
#include "platform/io/lzf.hpp"
#include "platform/io/record_layout.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::platform {

namespace {

using io_detail::FieldSpec;
using io_detail::HeaderLines;
using io_detail::LineError;
using io_detail::ScalarType;

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

struct PcdHeader {
  std::vector<FieldSpec> fields;
  std::uint64_t points = 0;
  PcdData data = PcdData::kBinary;
};

/// One header line: the values after its key, and where it was.
struct HeaderEntry {
  std::vector<std::string> values;
  std::size_t line = 0;
};
using HeaderEntries = std::map<std::string, HeaderEntry, std::less<>>;

constexpr std::string_view kKeys[] = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                      "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
constexpr std::size_t kAsciiFlushBytes = std::size_t{1} << 16;

/// Reads header lines up to and including DATA; skips blank and '#' lines.
Result<HeaderEntries> ReadHeaderEntries(HeaderLines* lines, const std::string& path) {
  HeaderEntries entries;
  std::vector<std::string_view> tokens;
  while (entries.count("DATA") == 0) {
    auto line = lines->Next("a DATA line");
    if (!line.ok()) return line.status();
    io_detail::SplitTokens(*line, &tokens);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    const std::string_view key = tokens[0];
    if (std::find(std::begin(kKeys), std::end(kKeys), key) == std::end(kKeys)) {
      return DataLoss(LineError(path, lines->line_number(),
                                "unknown header key '" + std::string(key) + "'; this is not a PCD header"));
    }
    if (entries.count(key) != 0) {
      return DataLoss(LineError(path, lines->line_number(), "second " + std::string(key) + " line"));
    }
    entries[std::string(key)] = HeaderEntry{{tokens.begin() + 1, tokens.end()}, lines->line_number()};
  }
  return entries;
}

Result<const HeaderEntry*> Required(const std::string& path, const HeaderEntries& entries, const char* key) {
  const auto it = entries.find(key);
  if (it == entries.end()) return DataLoss(path + ": the header has no " + key + " line");
  return &it->second;
}

Result<std::uint64_t> SingleCount(const std::string& path, const HeaderEntries& entries, const char* key) {
  auto entry = Required(path, entries, key);
  if (!entry.ok()) return entry.status();
  std::uint64_t value = 0;
  const std::vector<std::string>& values = (*entry)->values;
  if (values.size() != 1 || !io_detail::ParseCount(values[0], &value)) {
    return DataLoss(LineError(path, (*entry)->line, std::string(key) + " expects one non-negative integer"));
  }
  return value;
}

std::optional<ScalarType> PcdScalarType(const std::string& type, std::uint64_t size) {
  struct Rule {
    const char* type;
    std::uint64_t size;
    ScalarType scalar;
  };
  static constexpr Rule kRules[] = {
      {"F", 4, ScalarType::kFloat32}, {"F", 8, ScalarType::kFloat64}, {"U", 1, ScalarType::kUint8},
      {"U", 2, ScalarType::kUint16},  {"U", 4, ScalarType::kUint32},  {"U", 8, ScalarType::kUint64},
      {"I", 1, ScalarType::kInt8},    {"I", 2, ScalarType::kInt16},   {"I", 4, ScalarType::kInt32},
      {"I", 8, ScalarType::kInt64}};
  for (const Rule& rule : kRules) {
    if (type == rule.type && size == rule.size) return rule.scalar;
  }
  return std::nullopt;
}

/// The FIELDS, SIZE, TYPE and COUNT (optional: null) lines, checked to list one value per field.
struct FieldLines {
  const HeaderEntry* names = nullptr;
  const HeaderEntry* sizes = nullptr;
  const HeaderEntry* types = nullptr;
  const HeaderEntry* counts = nullptr;
};

Result<FieldLines> FindFieldLines(const std::string& path, const HeaderEntries& entries) {
  FieldLines lines;
  const HeaderEntry** targets[] = {&lines.names, &lines.sizes, &lines.types, &lines.counts};
  const char* const keys[] = {"FIELDS", "SIZE", "TYPE", "COUNT"};
  for (int k = 0; k < 3; ++k) {
    auto entry = Required(path, entries, keys[k]);
    if (!entry.ok()) return entry.status();
    *targets[k] = *entry;
  }
  const auto count = entries.find("COUNT");
  if (count != entries.end()) lines.counts = &count->second;
  const std::size_t n = lines.names->values.size();
  if (n == 0) return DataLoss(LineError(path, lines.names->line, "FIELDS names no field"));
  for (int k = 1; k < 4; ++k) {
    const HeaderEntry* entry = *targets[k];
    if (entry && entry->values.size() != n) {
      return DataLoss(LineError(path, entry->line, std::string(keys[k]) + " has " +
                                                       std::to_string(entry->values.size()) +
                                                       " values, but FIELDS names " + std::to_string(n)));
    }
  }
  return lines;
}

Result<FieldSpec> ParseField(const std::string& path, const FieldLines& lines, std::size_t i) {
  const std::string& name = lines.names->values[i];
  std::uint64_t size = 0, count = 1;
  if (!io_detail::ParseCount(lines.sizes->values[i], &size)) {
    return DataLoss(LineError(path, lines.sizes->line, "SIZE of field '" + name + "' is not an integer"));
  }
  if (lines.counts && !io_detail::ParseCount(lines.counts->values[i], &count)) {
    return DataLoss(LineError(path, lines.counts->line, "COUNT of field '" + name + "' is not an integer"));
  }
  const std::string& type_name = lines.types->values[i];
  const std::optional<ScalarType> type = PcdScalarType(type_name, size);
  if (!type) {
    const std::string what = "field '" + name + "' has TYPE " + type_name + " with SIZE " + std::to_string(size);
    return DataLoss(LineError(path, lines.types->line, what + "; supported: F 4/8, U and I 1/2/4/8"));
  }
  return FieldSpec{name, *type, static_cast<std::size_t>(count)};
}

Result<std::vector<FieldSpec>> ParseFields(const std::string& path, const HeaderEntries& entries) {
  auto lines = FindFieldLines(path, entries);
  if (!lines.ok()) return lines.status();
  std::vector<FieldSpec> fields;
  for (std::size_t i = 0; i < lines->names->values.size(); ++i) {
    auto field = ParseField(path, *lines, i);
    if (!field.ok()) return field.status();
    fields.push_back(std::move(*field));
  }
  return fields;
}

/// POINTS, which must equal WIDTH x HEIGHT (WIDTH x HEIGHT when POINTS is absent).
Result<std::uint64_t> ParsePointCount(const std::string& path, const HeaderEntries& entries) {
  auto width = SingleCount(path, entries, "WIDTH");
  if (!width.ok()) return width.status();
  auto height = SingleCount(path, entries, "HEIGHT");
  if (!height.ok()) return height.status();
  const bool overflow = *height != 0 && *width > UINT64_MAX / *height;
  const std::string product = "WIDTH x HEIGHT = " + std::to_string(*width) + " x " + std::to_string(*height);
  if (entries.count("POINTS") == 0) {
    if (overflow) return DataLoss(path + ": " + product + " does not fit in 64 bits");
    return *width * *height;
  }
  auto points = SingleCount(path, entries, "POINTS");
  if (!points.ok()) return points.status();
  if (overflow || *points != *width * *height) {
    return DataLoss(LineError(path, entries.find("POINTS")->second.line,
                              "POINTS " + std::to_string(*points) + " is not " + product));
  }
  return *points;
}

Result<PcdData> ParseDataKind(const std::string& path, const HeaderEntry& entry) {
  const std::string kind = entry.values.size() == 1 ? entry.values[0] : std::string();
  if (kind == "ascii") return PcdData::kAscii;
  if (kind == "binary") return PcdData::kBinary;
  if (kind == "binary_compressed") return PcdData::kBinaryCompressed;
  return DataLoss(LineError(path, entry.line, "DATA expects one of ascii, binary, binary_compressed"));
}

/// VERSION (ignored) and VIEWPOINT (checked, ignored) only need the right number of values.
Status CheckOptionalKeys(const std::string& path, const HeaderEntries& entries) {
  const auto version = entries.find("VERSION");
  if (version != entries.end() && version->second.values.size() != 1) {
    return DataLoss(LineError(path, version->second.line, "VERSION expects one value"));
  }
  const auto viewpoint = entries.find("VIEWPOINT");
  if (viewpoint == entries.end()) return Status::Ok();
  double value = 0.0;
  const std::vector<std::string>& values = viewpoint->second.values;
  const bool numeric = std::all_of(values.begin(), values.end(),
                                   [&value](const std::string& v) { return io_detail::ParseNumber(v, &value); });
  if (values.size() != 7 || !numeric) {
    return DataLoss(LineError(path, viewpoint->second.line, "VIEWPOINT expects 7 numbers (tx ty tz qw qx qy qz)"));
  }
  return Status::Ok();
}

Result<PcdHeader> ReadPcdHeader(HeaderLines* lines, const std::string& path) {
  auto entries = ReadHeaderEntries(lines, path);
  if (!entries.ok()) return entries.status();
  PcdHeader header;
  auto data = ParseDataKind(path, entries->find("DATA")->second);
  if (!data.ok()) return data.status();
  header.data = *data;
  auto fields = ParseFields(path, *entries);
  if (!fields.ok()) return fields.status();
  header.fields = std::move(*fields);
  auto points = ParsePointCount(path, *entries);
  if (!points.ok()) return points.status();
  header.points = *points;
  if (Status s = CheckOptionalKeys(path, *entries); !s.ok()) return s;
  return header;
}

/// Ascii rows, one per point; only blank lines may follow them.
Result<PointCloudFile> ReadAsciiData(std::FILE* f, const std::string& path, const io_detail::RecordLayout& layout,
                                     std::uint64_t points, std::uint64_t bytes, std::size_t first_line) {
  auto text = io_detail::ReadRemainingText(f, path, bytes);
  if (!text.ok()) return text.status();
  std::string_view rest;
  auto cloud = io_detail::ParseAsciiRecords(path, layout, *text, first_line, points, &rest);
  if (!cloud.ok()) return cloud.status();
  io_detail::LineCursor after(rest, first_line + cloud->records_in_file);
  std::string_view line;
  while (after.Next(&line)) {
    if (!io_detail::IsBlank(line)) {
      return DataLoss(LineError(path, after.line_number(),
                                "more data rows than the header announces (POINTS " + std::to_string(points) + ")"));
    }
  }
  return cloud;
}

// DATA binary_compressed (PCL's writer): uint32 compressed size, uint32 uncompressed size, then the LZF-compressed
// fields in column order (every point's value of field 1, then of field 2, ...; a field's COUNT elements stay
// together). PCL pads the file with zeros after the block (to a page), so bytes after it are allowed.
namespace pcd_compressed_impl {

constexpr std::uint64_t kSizeFieldsBytes = 8;

struct CompressedSizes {
  std::uint32_t compressed_bytes = 0;
  std::uint32_t uncompressed_bytes = 0;
};

/// The announced uncompressed size must be POINTS x record bytes, within 32 bits and what LZF can expand
/// `compressed_bytes` to: all checked before anything is allocated.
Status CheckUncompressedSize(const std::string& path, const CompressedSizes& sizes, std::uint64_t points,
                             std::size_t record_bytes) {
  const bool overflow = points > UINT64_MAX / record_bytes;
  const std::string expected = overflow ? std::string("more than 2^64") : std::to_string(points * record_bytes);
  const std::string announced = std::to_string(sizes.uncompressed_bytes);
  if (overflow || points * record_bytes > UINT32_MAX) {
    return DataLoss(path + ": POINTS " + std::to_string(points) + " x " + std::to_string(record_bytes) +
                    " record bytes = " + expected + " bytes: more than DATA binary_compressed can hold (32-bit sizes)");
  }
  if (sizes.uncompressed_bytes != points * record_bytes) {
    return DataLoss(path + ": DATA binary_compressed announces " + announced + " uncompressed bytes, but POINTS " +
                    std::to_string(points) + " x " + std::to_string(record_bytes) + " record bytes = " + expected);
  }
  if (sizes.uncompressed_bytes > kLzfMaxExpansion * sizes.compressed_bytes) {
    return DataLoss(path + ": DATA binary_compressed announces " + announced + " uncompressed bytes from " +
                    std::to_string(sizes.compressed_bytes) + " compressed bytes; LZF expands at most " +
                    std::to_string(kLzfMaxExpansion) + "-fold (corrupt sizes)");
  }
  return Status::Ok();
}

/// The two size fields, checked against the file size and the header.
Result<CompressedSizes> ReadCompressedSizes(std::FILE* f, const std::string& path, std::uint64_t data_bytes,
                                            std::uint64_t points, std::size_t record_bytes) {
  if (data_bytes < kSizeFieldsBytes) {
    return DataLoss(path + ": truncated: DATA binary_compressed needs 8 bytes of sizes after the header, the file " +
                    "has " + std::to_string(data_bytes));
  }
  unsigned char raw[kSizeFieldsBytes];
  if (std::fread(raw, 1, sizeof(raw), f) != sizeof(raw)) {
    return IoError(path + ": read failed in the binary_compressed sizes: " + ShortReadReason(f));
  }
  CompressedSizes sizes;
  std::memcpy(&sizes.compressed_bytes, raw, 4);
  std::memcpy(&sizes.uncompressed_bytes, raw + 4, 4);
  const std::uint64_t available = data_bytes - kSizeFieldsBytes;
  if (sizes.compressed_bytes > available) {
    return DataLoss(path + ": truncated: DATA binary_compressed announces " + std::to_string(sizes.compressed_bytes) +
                    " compressed bytes, the file has " + std::to_string(available) + " after the size fields");
  }
  if (Status s = CheckUncompressedSize(path, sizes, points, record_bytes); !s.ok()) return s;
  return sizes;
}

/// Reads and decompresses the block: the fields in column order.
Result<std::vector<unsigned char>> ReadColumns(std::FILE* f, const std::string& path, const CompressedSizes& sizes) {
  std::vector<unsigned char> compressed(sizes.compressed_bytes);
  if (!compressed.empty() && std::fread(compressed.data(), 1, compressed.size(), f) != compressed.size()) {
    return IoError(path + ": read failed in the binary_compressed data: " + ShortReadReason(f));
  }
  std::vector<unsigned char> columns(sizes.uncompressed_bytes);
  const Status s = LzfDecompress(Span<const unsigned char>(compressed), Span<unsigned char>(columns));
  if (!s.ok()) return DataLoss(path + ": DATA binary_compressed: " + s.message());
  return columns;
}

/// Column order to records (the layout of DATA binary): field k of point i moves from
/// points x (offset of field k) + i x (its bytes) to i x record bytes + (offset of field k).
std::vector<unsigned char> ColumnsToRecords(const std::vector<unsigned char>& columns,
                                            const std::vector<io_detail::FieldSpec>& fields, std::size_t points,
                                            std::size_t record_bytes) {
  std::vector<unsigned char> records(columns.size());
  std::size_t offset = 0;
  for (const io_detail::FieldSpec& field : fields) {
    const std::size_t width = io_detail::ScalarSize(field.type) * field.count;
    const unsigned char* column = columns.data() + points * offset;
    for (std::size_t i = 0; i < points; ++i) std::memcpy(&records[i * record_bytes + offset], column + i * width, width);
    offset += width;
  }
  return records;
}

Result<PointCloudFile> ReadCompressedData(std::FILE* f, const std::string& path, const PcdHeader& header,
                                          const io_detail::RecordLayout& layout, std::uint64_t data_bytes) {
  auto sizes = ReadCompressedSizes(f, path, data_bytes, header.points, layout.record_bytes);
  if (!sizes.ok()) return sizes.status();
  if (header.points == 0) return PointCloudFile{};  // the block is empty or fails to decompress into nothing
  std::vector<unsigned char> records;
  {
    auto columns = ReadColumns(f, path, *sizes);
    if (!columns.ok()) return columns.status();
    records = ColumnsToRecords(*columns, header.fields, static_cast<std::size_t>(header.points), layout.record_bytes);
  }
  // Decoded as DATA binary is (the same conversions, robot-id checks and non-finite drops), from memory.
  FilePtr memory(fmemopen(records.data(), records.size(), "rb"));
  if (!memory) return IoError(path + ": cannot open the decompressed data as a stream: " + std::strerror(errno));
  return io_detail::ReadBinaryRecords(memory.get(), path, layout, header.points, records.size());
}

}  // namespace pcd_compressed_impl

std::string PcdHeaderText(std::size_t num_points, PcdEncoding encoding, bool with_robot) {
  const std::string n = std::to_string(num_points);
  std::string text = "# .PCD v0.7 - Point Cloud Data file format (written by commerge)\nVERSION 0.7\n";
  text += with_robot ? "FIELDS x y z intensity robot\nSIZE 4 4 4 4 2\nTYPE F F F F U\nCOUNT 1 1 1 1 1\n"
                     : "FIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n";
  text += "WIDTH " + n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\n";
  text += encoding == PcdEncoding::kAscii ? "DATA ascii\n" : "DATA binary\n";
  return text;
}

Status WriteAsciiRows(std::FILE* f, const std::string& path, Span<const PointXYZI> points,
                      Span<const std::uint16_t> robot_ids) {
  std::string buffer;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const PointXYZI& p = points[i];
    for (const float value : {p.x, p.y, p.z, p.intensity}) {
      io_detail::AppendNumber(&buffer, value);
      buffer += ' ';
    }
    buffer.pop_back();
    if (!robot_ids.empty()) buffer += ' ' + std::to_string(robot_ids[i]);
    buffer += '\n';
    if (buffer.size() >= kAsciiFlushBytes || i + 1 == points.size()) {
      if (Status s = io_detail::WriteBytes(f, path, buffer.data(), buffer.size()); !s.ok()) return s;
      buffer.clear();
    }
  }
  return Status::Ok();
}

}  // namespace

Result<PointCloudFile> ReadPcd(const std::string& path) {
  auto file = OpenForRead(path);
  if (!file.ok()) return file.status();
  auto size = FileSize(file->get(), path);
  if (!size.ok()) return size.status();
  HeaderLines lines(file->get(), path);
  auto header = ReadPcdHeader(&lines, path);
  if (!header.ok()) return header.status();
  auto layout = io_detail::MakeRecordLayout(path, header->fields);
  if (!layout.ok()) return layout.status();
  const std::uint64_t data_bytes = *size - std::min(*size, lines.bytes_consumed());
  if (header->data == PcdData::kBinary) {
    return io_detail::ReadBinaryRecords(file->get(), path, *layout, header->points, data_bytes);
  }
  if (header->data == PcdData::kBinaryCompressed) {
    return pcd_compressed_impl::ReadCompressedData(file->get(), path, *header, *layout, data_bytes);
  }
  return ReadAsciiData(file->get(), path, *layout, header->points, data_bytes, lines.line_number() + 1);
}

Status WritePcd(const std::string& path, Span<const PointXYZI> points, PcdEncoding encoding,
                Span<const std::uint16_t> robot_ids) {
  if (Status s = io_detail::CheckRobotIds(path, points.size(), robot_ids.size()); !s.ok()) return s;
  auto file = OpenForWrite(path);
  if (!file.ok()) return file.status();
  const std::string header = PcdHeaderText(points.size(), encoding, !robot_ids.empty());
  Status s = io_detail::WriteBytes(file->get(), path, header.data(), header.size());
  if (s.ok()) {
    s = encoding == PcdEncoding::kAscii ? WriteAsciiRows(file->get(), path, points, robot_ids)
                                        : io_detail::WriteBinaryRecords(file->get(), path, points, robot_ids);
  }
  if (!s.ok()) return s;
  return CloseChecked(std::move(*file), path);
}

}  // namespace commerge::platform
