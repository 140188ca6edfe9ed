#include "svms/pipelines/report_file.h"

#include <iostream>
#include <mutex>

#include "svms/base/file_io.h"

namespace svms {
namespace {

std::mutex& FailuresMutex() {
  static std::mutex m;
  return m;
}

std::vector<std::string>& Failures() {
  static std::vector<std::string> f;
  return f;
}

}  // namespace

void OutputFile::close() {
  if (written_) return;
  written_ = true;
  if (std::uncaught_exceptions() > exceptions_) return;
  if (Status s = WriteFileAtomically(path_, str()); !s) NoteOutputFailure(s.message());
}

void NoteOutputFailure(const std::string& message) {
  std::lock_guard<std::mutex> lock(FailuresMutex());
  Failures().push_back(message);
}

std::vector<std::string> TakeOutputFailures() {
  std::lock_guard<std::mutex> lock(FailuresMutex());
  std::vector<std::string> out;
  out.swap(Failures());
  return out;
}

int FinishOutputs(const std::string& program, int rc) {
  const std::vector<std::string> failures = TakeOutputFailures();
  for (const std::string& f : failures) std::cerr << program << ": " << f << "\n";
  if (failures.empty()) return rc;
  std::cerr << program << ": " << failures.size()
            << " output file(s) not written; earlier files are as they were\n";
  return rc == 0 ? 1 : rc;
}

}  // namespace svms
