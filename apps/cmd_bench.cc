// svms bench: the benchmark commands that measure the toolkit's targets on the simulator's
// datasets. Each `svms bench NAME --out DIR` writes CSV/JSON, plots and DIR/report.md;
// scripts/update_benchmarks assembles docs/benchmarks.md from the reports.
#include "commands.h"

namespace svms::cli {

void AddBenchCommands(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand(
      "bench", "Measure detection, accuracy and speed on simulated datasets against truth");
  bench->require_subcommand(1);
  AddBenchDetect(*bench, exit_code);
  AddBenchCalibrate(*bench, exit_code);
  AddBenchCompare(*bench, exit_code);
  AddBenchSurvey(*bench, exit_code);
  AddBenchPose(*bench, exit_code);
  AddBenchProfiles(*bench, exit_code);
}

}  // namespace svms::cli
