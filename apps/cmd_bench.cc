// svms bench: the benchmark group. Each benchmark registers itself with AddBenchNAME
// (commands.h) and writes CSV/JSON, plots and DIR/report.md.
#include "commands.h"

namespace svms::cli {

void AddBenchCommands(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks: tables, plots and a report.md");
  bench->require_subcommand(1);
  AddBenchSurvey(*bench, exit_code);
}

}  // namespace svms::cli
