// What the `svms` commands share for their standard streams: writes to standard output that
// are checked, and bounded lines from standard input (docs/reliability.md).
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

namespace svms::cli {

// Writes `text` to standard output. False (and *error set, once) when the write fails: a full
// disk, a closed pipe, /dev/full. Commands report it by name and exit 1 at the end.
bool WriteStdout(const std::string& text, bool flush, std::string* error);

// The longest line `svms pose --stdin` reads (a path and a time stamp); longer lines are
// reported and skipped, so that an endless line cannot exhaust memory.
constexpr size_t kMaxStdinLineBytes = 65536;

// Reads one line (without its newline) of at most `max_bytes` from `in`. Returns false at the
// end of input. A longer line is consumed to its end and *too_long set (the line's start is in
// *line).
bool ReadBoundedLine(std::FILE* in, size_t max_bytes, std::string* line, bool* too_long);

}  // namespace svms::cli
