// svms-bench: the benchmarks of the Space Vision Marker System (`svms bench NAME`, which runs
// this program). Each measures the toolkit's targets on the simulator's datasets and writes
// CSV/JSON, plots and DIR/report.md; scripts/update_benchmarks assembles docs/benchmarks.md
// from the reports. It is the only program that links the peers (AprilTag, ArUco).
#include "bench_commands.h"
#include "run_command_line.h"
#include "svms/pipelines/exit_codes.h"

int main(int argc, char** argv) {
  CLI::App app{"Measure detection, accuracy and speed on simulated datasets against truth",
               "svms bench"};
  app.require_subcommand(1);
  app.footer("Run 'svms bench NAME --help' for each benchmark's options.");
  int exit_code = svms::kExitOk;
  svms::cli::AddBenchDetect(app, &exit_code);
  svms::cli::AddBenchCalibrate(app, &exit_code);
  svms::cli::AddBenchCompare(app, &exit_code);
  svms::cli::AddBenchSurvey(app, &exit_code);
  svms::cli::AddBenchPose(app, &exit_code);
  svms::cli::AddBenchProfiles(app, &exit_code);
  svms::cli::AddBenchSpeed(app, &exit_code);
  return svms::cli::RunCommandLine(app, argc, argv, &exit_code);
}
