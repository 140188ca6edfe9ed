// Progress of a long loop, on stderr. On a terminal one line is rewritten in place ("\r");
// when stderr is not a terminal (a log file, CI, a pipe) a line is written at each tenth of
// the work instead, so that a log holds a few readable lines rather than one run-on line.
// Not thread-safe: workers call Update under the lock that already orders their output.
#pragma once

#include <cstddef>
#include <string>

namespace svms {

class Progress {
 public:
  // Lines read "<prefix> <done>/<total><suffix>", e.g. ("svms render:", 40, " views of range").
  // Disabled (prints nothing) when `enabled` is false or total is 0.
  Progress(std::string prefix, size_t total, std::string suffix = "", bool enabled = true);
  ~Progress() { Finish(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // `done` items of total are finished.
  void Update(size_t done);
  // Ends the in-place line on a terminal, so that the next output starts on its own line
  // (idempotent; the destructor calls it). Call it before printing anything else to stderr.
  void Finish();

 private:
  std::string prefix_, suffix_;
  size_t total_;
  bool enabled_, terminal_;
  bool open_line_ = false;  // a "\r" line is on the terminal without its newline
  size_t last_tenth_ = 0;   // in a log: the last tenth written
};

}  // namespace svms
