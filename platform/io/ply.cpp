// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/ply.hpp"

#include <algorithm>
#include <optional>
#include <string_view>
#include <vector>

#include "platform/io/file_util.hpp"
#include "platform/io/record_layout.hpp"
#include "platform/io/text_io.hpp"

namespace commerge::platform {

namespace {

using io_detail::FieldSpec;
using io_detail::HeaderLines;
using io_detail::LineError;
using io_detail::ScalarType;
using Tokens = std::vector<std::string_view>;

enum class PlyFormat { kAscii, kBinaryLittleEndian };

struct PlyHeader {
  std::optional<PlyFormat> format;
  std::optional<std::uint64_t> vertices;  ///< set when the vertex element is declared
  bool in_vertex = false;                 ///< the properties being read belong to the vertex element
  std::vector<FieldSpec> vertex_properties;
};

std::optional<ScalarType> PlyScalarType(std::string_view name) {
  struct Rule {
    std::string_view name;
    ScalarType type;
  };
  static constexpr Rule kRules[] = {
      {"char", ScalarType::kInt8},     {"int8", ScalarType::kInt8},       {"uchar", ScalarType::kUint8},
      {"uint8", ScalarType::kUint8},   {"short", ScalarType::kInt16},     {"int16", ScalarType::kInt16},
      {"ushort", ScalarType::kUint16}, {"uint16", ScalarType::kUint16},   {"int", ScalarType::kInt32},
      {"int32", ScalarType::kInt32},   {"uint", ScalarType::kUint32},     {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32}, {"float32", ScalarType::kFloat32}, {"double", ScalarType::kFloat64},
      {"float64", ScalarType::kFloat64}};
  for (const Rule& rule : kRules) {
    if (name == rule.name) return rule.type;
  }
  return std::nullopt;
}

Status ParseFormat(const std::string& path, std::size_t line, const Tokens& tokens, PlyHeader* header) {
  if (tokens.size() != 3 || tokens[2] != "1.0") {
    return DataLoss(LineError(path, line, "expected 'format <ascii|binary_little_endian> 1.0'"));
  }
  if (tokens[1] == "ascii") {
    header->format = PlyFormat::kAscii;
  } else if (tokens[1] == "binary_little_endian") {
    header->format = PlyFormat::kBinaryLittleEndian;
  } else if (tokens[1] == "binary_big_endian") {
    return Unimplemented(path + ": format binary_big_endian is not supported (unimplemented); convert the file " +
                         "to binary_little_endian or ascii");
  } else {
    return DataLoss(LineError(path, line, "unknown format '" + std::string(tokens[1]) + "'"));
  }
  return Status::Ok();
}

Status ParseElement(const std::string& path, std::size_t line, const Tokens& tokens, PlyHeader* header) {
  std::uint64_t count = 0;
  if (tokens.size() != 3 || !io_detail::ParseCount(tokens[2], &count)) {
    return DataLoss(LineError(path, line, "expected 'element <name> <count>'"));
  }
  header->in_vertex = tokens[1] == "vertex";
  if (header->vertices && header->in_vertex) return DataLoss(LineError(path, line, "second vertex element"));
  if (!header->vertices && !header->in_vertex) {
    return Unimplemented(path + ": element '" + std::string(tokens[1]) + "' comes before the vertex element; " +
                         "only files whose first element is vertex are supported");
  }
  if (header->in_vertex) header->vertices = count;
  return Status::Ok();
}

Status ParseProperty(const std::string& path, std::size_t line, const Tokens& tokens, PlyHeader* header) {
  if (!header->vertices) return DataLoss(LineError(path, line, "property before any element"));
  if (!header->in_vertex) return Status::Ok();  // other elements are not read
  if (tokens.size() >= 2 && tokens[1] == "list") {
    return Unimplemented(path + ": vertex property '" + std::string(tokens.back()) + "' is a list; list " +
                         "properties on the vertex element are not supported");
  }
  const std::optional<ScalarType> type = tokens.size() == 3 ? PlyScalarType(tokens[1]) : std::nullopt;
  if (!type) return DataLoss(LineError(path, line, "expected 'property <scalar type> <name>'"));
  header->vertex_properties.push_back(FieldSpec{std::string(tokens[2]), *type, 1});
  return Status::Ok();
}

Status ParseHeaderLine(const std::string& path, std::size_t line, const Tokens& tokens, PlyHeader* header) {
  if (tokens[0] == "format") return ParseFormat(path, line, tokens, header);
  if (tokens[0] == "element") return ParseElement(path, line, tokens, header);
  if (tokens[0] == "property") return ParseProperty(path, line, tokens, header);
  if (tokens[0] == "comment" || tokens[0] == "obj_info") return Status::Ok();
  return DataLoss(LineError(path, line, "unknown header keyword '" + std::string(tokens[0]) + "'"));
}

Result<PlyHeader> ReadPlyHeader(HeaderLines* lines, const std::string& path) {
  auto magic = lines->Next("the line 'ply'");
  if (!magic.ok()) return magic.status();
  if (*magic != "ply") return DataLoss(path + ": not a PLY file: the first line is not 'ply'");
  PlyHeader header;
  Tokens tokens;
  for (;;) {
    auto line = lines->Next("an end_header line");
    if (!line.ok()) return line.status();
    io_detail::SplitTokens(*line, &tokens);
    if (tokens.empty()) continue;
    if (tokens[0] == "end_header") break;
    if (Status s = ParseHeaderLine(path, lines->line_number(), tokens, &header); !s.ok()) return s;
  }
  if (!header.format) return DataLoss(path + ": the header has no format line");
  if (!header.vertices) return InvalidArgument(path + ": the header has no vertex element; not a point cloud");
  return header;
}

std::string PlyHeaderText(std::size_t num_points, bool with_robot) {
  std::string text = "ply\nformat binary_little_endian 1.0\ncomment written by commerge\n";
  text += "element vertex " + std::to_string(num_points) + "\n";
  text += "property float x\nproperty float y\nproperty float z\nproperty float intensity\n";
  if (with_robot) text += "property ushort robot\n";
  text += "end_header\n";
  return text;
}

}  // namespace

Result<PointCloudFile> ReadPly(const std::string& path) {
  auto file = OpenForRead(path);
  if (!file.ok()) return file.status();
  auto size = FileSize(file->get(), path);
  if (!size.ok()) return size.status();
  HeaderLines lines(file->get(), path);
  auto header = ReadPlyHeader(&lines, path);
  if (!header.ok()) return header.status();
  auto layout = io_detail::MakeRecordLayout(path, header->vertex_properties);
  if (!layout.ok()) return layout.status();
  const std::uint64_t data_bytes = *size - std::min(*size, lines.bytes_consumed());
  if (*header->format == PlyFormat::kBinaryLittleEndian) {
    return io_detail::ReadBinaryRecords(file->get(), path, *layout, *header->vertices, data_bytes);
  }
  auto text = io_detail::ReadRemainingText(file->get(), path, data_bytes);
  if (!text.ok()) return text.status();
  std::string_view other_elements;  // faces etc. after the vertices: not read
  return io_detail::ParseAsciiRecords(path, *layout, *text, lines.line_number() + 1, *header->vertices,
                                      &other_elements);
}

Status WritePly(const std::string& path, Span<const PointXYZI> points, Span<const std::uint16_t> robot_ids) {
  if (Status s = io_detail::CheckRobotIds(path, points.size(), robot_ids.size()); !s.ok()) return s;
  auto file = OpenForWrite(path);
  if (!file.ok()) return file.status();
  const std::string header = PlyHeaderText(points.size(), !robot_ids.empty());
  Status s = io_detail::WriteBytes(file->get(), path, header.data(), header.size());
  if (s.ok()) s = io_detail::WriteBinaryRecords(file->get(), path, points, robot_ids);
  if (!s.ok()) return s;
  return CloseChecked(std::move(*file), path);
}

}  // namespace commerge::platform
