#include "svms/pipelines/render_scene.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "svms/base/memory_limit.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms {

int RenderScene(const Scene& scene, const std::string& source, const std::string& out_dir,
                int threads, bool write_radiance, bool quiet, AtomicFileSet* into) {
  if (Status s = PrepareOutputDirectory("--out", out_dir); !s) {
    std::cerr << "svms render: " << s.message() << "\n";
    return kExitBadInput;
  }
  const int n = static_cast<int>(scene.views.size());
  const int workers = std::max(1, std::min(threads, n));
  if (Status s = CheckMemory("rendering " + std::to_string(scene.camera.width()) + "x" +
                                 std::to_string(scene.camera.height()) + " pixels on " +
                                 std::to_string(workers) + " thread(s)",
                             RenderMemoryBytes(scene, workers));
      !s) {
    std::cerr << "svms render: " << source << ": " << s.message()
              << " (fewer --threads, or a smaller camera)\n";
    return kExitBadInput;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<Renderer> renderer;
  if (Status s = Renderer::Create(scene, &renderer); !s) {
    std::cerr << "svms render: " << source << ": " << s.message() << "\n";
    return kExitBadInput;
  }
  std::vector<ViewTruth> truth(n);
  std::atomic<int> next{0};
  int done = 0;  // under io
  std::mutex io;
  Progress progress("svms render:", n, " views of " + source, !quiet);
  std::vector<std::string> failures;
  AtomicFileSet own;
  AtomicFileSet& files = into ? *into : own;
  auto worker = [&] {
    for (int v; (v = next++) < n;) {
      const std::string file =
          (std::filesystem::path(out_dir) / (scene.views[v].name + ViewFileExtension(scene.sensor)))
              .string();
      Status written;
      try {
        // Behind a defocus, the light on the finer grid the lens blurs (render.h).
        const cv::Mat radiance = renderer->RenderRadianceFor(v, scene.sensor);
        const cv::Mat image = renderer->Expose(radiance, v);
        truth[v] = ComputeTruth(*renderer, v);
        written = AddImage(file, image, &files, ViewImageEncoding(scene.sensor));
        if (written && write_radiance) {
          // At the camera's size: each pixel the mean of its fine pixels.
          cv::Mat pixels = radiance;
          if (radiance.cols != image.cols)
            cv::resize(radiance, pixels, image.size(), 0, 0, cv::INTER_AREA);
          written =
              AddImage((std::filesystem::path(out_dir) / (scene.views[v].name + ".exr")).string(),
                       pixels, &files);
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
  const std::string truth_file = (std::filesystem::path(out_dir) / "truth.json").string();
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
            << ") in " << secs << " s to " << out_dir << " (truth: " << truth_file << ")\n";
  return kExitOk;
}

}  // namespace svms
