// Report files of the benchmarks and pipelines, written like every other output (file_io.h):
// whole or not at all, with the failures gathered for one message at the end of the run.
#pragma once

#include <exception>
#include <sstream>
#include <string>
#include <vector>

namespace svms {

// A report file: the text is gathered in memory and written atomically when the object is
// destroyed, so a failed write leaves an earlier report as it was. A failure is remembered (not
// thrown from a destructor): TakeOutputFailures() returns and clears them, and each benchmark
// reports them and exits 1. Destroyed while an exception unwinds the stack, it writes nothing:
// a half-built table must not replace a good one.
class OutputFile : public std::ostringstream {
 public:
  explicit OutputFile(std::string path)
      : path_(std::move(path)), exceptions_(std::uncaught_exceptions()) {}
  ~OutputFile() override { close(); }
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  // Writes the file now (once; the destructor then does nothing), for a reader that follows.
  void close();

 private:
  std::string path_;
  bool written_ = false;
  int exceptions_;  // in flight at construction: a destructor run by a new one writes nothing
};

// The failures recorded since the last call (thread-safe), each one line naming the file.
std::vector<std::string> TakeOutputFailures();
// Records a failure of another kind of output (an image, a model) for TakeOutputFailures.
void NoteOutputFailure(const std::string& message);
// Prints the failures TakeOutputFailures() returns ("PROGRAM: ..." on stderr), and returns exit
// code 1 when there were any (unless `rc` is already a failure), else `rc`.
int FinishOutputs(const std::string& program, int rc);

}  // namespace svms
