// svms dataset: the standard simulated datasets, written as scenes and rendered.
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include "cli_io.h"
#include "commands.h"
#include "svms/datasets/datasets.h"
#include "svms/marker/model_io.h"

namespace svms::cli {

int RunDataset(const DatasetCliOptions& o) {
  if (o.list || o.name.empty()) {
    for (const std::string& n : DatasetNames())
      std::cout << n << "\t" << DatasetDescription(n) << "\n";
    return o.list ? kExitOk : kExitBadInput;
  }
  if (o.out.empty()) {
    std::cerr << "svms dataset: --out DIR is required\n";
    return kExitBadInput;
  }
  Sensor probe;
  if (Status s = o.profile.empty() ? Status::Ok() : ApplySensorProfile(o.profile, &probe); !s) {
    std::cerr << "svms dataset: --profile: " << s.message() << "\n";
    return kExitBadInput;
  }
  Dataset d;
  DatasetOptions opts;
  opts.seed = o.seed;
  opts.quick = o.quick;
  if (Status s = MakeDataset(o.name, opts, &d); !s) {
    std::cerr << "svms dataset: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (!o.profile.empty()) ApplySensorProfile(o.profile, &d);  // checked above
  namespace fs = std::filesystem;
  if (Status s = PrepareOutputDirectory("--out", o.out); !s) {
    std::cerr << "svms dataset: " << s.message() << "\n";
    return kExitBadInput;
  }
  // Every file of the dataset is written as one group, committed when all are complete: a
  // failure leaves an earlier dataset in the directory as it was.
  AtomicFileSet files;
  std::vector<std::string> wrote;
  auto add = [&](const std::string& path, const std::string& text) {
    if (Status s = files.Add(path, text); !s) {
      std::cerr << "svms dataset: " << s.message() << "\n";
      return false;
    }
    wrote.push_back(path);
    return true;
  };
  for (const auto& [rel, text] : d.files) {
    const std::string path = (fs::path(o.out) / rel).string();
    std::string bytes = text;
    if (rel.size() > 12 && rel.substr(rel.size() - 12) == ".cameramodel") {
      if (Status s = d.scenes.front().second.camera.ToText(path, &bytes); !s) {
        std::cerr << "svms dataset: " << s.message() << "\n";
        return kExitFailed;
      }
    }
    if (!add(path, bytes)) return kExitFailed;
  }
  int rc = kExitOk;
  for (const auto& [sub, scene] : d.scenes) {
    const fs::path dir = sub.empty() ? fs::path(o.out) : fs::path(o.out) / sub;
    if (Status s = PrepareOutputDirectory("--out", dir.string()); !s) {
      std::cerr << "svms dataset: " << s.message() << "\n";
      return kExitFailed;
    }
    const std::string scene_file = (dir / "scene.json").string();
    if (!add(scene_file, SceneToJson(scene))) return kExitFailed;
    if (!o.no_render)
      rc = std::max(
          rc, RenderScene(scene, scene_file, dir.string(), o.threads, false, o.quiet, &files));
    if (rc != kExitOk) return rc;
  }
  if (Status s = files.Commit(); !s) {
    std::cerr << "svms dataset: " << s.message() << "; nothing written\n";
    return kExitFailed;
  }
  for (const std::string& w : wrote) std::cout << "wrote " << w << "\n";
  return rc;
}

void AddDatasetCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<DatasetCliOptions>();
  CLI::App* ds = app.add_subcommand("dataset", "Write and render a standard simulated dataset");
  ds->add_option("NAME", o->name,
                 "range, angle, sun, occlusion, mockup, approach, calibration, clutter or gallery");
  ds->add_option("--out", o->out, "Output directory");
  ds->add_option("--seed", o->seed, "Seed (everything is deterministic from it)")
      ->capture_default_str();
  ds->add_flag("--quick", o->quick, "A small subset of the views (smoke tests)");
  std::string profiles;
  for (const std::string& p : SensorProfileNames()) profiles += (profiles.empty() ? "" : ", ") + p;
  ds->add_option("--profile", o->profile,
                 "Sensor profile for every scene: the camera pipeline (response, bits, black "
                 "level, Bayer mosaic, file format; docs/simulator.md): " +
                     profiles);
  ds->add_flag("--no-render", o->no_render, "Only write the scene JSON and companion files");
  ds->add_flag("--list", o->list, "List the datasets");
  ds->add_flag("--quiet", o->quiet, "No progress on stderr");
  ds->add_option("--threads", o->threads, "Views rendered in parallel")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  ds->footer(
      "Examples:\n  svms dataset --list\n  svms dataset range --out out/range\n"
      "  svms dataset mockup --out out/mockup --seed 2\n  svms dataset calibration --quick --out "
      "out/calib\n  svms dataset range --quick --profile raw12_bayer --out out/range_raw");
  ds->callback([o, exit_code] { *exit_code = RunDataset(*o); });
}

}  // namespace svms::cli
