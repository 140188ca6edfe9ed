// svms: the command-line front end of the Space Vision Marker System.
#include <cstring>

#include "commands.h"
#include "run_command_line.h"

#ifndef SVMS_VERSION
#define SVMS_VERSION "unknown"
#endif

int main(int argc, char** argv) {
  // `svms bench ...` is the svms-bench program beside this one (cmd_bench.cc): the benchmarks
  // and the peers they compare with are not linked into svms.
  if (argc >= 2 && std::strcmp(argv[1], "bench") == 0)
    return svms::cli::RunBenchProgram(argc - 2, argv + 2);
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
  svms::cli::AddCameraCommands(app, &exit_code);
  svms::cli::AddBenchCommands(app, &exit_code);
  return svms::cli::RunCommandLine(app, argc, argv, &exit_code);
}
