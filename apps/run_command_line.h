// What `svms` and `svms-bench` do around their commands: signals that would kill a write,
// the parse (the commands run inside it), one line for what escapes a command, and a check
// that standard output reached its reader.
#pragma once

#include <CLI/CLI.hpp>

namespace svms::cli {

// Parses `argc`/`argv` with `app`, whose commands set *exit_code as they run, and returns the
// process's exit code: the command's, 2 for a usage error (0 for --help and --version), 1 for
// running out of memory, an internal error or standard output that could not be written.
// Messages on stderr start with "svms: ".
int RunCommandLine(CLI::App& app, int argc, char** argv, const int* exit_code);

}  // namespace svms::cli
