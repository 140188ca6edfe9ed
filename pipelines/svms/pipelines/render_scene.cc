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

namespace {

// RenderScene and RenderSceneThrough: the views of `scene` exposed through each of `outputs`
// (one radiance per view), VIEW.exr beside the first output's images with `write_radiance`.
int RenderOutputs(const Scene& scene, const std::vector<SensorOutput>& outputs,
                  const std::string& source, int threads, bool write_radiance, bool quiet,
                  AtomicFileSet* into) {
  if (outputs.empty()) {
    std::cerr << "svms render: " << source << ": no output to render to\n";
    return kExitBadInput;
  }
  // Every output is checked before any directory is made. A directory's name without "." or
  // ".." steps and without a trailing separator: "d", "d/" and "d/." name one directory.
  auto dir_name = [](const std::string& dir) {
    std::filesystem::path p = std::filesystem::path(dir).lexically_normal();
    return p.has_filename() ? p : p.parent_path();
  };
  for (size_t k = 0; k < outputs.size(); ++k) {
    const SensorOutput& o = outputs[k];
    if (!SharesRadiance(scene.sensor, o.sensor)) {
      std::cerr << "svms render: " << source << ": the sensor of " << o.out_dir
                << " casts other rays than the scene's (rays per pixel, on edges too, motion "
                   "blur or defocus): render it on its own\n";
      return kExitBadInput;
    }
    for (size_t j = 0; j < k; ++j) {
      if (dir_name(o.out_dir) == dir_name(outputs[j].out_dir)) {
        std::cerr << "svms render: " << source << ": " << o.out_dir
                  << ": named twice; expected one directory per sensor\n";
        return kExitBadInput;
      }
    }
  }
  for (const SensorOutput& o : outputs) {
    if (Status s = PrepareOutputDirectory("--out", o.out_dir); !s) {
      std::cerr << "svms render: " << s.message() << "\n";
      return kExitBadInput;
    }
  }
  const int n = static_cast<int>(scene.views.size());
  const int workers = std::max(1, std::min(threads, n));
  // Each further output adds, per view in flight, its exposure and its encoding: at most 4
  // bytes per pixel (16-bit), beside RenderMemoryBytes's 16 for the first.
  const double pixels = static_cast<double>(scene.camera.width()) * scene.camera.height();
  const double twins = 4 * pixels * workers * static_cast<double>(outputs.size() - 1);
  if (Status s = CheckMemory("rendering " + std::to_string(scene.camera.width()) + "x" +
                                 std::to_string(scene.camera.height()) + " pixels on " +
                                 std::to_string(workers) + " thread(s)",
                             RenderMemoryBytes(scene, workers) + twins);
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
      const std::string name = scene.views[v].name;
      // The file a failure is reported against: the first output's image until another's.
      std::string file = (std::filesystem::path(outputs[0].out_dir) /
                          (name + ViewFileExtension(outputs[0].sensor)))
                             .string();
      Status written;
      try {
        // Behind a defocus, the light on the finer grid the lens blurs (render.h).
        const cv::Mat radiance = renderer->RenderRadianceFor(v, scene.sensor);
        truth[v] = ComputeTruth(*renderer, v);
        for (size_t k = 0; k < outputs.size() && written; ++k) {
          const SensorOutput& o = outputs[k];
          file = (std::filesystem::path(o.out_dir) / (name + ViewFileExtension(o.sensor))).string();
          const cv::Mat image = renderer->Expose(radiance, v, o.sensor);
          written = AddImage(file, image, &files, ViewImageEncoding(o.sensor));
          if (written && write_radiance && k == 0) {
            // At the camera's size: each pixel the mean of its fine pixels.
            cv::Mat pixels = radiance;
            if (radiance.cols != image.cols)
              cv::resize(radiance, pixels, image.size(), 0, 0, cv::INTER_AREA);
            file = (std::filesystem::path(o.out_dir) / (name + ".exr")).string();
            written = AddImage(file, pixels, &files);
          }
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
  std::vector<std::string> truth_files;
  for (const SensorOutput& o : outputs) {
    if (!failures.empty()) break;
    truth_files.push_back((std::filesystem::path(o.out_dir) / "truth.json").string());
    Scene seen = scene;
    seen.sensor = o.sensor;
    if (Status s = files.Add(truth_files.back(), TruthToJson(seen, truth)); !s)
      failures.push_back(s.message());
  }
  if (failures.empty())
    if (Status c = into ? Status::Ok() : files.Commit(); !c) failures.push_back(c.message());
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const std::string& f : failures) std::cerr << "svms render: " << f << "\n";
  if (!failures.empty()) {
    std::cerr << "svms render: nothing written; the files that were there before are as they "
                 "were\n";
    return kExitFailed;
  }
  for (size_t k = 0; k < outputs.size(); ++k) {
    const Sensor& se = outputs[k].sensor;
    std::cout << "rendered " << n << " views of " << scene.camera.width() << "x"
              << scene.camera.height() << " at " << se.rays_per_pixel << " rays/pixel ("
              << (se.edge_rays_per_pixel > se.rays_per_pixel
                      ? std::to_string(se.edge_rays_per_pixel) + " on edges"
                      : std::string("none more on edges"))
              << ") in " << secs << " s to " << outputs[k].out_dir << " (truth: " << truth_files[k]
              << (k > 0 ? "; the same light as " + outputs[0].out_dir : std::string()) << ")\n";
  }
  return kExitOk;
}

}  // namespace

int RenderScene(const Scene& scene, const std::string& source, const std::string& out_dir,
                int threads, bool write_radiance, bool quiet, AtomicFileSet* into) {
  return RenderOutputs(scene, {{scene.sensor, out_dir}}, source, threads, write_radiance, quiet,
                       into);
}

int RenderSceneThrough(const Scene& scene, const std::vector<SensorOutput>& outputs,
                       const std::string& source, int threads, bool quiet) {
  for (const SensorOutput& o : outputs) {
    if (Status s = CheckSensor(o.sensor); !s) {
      std::cerr << "svms render: " << source << ": " << o.out_dir << ": " << s.message() << "\n";
      return kExitBadInput;
    }
  }
  return RenderOutputs(scene, outputs, source, threads, false, quiet, nullptr);
}

}  // namespace svms
