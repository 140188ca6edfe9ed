// svms render: images of a scene with exact ground truth.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <thread>

#include "cli_io.h"
#include "commands.h"
#include "progress.h"
#include "svms/base/memory_limit.h"
#include "svms/imageio/image_io.h"
#include "svms/marker/model_io.h"
#include "svms/sim/render.h"
#include "svms/sim/scene.h"
#include "svms/sim/truth.h"

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

int RenderScene(const Scene& scene, const std::string& source, const std::string& out_dir,
                int threads, bool radiance, bool quiet, AtomicFileSet* into) {
  RenderOptions o;
  o.scene = source;
  o.out = out_dir;
  o.threads = threads;
  o.radiance = radiance;
  o.quiet = quiet;
  if (Status s = PrepareOutputDirectory("--out", o.out); !s) {
    std::cerr << "svms render: " << s.message() << "\n";
    return kExitBadInput;
  }
  const int n = static_cast<int>(scene.views.size());
  const int workers = std::max(1, std::min(o.threads, n));
  if (Status s = CheckMemory("rendering " + std::to_string(scene.camera.width()) + "x" +
                                 std::to_string(scene.camera.height()) + " pixels on " +
                                 std::to_string(workers) + " thread(s)",
                             RenderMemoryBytes(scene, workers));
      !s) {
    std::cerr << "svms render: " << o.scene << ": " << s.message()
              << " (fewer --threads, or a smaller camera)\n";
    return kExitBadInput;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<Renderer> renderer;
  if (Status s = Renderer::Create(scene, &renderer); !s) {
    std::cerr << "svms render: " << o.scene << ": " << s.message() << "\n";
    return kExitBadInput;
  }
  std::vector<ViewTruth> truth(n);
  std::atomic<int> next{0};
  int done = 0;  // under io
  std::mutex io;
  Progress progress("svms render:", n, " views of " + o.scene, !o.quiet);
  std::vector<std::string> failures;
  AtomicFileSet own;
  AtomicFileSet& files = into ? *into : own;
  auto worker = [&] {
    for (int v; (v = next++) < n;) {
      const std::string file =
          (std::filesystem::path(o.out) / (scene.views[v].name + ViewFileExtension(scene.sensor)))
              .string();
      Status written;
      try {
        const cv::Mat radiance = renderer->RenderRadiance(v);
        const cv::Mat image = renderer->Expose(radiance, v);
        truth[v] = ComputeTruth(*renderer, v);
        written = AddImage(file, image, &files, ViewImageEncoding(scene.sensor));
        if (written && o.radiance) {
          written =
              AddImage((std::filesystem::path(o.out) / (scene.views[v].name + ".exr")).string(),
                       radiance, &files);
        }
      } catch (...) {
        written = Status::Error(ItemFailure(file, std::current_exception()));
      }
      std::lock_guard<std::mutex> lock(io);
      if (!written) failures.push_back(written.message());
      progress.Update(++done);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < workers; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  progress.Finish();
  // The images and truth.json are replaced as one group: truth.json describes the images
  // beside it, and a failed write leaves an earlier render as it was.
  const std::string truth_file = (std::filesystem::path(o.out) / "truth.json").string();
  if (failures.empty()) {
    if (Status s = files.Add(truth_file, TruthToJson(scene, truth)); !s)
      failures.push_back(s.message());
    else if (Status c = into ? Status::Ok() : files.Commit(); !c)
      failures.push_back(c.message());
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const std::string& f : failures) std::cerr << "svms render: " << f << "\n";
  if (!failures.empty()) {
    std::cerr << "svms render: nothing written; the files that were there before are as they "
                 "were\n";
    return kExitFailed;
  }
  std::cout << "rendered " << n << " views of " << scene.camera.width() << "x"
            << scene.camera.height() << " at " << scene.sensor.rays_per_pixel << " rays/pixel ("
            << (scene.sensor.edge_rays_per_pixel > scene.sensor.rays_per_pixel
                    ? std::to_string(scene.sensor.edge_rays_per_pixel) + " on edges"
                    : std::string("none more on edges"))
            << ") in " << secs << " s to " << o.out << " (truth: " << truth_file << ")\n";
  return kExitOk;
}

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
