#include "svms/pipelines/dataset_run.h"

#include <filesystem>
#include <iostream>
#include <vector>

#include "svms/base/file_io.h"
#include "svms/datasets/datasets.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/render_scene.h"

namespace svms {

namespace fs = std::filesystem;

int RunDataset(const DatasetRunOptions& o) {
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

}  // namespace svms
