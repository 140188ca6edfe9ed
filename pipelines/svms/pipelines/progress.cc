#include "svms/pipelines/progress.h"

#include <unistd.h>

#include <iostream>
#include <utility>

namespace svms {

Progress::Progress(std::string prefix, size_t total, std::string suffix, bool enabled)
    : prefix_(std::move(prefix)),
      suffix_(std::move(suffix)),
      total_(total),
      enabled_(enabled && total > 0),
      terminal_(isatty(STDERR_FILENO) != 0) {}

void Progress::Update(size_t done) {
  if (!enabled_) return;
  const std::string line =
      prefix_ + " " + std::to_string(done) + "/" + std::to_string(total_) + suffix_;
  if (terminal_) {
    std::cerr << "\r" << line << std::flush;
    open_line_ = true;
    return;
  }
  const size_t tenth = done * 10 / total_;
  if (tenth > last_tenth_) {
    last_tenth_ = tenth;
    std::cerr << line << "\n" << std::flush;
  }
}

void Progress::Finish() {
  if (open_line_) std::cerr << "\n" << std::flush;
  open_line_ = false;
}

}  // namespace svms
