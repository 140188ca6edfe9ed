// svms bench: benchmarks that write CSV/JSON, plots and a report.md section (docs/bench/).
#include "commands.h"

namespace svms::cli {

void AddBenchCommands(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks: tables, plots and report.md");
  bench->require_subcommand(1);
  AddBenchCalibrate(*bench, exit_code);
}

}  // namespace svms::cli
