// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/text_io.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>

#include "platform/io/file_util.hpp"

namespace commerge::platform::io_detail {

namespace {

constexpr std::size_t kMaxHeaderLineBytes = std::size_t{1} << 16;

template <class T>
bool ParseFloating(std::string_view token, T* value) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size();
}

template <class T>
void AppendFloating(std::string* out, T value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  if (ec == std::errc()) out->append(buffer, end);
}

}  // namespace

Status WriteBytes(std::FILE* f, const std::string& path, const void* data, std::size_t size) {
  if (size == 0 || std::fwrite(data, 1, size, f) == size) return Status::Ok();
  return IoError(path + ": write failed: " + std::strerror(errno));
}

Status WriteTextFile(const std::string& path, const std::string& text) {
  auto file = OpenForWrite(path);
  if (!file.ok()) return file.status();
  if (Status s = WriteBytes(file->get(), path, text.data(), text.size()); !s.ok()) return s;
  return CloseChecked(std::move(*file), path);
}

Result<std::string> HeaderLines::Next(const char* what_is_missing) {
  std::string line;
  for (;;) {
    const int c = std::getc(f_);
    if (c == EOF) {
      if (std::ferror(f_)) return IoError(path_ + ": read failed in the header: " + std::strerror(errno));
      if (line.empty()) {
        return DataLoss(path_ + ": header ends after line " + std::to_string(line_number_) + " without " +
                        what_is_missing);
      }
      break;  // the last line of the file has no line break
    }
    ++bytes_consumed_;
    if (c == '\n') break;
    if (line.size() >= kMaxHeaderLineBytes) {
      return DataLoss(path_ + ": header line " + std::to_string(line_number_ + 1) + " is longer than " +
                      std::to_string(kMaxHeaderLineBytes) + " bytes; this is not a text header");
    }
    line.push_back(static_cast<char>(c));
  }
  ++line_number_;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

bool LineCursor::Next(std::string_view* line) {
  if (pos_ >= text_.size()) return false;
  std::size_t end = text_.find('\n', pos_);
  const std::size_t next = end == std::string_view::npos ? text_.size() : end + 1;
  if (end == std::string_view::npos) end = text_.size();
  *line = text_.substr(pos_, end - pos_);
  if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
  pos_ = next;
  ++next_line_number_;
  return true;
}

void SplitTokens(std::string_view line, std::vector<std::string_view>* tokens) {
  tokens->clear();
  std::size_t pos = 0;
  while (true) {
    pos = line.find_first_not_of(" \t", pos);
    if (pos == std::string_view::npos) return;
    const std::size_t end = std::min(line.find_first_of(" \t", pos), line.size());
    tokens->push_back(line.substr(pos, end - pos));
    pos = end;
  }
}

bool IsBlank(std::string_view line) { return line.find_first_not_of(" \t") == std::string_view::npos; }

bool ParseNumber(std::string_view token, double* value) { return ParseFloating(token, value); }
bool ParseNumber(std::string_view token, float* value) { return ParseFloating(token, value); }

bool ParseCount(std::string_view token, std::uint64_t* value) {
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return !token.empty() && ec == std::errc() && end == token.data() + token.size();
}

void AppendNumber(std::string* out, double value) { AppendFloating(out, value); }
void AppendNumber(std::string* out, float value) { AppendFloating(out, value); }

std::string NumberText(double value) {
  std::string text;
  AppendNumber(&text, value);
  return text;
}

std::string LineError(const std::string& path, std::size_t line_number, const std::string& what) {
  return path + ": line " + std::to_string(line_number) + ": " + what;
}

std::string WrongValueCount(std::size_t expected, std::size_t found) {
  return "expected " + std::to_string(expected) + " values, found " + std::to_string(found);
}

std::string NotANumber(std::size_t index, std::string_view token) {
  return "value " + std::to_string(index + 1) + " '" + std::string(token) + "' is not a number";
}

}  // namespace commerge::platform::io_detail
