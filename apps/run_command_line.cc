#include "run_command_line.h"

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <new>

#include "svms/pipelines/exit_codes.h"

namespace svms::cli {

int RunCommandLine(CLI::App& app, int argc, char** argv, const int* exit_code) {
  // A file-size limit (ulimit -f) would kill us with SIGXFSZ before write(2) could say EFBIG;
  // ignored, the limit is a write error like a full disk: reported, and the earlier file kept
  // (file_io.h).
  std::signal(SIGXFSZ, SIG_IGN);
  // A closed pipe is a write error too (EPIPE), reported once, exit 1: not a silent death.
  std::signal(SIGPIPE, SIG_IGN);
  // The commands run inside parse(). What they do not catch themselves ends here as one line
  // and exit code 1, never as an abort: running out of memory (each command estimates what a
  // request needs and refuses what is beyond its documented limits first, docs/reliability.md)
  // or an internal error.
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);  // prints help, version or the usage error
    return rc == 0 ? 0 : kExitBadInput;
  } catch (const std::bad_alloc&) {
    std::cerr << "svms: out of memory; expected a smaller request (see the limits in "
                 "docs/reliability.md)\n";
    return kExitFailed;
  } catch (const std::exception& e) {
    std::cerr << "svms: internal error: " << e.what() << "\n";
    return kExitFailed;
  }
  // Whatever a command printed must have reached its reader.
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::cerr << "svms: standard output: cannot write: " << std::strerror(errno)
              << "; the output is incomplete\n";
    return kExitFailed;
  }
  return *exit_code;
}

}  // namespace svms::cli
