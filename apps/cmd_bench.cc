// svms bench: the benchmark commands, each writing CSV/JSON, plots and DIR/report.md.
#include "commands.h"

namespace svms::cli {

void AddBenchCommands(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks: tables, plots and a report section");
  bench->require_subcommand(1);
  AddBenchCompare(*bench, exit_code);
}

}  // namespace svms::cli
