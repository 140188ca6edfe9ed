// What every `svms` command shares for its output: JSON that cannot fail on the bytes of a
// path, writes to standard output that are checked, and outputs that may not replace inputs.
// docs/reliability.md describes the rules; docs/conventions.md the path fields.
#pragma once

#include <cstdio>
#include <exception>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "svms/base/status.h"

namespace svms::cli {

// JSON text of `j` (indent < 0: one line). Strings that are not valid UTF-8 (only paths can
// be: Linux paths are bytes) have each invalid byte replaced by U+FFFD instead of making
// nlohmann throw; SetPath keeps the exact bytes beside them.
std::string DumpJson(const nlohmann::json& j, int indent = -1);

// Sets j[key] to `path`. A path that is not valid UTF-8 is written with U+FFFD for its invalid
// bytes, and j[key + "_hex"] carries its exact bytes as lowercase hex, so that a reader
// recovers the file name (Python: bytes.fromhex(line["image_hex"]) if "image_hex" in line
// else os.fsencode(line["image"])).
void SetPath(nlohmann::json& j, const std::string& key, const std::string& path);

// Writes `text` to standard output. False (and *error set, once) when the write fails: a full
// disk, a closed pipe, /dev/full. Commands report it by name and exit 1 at the end.
bool WriteStdout(const std::string& text, bool flush, std::string* error);

// Checks that the output file `out` is none of `inputs` (same device and inode, so links and
// other spellings count): "FLAG OUT: is the input INPUT; expected a new file name". Ok when it
// does not exist yet.
Status CheckNotAnInput(const std::string& flag, const std::string& out,
                       const std::vector<std::string>& inputs);

// Creates the directory `dir` for an option `flag` (with its parents) and checks that files can
// be written in it: "FLAG DIR: is a file; expected a directory", "...: cannot create the
// directory: Permission denied", "...: cannot write in it: Read-only file system".
Status PrepareOutputDirectory(const std::string& flag, const std::string& dir);

// One line for an exception that ended the work on one item of a batch (`item`: the file):
// out of memory (std::bad_alloc, or OpenCV's StsNoMem), another OpenCV error, or an internal
// error. Called from `catch (...)` with std::current_exception(), so that nothing escapes a
// worker thread (which would abort the process).
std::string ItemFailure(const std::string& item, std::exception_ptr failure);

// The longest line `svms pose --stdin` reads (a path and a time stamp); longer lines are
// reported and skipped, so that an endless line cannot exhaust memory.
constexpr size_t kMaxStdinLineBytes = 65536;

// Reads one line (without its newline) of at most `max_bytes` from `in`. Returns false at the
// end of input. A longer line is consumed to its end and *too_long set (the line's start is in
// *line).
bool ReadBoundedLine(std::FILE* in, size_t max_bytes, std::string* line, bool* too_long);

}  // namespace svms::cli

namespace svms::cli {

// A report file of the benchmarks, written like every other output (file_io.h): the text is
// gathered in memory and written atomically when the object is destroyed, so a failed write
// leaves an earlier report as it was. A failure is remembered (not thrown from a destructor):
// TakeOutputFailures() returns and clears them, and each benchmark reports them and exits 1.
// Destroyed while an exception unwinds the stack, it writes nothing: a half-built table must
// not replace a good one.
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
std::vector<std::string> TakeOutputFailures();
// Records a failure of another kind of output (an image, a model) for TakeOutputFailures.
void NoteOutputFailure(const std::string& message);
// Prints the failures TakeOutputFailures() returns ("PROGRAM: ..."), and returns exit code 1
// when there were any, else `rc`.
int FinishOutputs(const std::string& program, int rc);

}  // namespace svms::cli
