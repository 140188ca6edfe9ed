#include "cli_io.h"

#include <cerrno>
#include <cstring>

namespace svms::cli {

bool WriteStdout(const std::string& text, bool flush, std::string* error) {
  if (!error->empty()) return false;  // reported once; later lines are not tried
  const bool ok = std::fwrite(text.data(), 1, text.size(), stdout) == text.size() &&
                  (!flush || std::fflush(stdout) == 0);
  if (!ok) *error = std::string("standard output: cannot write: ") + std::strerror(errno);
  return ok;
}

bool ReadBoundedLine(std::FILE* in, size_t max_bytes, std::string* line, bool* too_long) {
  line->clear();
  *too_long = false;
  int c;
  bool any = false;
  while ((c = std::getc(in)) != EOF) {
    any = true;
    if (c == '\n') return true;
    if (line->size() < max_bytes)
      line->push_back(static_cast<char>(c));
    else
      *too_long = true;
  }
  return any;
}

}  // namespace svms::cli
