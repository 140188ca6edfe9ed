// The `svms` command table: each group of subcommands registers itself on the app and sets
// *exit_code when it runs. Exit codes: 0 success, 1 a failure of the work (e.g. a word that
// does not decode), 2 bad input (usage, unreadable or invalid files).
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "image_inputs.h"
#include "svms/base/file_io.h"
#include "svms/sim/scene.h"

namespace svms {
struct FrameResult;
}

namespace svms::cli {

// 3: a benchmark ran and wrote its report but missed one of its targets (bench_targets.h).
constexpr int kExitOk = 0, kExitFailed = 1, kExitBadInput = 2, kExitTargetMissed = 3;

void AddCodecCommands(CLI::App& app, int* exit_code);
void AddModelCommands(CLI::App& app, int* exit_code);
void AddGenerateCommands(CLI::App& app, int* exit_code);
void AddRenderCommands(CLI::App& app, int* exit_code);
void AddDatasetCommands(CLI::App& app, int* exit_code);
void AddDetectCommands(CLI::App& app, int* exit_code);
void AddCalibrateCommands(CLI::App& app, int* exit_code);
void AddSurveyCommands(CLI::App& app, int* exit_code);
void AddPoseCommands(CLI::App& app, int* exit_code);
void AddBenchCommands(CLI::App& app, int* exit_code);

// The `svms bench` subcommands, each registered on the `bench` group (cmd_bench.cc).
void AddBenchDetect(CLI::App& bench, int* exit_code);
void AddBenchCalibrate(CLI::App& bench, int* exit_code);
void AddBenchCompare(CLI::App& bench, int* exit_code);
void AddBenchSurvey(CLI::App& bench, int* exit_code);
void AddBenchPose(CLI::App& bench, int* exit_code);
void AddBenchProfiles(CLI::App& bench, int* exit_code);

// `svms dataset` and `svms survey` as functions (their options as on the command line): the
// benchmarks render their datasets and survey their mockup in-process through them. Each
// returns the command's exit code.
struct DatasetCliOptions {
  std::string name, out;
  std::string profile;  // a sensor profile (scene.h) for every scene
  uint64_t seed = 1;
  bool quick = false, no_render = false, list = false, quiet = false;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
};

int RunDataset(const DatasetCliOptions& o);
struct SurveyCliOptions {
  std::vector<std::string> inputs;
  std::string camera, markers, out, report;
  std::optional<int> reference;
  std::vector<std::string> scale_bars, control_points;
  bool refine_intrinsics = false, drop_disconnected = false, quiet = false;
  std::optional<double> corner_sigma;  // unset: each corner's own, from the side fits
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  PhotometryOptions photometry;
};

int RunSurveyCommand(const SurveyCliOptions& o);

// One frame of `svms pose` as its JSON line (cmd_pose.cc; docs/flight-interface.md).
nlohmann::json FrameJson(const FrameResult& frame);

// Renders every view of `scene` into `out_dir` (VIEW.png, truth.json) on `threads` threads,
// progress on stderr; `source` names the scene in messages. Returns an exit code. The files
// are written as one group (file_io.h); with `into` they are added to that group instead, for
// the caller to commit with its own.
int RenderScene(const Scene& scene, const std::string& source, const std::string& out_dir,
                int threads, bool radiance, bool quiet, AtomicFileSet* into = nullptr);

}  // namespace svms::cli
