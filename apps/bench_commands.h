// The subcommands of svms-bench, the program behind `svms bench` (bench_commands.cc): each
// registers itself on the app and sets *exit_code when it runs.
#pragma once

#include <CLI/CLI.hpp>

namespace svms::cli {

void AddBenchDetect(CLI::App& bench, int* exit_code);
void AddBenchCalibrate(CLI::App& bench, int* exit_code);
void AddBenchCompare(CLI::App& bench, int* exit_code);
void AddBenchSurvey(CLI::App& bench, int* exit_code);
void AddBenchPose(CLI::App& bench, int* exit_code);
void AddBenchProfiles(CLI::App& bench, int* exit_code);
void AddBenchSpeed(CLI::App& bench, int* exit_code);

}  // namespace svms::cli
