// svms dataset: the standard simulated datasets, written as scenes and rendered.
#include <iostream>
#include <memory>

#include "commands.h"
#include "svms/datasets/datasets.h"
#include "svms/pipelines/dataset_run.h"

namespace svms::cli {
namespace {

// --list (or no NAME): the datasets, one per line; else the pipeline (dataset_run.h).
int RunDatasetCommand(const DatasetRunOptions& o, bool list) {
  if (list || o.name.empty()) {
    for (const std::string& n : DatasetNames())
      std::cout << n << "\t" << DatasetDescription(n) << "\n";
    return list ? kExitOk : kExitBadInput;
  }
  return RunDataset(o);
}

}  // namespace

void AddDatasetCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<DatasetRunOptions>();
  auto list = std::make_shared<bool>(false);
  CLI::App* ds = app.add_subcommand("dataset", "Write and render a standard simulated dataset");
  ds->add_option(
      "NAME", o->name,
      "range, angle, small, sun, occlusion, mockup, approach, calibration, clutter or gallery");
  ds->add_option("--out", o->out, "Output directory");
  ds->add_option("--seed", o->seed, "Seed (everything is deterministic from it)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  ds->add_flag("--quick", o->quick, "A small subset of the views (smoke tests)");
  std::string profiles;
  for (const std::string& p : SensorProfileNames()) profiles += (profiles.empty() ? "" : ", ") + p;
  ds->add_option("--profile", o->profile,
                 "Sensor profile for every scene: the camera pipeline (response, bits, black "
                 "level, Bayer mosaic, file format; docs/simulator.md): " +
                     profiles);
  ds->add_flag("--no-render", o->no_render, "Only write the scene JSON and companion files");
  ds->add_flag("--list", *list, "List the datasets");
  ds->add_flag("--quiet", o->quiet, "No progress on stderr");
  ds->add_option("--threads", o->threads, "Views rendered in parallel")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  ds->footer(
      "Examples:\n  svms dataset --list\n  svms dataset range --out out/range\n"
      "  svms dataset mockup --out out/mockup --seed 2\n  svms dataset calibration --quick --out "
      "out/calib\n  svms dataset range --quick --profile raw12_bayer --out out/range_raw");
  ds->callback([o, list, exit_code] { *exit_code = RunDatasetCommand(*o, *list); });
}

}  // namespace svms::cli
