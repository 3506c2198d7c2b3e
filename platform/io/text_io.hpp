// SPDX-License-Identifier: BSD-3-Clause
// Text building blocks of the file formats (PCD/PLY headers and ascii data, pose files): bounded header
// lines, line iteration, tokens, locale-independent exact number parsing and formatting, error texts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/status.hpp"

namespace commerge::platform::io_detail {

/// Reads header lines from the start of an open file, one at a time, with a bounded line length so a
/// binary file without newlines cannot make it read forever.
class HeaderLines {
 public:
  HeaderLines(std::FILE* f, const std::string& path) : f_(f), path_(path) {}
  /// The next line without its line ending. At the end of the file: data loss saying the header ends
  /// without `what_is_missing`.
  Result<std::string> Next(const char* what_is_missing);
  std::size_t line_number() const { return line_number_; }       ///< 1-based, of the last line returned
  std::uint64_t bytes_consumed() const { return bytes_consumed_; }  ///< header bytes read so far

 private:
  std::FILE* f_;
  const std::string& path_;
  std::size_t line_number_ = 0;
  std::uint64_t bytes_consumed_ = 0;
};

/// Iterates over the lines of a text, stripping "\n" and "\r\n".
class LineCursor {
 public:
  explicit LineCursor(std::string_view text, std::size_t first_line_number = 1)
      : text_(text), next_line_number_(first_line_number) {}
  /// False at the end of the text.
  bool Next(std::string_view* line);
  std::size_t line_number() const { return next_line_number_ - 1; }  ///< of the last line returned
  std::string_view rest() const { return text_.substr(pos_); }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t next_line_number_;
};

/// Splits on spaces and tabs into `tokens` (cleared first).
void SplitTokens(std::string_view line, std::vector<std::string_view>* tokens);
bool IsBlank(std::string_view line);

/// Locale-independent parsing of a whole token (a leading '+' is allowed; "nan" and "inf" parse).
bool ParseNumber(std::string_view token, double* value);
bool ParseNumber(std::string_view token, float* value);
bool ParseCount(std::string_view token, std::uint64_t* value);

/// Appends the shortest text that reads back as exactly `value`.
void AppendNumber(std::string* out, double value);
void AppendNumber(std::string* out, float value);
std::string NumberText(double value);

/// "<path>: line <n>: <what>".
std::string LineError(const std::string& path, std::size_t line_number, const std::string& what);
/// "expected <expected> values, found <found>".
std::string WrongValueCount(std::size_t expected, std::size_t found);
/// "value <index + 1> '<token>' is not a number".
std::string NotANumber(std::size_t index, std::string_view token);

/// fwrite with an error naming `path`.
Status WriteBytes(std::FILE* f, const std::string& path, const void* data, std::size_t size);
/// Creates or overwrites `path` with `text`.
Status WriteTextFile(const std::string& path, const std::string& text);

}  // namespace commerge::platform::io_detail
