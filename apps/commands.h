// The `svms` command table: each group of subcommands registers itself on the app and sets
// *exit_code when it runs (exit codes: svms/pipelines/exit_codes.h).
#pragma once

#include <CLI/CLI.hpp>

#include "svms/pipelines/exit_codes.h"

namespace svms::cli {

void AddCodecCommands(CLI::App& app, int* exit_code);
void AddModelCommands(CLI::App& app, int* exit_code);
void AddGenerateCommands(CLI::App& app, int* exit_code);
void AddRenderCommands(CLI::App& app, int* exit_code);
void AddDatasetCommands(CLI::App& app, int* exit_code);
void AddDetectCommands(CLI::App& app, int* exit_code);
void AddCalibrateCommands(CLI::App& app, int* exit_code);
void AddSurveyCommands(CLI::App& app, int* exit_code);
void AddPoseCommands(CLI::App& app, int* exit_code);
void AddCameraCommands(CLI::App& app, int* exit_code);
void AddBenchCommands(CLI::App& app, int* exit_code);

// `svms bench ARGS...`: runs the svms-bench program beside this one (/proc/self/exe's
// directory) with ARGS, replacing this process. Returns only when it cannot: 2 when svms-bench
// is not there (an installation without the benchmarks), 1 when it cannot be started; one line
// on stderr says which.
int RunBenchProgram(int argc, char** argv);

}  // namespace svms::cli
