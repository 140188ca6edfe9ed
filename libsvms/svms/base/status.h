// Status: success, or a one-line message for a user-input or numerical failure.
// (Programmer errors use assertions; see docs/conventions.md.)
#pragma once

#include <string>
#include <utility>

namespace svms {

class Status {
 public:
  Status() = default;  // OK
  static Status Ok() { return Status(); }
  static Status Error(std::string message) { return Status(std::move(message)); }
  bool ok() const { return !failed_; }
  explicit operator bool() const { return ok(); }
  const std::string& message() const { return message_; }

 private:
  explicit Status(std::string m) : failed_(true), message_(std::move(m)) {}
  bool failed_ = false;
  std::string message_;
};

}  // namespace svms
