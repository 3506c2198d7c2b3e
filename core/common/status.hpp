// SPDX-License-Identifier: BSD-3-Clause
// commerge: error values. Core code never throws, prints or aborts on data-dependent failures;
// it returns a Status (or a Result<T>) that says what went wrong in words a field engineer can act on.
#pragma once

#include <string>
#include <utility>

namespace commerge {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,    ///< a parameter or input value is outside its documented range
  kNotFound,           ///< a file, key or keyframe does not exist
  kDataLoss,           ///< truncated or corrupt data
  kResourceExhausted,  ///< a pool, arena or budget is full
  kIoError,            ///< the operating system refused a read or write
  kUnimplemented,      ///< a format variant this build does not support
  kInternal,           ///< a broken invariant (a bug)
};

/// Name of a status code, for messages ("invalid argument", ...).
const char* StatusCodeName(StatusCode code) noexcept;

class Status {
 public:
  Status() = default;  // OK
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return Status(); }
  bool ok() const noexcept { return code_ == StatusCode::kOk; }
  StatusCode code() const noexcept { return code_; }
  const std::string& message() const noexcept { return message_; }
  /// "<code name>: <message>", or "ok".
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidArgument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status NotFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status DataLoss(std::string m) { return {StatusCode::kDataLoss, std::move(m)}; }
inline Status ResourceExhausted(std::string m) { return {StatusCode::kResourceExhausted, std::move(m)}; }
inline Status IoError(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
inline Status Unimplemented(std::string m) { return {StatusCode::kUnimplemented, std::move(m)}; }

/// A value or the Status that explains why there is none.
template <class T>
class Result {
 public:
  Result(T value) : value_(std::move(value)), has_value_(true) {}  // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {               // NOLINT: implicit by design
    if (status_.ok()) status_ = Status(StatusCode::kInternal, "Result built from an OK status without a value");
  }

  bool ok() const noexcept { return has_value_; }
  const Status& status() const noexcept { return status_; }
  /// Precondition: ok().
  T& value() & noexcept { return value_; }
  const T& value() const& noexcept { return value_; }
  T&& value() && noexcept { return std::move(value_); }
  T* operator->() noexcept { return &value_; }
  const T* operator->() const noexcept { return &value_; }
  T& operator*() & noexcept { return value_; }
  const T& operator*() const& noexcept { return value_; }

 private:
  T value_{};
  Status status_;
  bool has_value_ = false;
};

}  // namespace commerge
