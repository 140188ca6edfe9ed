// svms render: images of a scene with exact ground truth.
#include <iostream>
#include <memory>
#include <thread>

#include "commands.h"
#include "svms/pipelines/render_scene.h"
#include "svms/sim/scene.h"

namespace svms::cli {
namespace {

struct RenderOptions {
  std::string scene, out;
  std::string profile;  // a sensor profile (scene.h) replacing the scene's camera pipeline
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  bool radiance = false;
  bool quiet = false;
};

int RunRender(const RenderOptions& o) {
  Sensor probe;
  if (Status s = o.profile.empty() ? Status::Ok() : ApplySensorProfile(o.profile, &probe); !s) {
    std::cerr << "svms render: --profile: " << s.message() << "\n";
    return kExitBadInput;
  }
  Scene scene;
  if (Status s = ReadSceneFile(o.scene, &scene); !s) {
    std::cerr << "svms render: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (!o.profile.empty()) ApplySensorProfile(o.profile, &scene.sensor);
  return RenderScene(scene, o.scene, o.out, o.threads, o.radiance, o.quiet);
}

}  // namespace

void AddRenderCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* render = app.add_subcommand("render", "Render a scene's views with exact ground truth");
  render->add_option("SCENE", o->scene, "Scene JSON (svms.scene, docs/simulator.md)")->required();
  render
      ->add_option("--out", o->out,
                   "Output directory: VIEW.png (VIEW.jpg for a JPEG sensor) per view and "
                   "truth.json")
      ->required();
  std::string profiles;
  for (const std::string& p : SensorProfileNames()) profiles += (profiles.empty() ? "" : ", ") + p;
  render->add_option("--profile", o->profile,
                     "Sensor profile replacing the scene's camera pipeline (response, bits, black "
                     "level, Bayer mosaic, file format; docs/simulator.md): " +
                         profiles);
  render->add_option("--threads", o->threads, "Views rendered in parallel")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  render->add_flag("--radiance", o->radiance, "Also write the noise-free radiance as VIEW.exr");
  render->add_flag("--quiet", o->quiet, "No progress on stderr");
  render->footer(
      "Examples:\n"
      "  svms dataset range --out out/range && svms render out/range/scene.json --out out/range\n"
      "  svms render out/range/scene.json --out out/range_radiance --radiance\n"
      "  svms render out/range/scene.json --out out/range_jpeg --profile jpeg_srgb");
  render->callback([o, exit_code] { *exit_code = RunRender(*o); });
}

}  // namespace svms::cli
