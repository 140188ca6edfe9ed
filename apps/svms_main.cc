// svms: the command-line front end of the Space Vision Marker System.
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <new>

#include "commands.h"

#ifndef SVMS_VERSION
#define SVMS_VERSION "unknown"
#endif

int main(int argc, char** argv) {
  CLI::App app{"svms: Space Vision Marker System -- markers, detection, calibration, survey, pose"};
  app.set_version_flag("--version", std::string("svms ") + SVMS_VERSION);
  app.require_subcommand(1);
  app.footer(
      "Examples:\n"
      "  svms generate marker --id 17 --size 0.2 --out m17\n"
      "  svms model check m17.json\n"
      "  svms codec stats --json\n"
      "Run 'svms COMMAND --help' for each command's options and examples.");
  int exit_code = svms::kExitOk;
  svms::cli::AddCodecCommands(app, &exit_code);
  svms::cli::AddModelCommands(app, &exit_code);
  svms::cli::AddGenerateCommands(app, &exit_code);
  svms::cli::AddRenderCommands(app, &exit_code);
  svms::cli::AddDatasetCommands(app, &exit_code);
  svms::cli::AddDetectCommands(app, &exit_code);
  svms::cli::AddCalibrateCommands(app, &exit_code);
  svms::cli::AddSurveyCommands(app, &exit_code);
  svms::cli::AddPoseCommands(app, &exit_code);
  svms::cli::AddBenchCommands(app, &exit_code);
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
    return rc == 0 ? 0 : svms::kExitBadInput;
  } catch (const std::bad_alloc&) {
    std::cerr << "svms: out of memory; expected a smaller request (see the limits in "
                 "docs/reliability.md)\n";
    return svms::kExitFailed;
  } catch (const std::exception& e) {
    std::cerr << "svms: internal error: " << e.what() << "\n";
    return svms::kExitFailed;
  }
  // Whatever a command printed must have reached its reader.
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::cerr << "svms: standard output: cannot write: " << std::strerror(errno)
              << "; the output is incomplete\n";
    return svms::kExitFailed;
  }
  return exit_code;
}
