#include "svms/bench/detect_benchmark.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "svms/bench/detect_report.h"
#include "svms/bench/detect_scoring.h"
#include "svms/bench/report_numbers.h"
#include "svms/datasets/datasets.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/overlay.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/render.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// One set: a dataset, possibly altered (noise off), and how the detector is set up for it.
struct SetSpec {
  std::string name;     // the set's name in the report
  std::string dataset;  // the datasets.h generator
  bool noise_free = false;
  bool with_models = true;  // false: no marker models, every ID accepted (the hardest case)
};

const std::vector<SetSpec>& AllSets() {
  static const std::vector<SetSpec> sets = {{"range", "range", false, true},
                                            {"angle", "angle", false, true},
                                            {"sun", "sun", false, true},
                                            {"occlusion", "occlusion", false, true},
                                            {"clutter", "clutter", false, false},
                                            {"noisefree", "angle", true, true},
                                            {"noisefree_range", "range", true, true}};
  return sets;
}

// Truth corners in red, detections in the Fig. 4 colours.
void WriteMissImage(const cv::Mat& image, const ViewTruth& truth,
                    const std::vector<Detection>& found, const std::string& file) {
  cv::Mat bgr;
  if (image.depth() == CV_16U)
    image.convertTo(bgr, CV_8U, 1.0 / 257);
  else
    bgr = image.clone();
  if (bgr.channels() == 1) cv::cvtColor(bgr, bgr, cv::COLOR_GRAY2BGR);
  for (const MarkerTruth& m : truth.markers) {
    std::vector<cv::Point> poly;
    for (const PointTruth& c : m.corners)
      if (c.projects) poly.emplace_back(cvRound(c.pixel.x() * 16), cvRound(c.pixel.y() * 16));
    if (poly.size() == 4) cv::polylines(bgr, poly, true, {0, 0, 255}, 1, cv::LINE_AA, 4);
  }
  DrawOverlay(bgr, found);
  if (Status w = WriteImage(file, bgr); !w) NoteOutputFailure(w.message());
}

// Renders and detects every view of one set on `threads` threads; progress on stderr.
Status RunSet(const SetSpec& spec, const DetectBenchmarkOptions& o, SetResult* result) {
  DatasetOptions dopt;
  dopt.seed = o.seed;
  dopt.quick = o.quick;
  Dataset dataset;
  if (Status s = MakeDataset(spec.dataset, dopt, &dataset); !s) return s;
  for (auto& [subdir, scene_in] : dataset.scenes) {
    Scene scene = scene_in;
    if (spec.noise_free) {
      scene.sensor.read_noise = 0;
      scene.sensor.shot_noise = false;
      scene.sensor.rays_per_pixel = 64;
    }
    std::unique_ptr<Renderer> renderer;
    if (Status s = Renderer::Create(scene, &renderer); !s)
      return Status::Error(spec.name + ": " + s.message());
    std::vector<MarkerModel> models;
    if (spec.with_models)
      for (const SceneObject& ob : scene.objects)
        for (const SceneMarker& m : ob.markers) models.push_back(m.model);
    const Detector detector(DetectorOptions{}, scene.camera, models);
    const int n = static_cast<int>(scene.views.size());
    std::vector<std::vector<MarkerRow>> rows(n);
    std::vector<ViewRow> views(n);
    std::atomic<int> next{0}, miss_images{0};
    int done = 0;  // under io
    std::mutex io;
    Progress progress("svms bench detect: " + spec.name, n);
    const fs::path miss_dir = fs::path(o.out) / "misses";
    auto worker = [&] {
      for (int v; (v = next++) < n;) {
        const cv::Mat image =
            renderer->Expose(renderer->RenderRadianceFor(v, renderer->scene().sensor), v);
        const ViewTruth truth = ComputeTruth(*renderer, v);
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<Detection> found = detector.Detect(image);
        views[v].detect_ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        views[v].set = spec.name;
        views[v].view = truth.name;
        Score(spec.name, truth, found, &rows[v], &views[v]);
        if (!views[v].problems.empty() && miss_images++ < o.max_miss_images) {
          std::error_code ec;
          fs::create_directories(miss_dir, ec);
          WriteMissImage(image, truth, found,
                         (miss_dir / (spec.name + "_" + truth.name + ".png")).string());
        }
        std::lock_guard<std::mutex> lock(io);
        progress.Update(++done);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::min(o.threads, n); ++t) pool.emplace_back(worker);
    for (auto& t : pool) t.join();
    progress.Finish();
    for (int v = 0; v < n; ++v) {
      result->markers.insert(result->markers.end(), rows[v].begin(), rows[v].end());
      result->views.push_back(views[v]);
    }
  }
  return Status::Ok();
}

int RunBenchmark(const DetectBenchmarkOptions& o) {
  std::vector<SetSpec> sets;
  for (const SetSpec& s : AllSets())
    if (o.sets.empty() || std::count(o.sets.begin(), o.sets.end(), s.name)) sets.push_back(s);
  for (const std::string& name : o.sets)
    if (std::none_of(AllSets().begin(), AllSets().end(),
                     [&](const SetSpec& s) { return s.name == name; })) {
      std::cerr << "svms bench detect: --sets: unknown set '" << name
                << "' (expected range, angle, sun, occlusion, clutter, noisefree, "
                   "noisefree_range)\n";
      return kExitBadInput;
    }
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out)) {
    std::cerr << "svms bench detect: " << o.out << ": cannot create the output directory\n";
    return kExitBadInput;
  }
  fs::remove_all(fs::path(o.out) / "misses", ec);
  const auto t0 = std::chrono::steady_clock::now();
  std::map<std::string, SetResult> results;
  for (const SetSpec& s : sets) {
    if (Status st = RunSet(s, o, &results[s.name]); !st) {
      std::cerr << "svms bench detect: " << st.message() << "\n";
      return kExitFailed;
    }
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  WriteDetectTables(o, results);
  const bool met = WriteDetectReport(o, results, secs);
  std::cout << "svms bench detect: " << (met ? "every target met" : "some targets NOT met")
            << "; report " << (fs::path(o.out) / "report.md").string() << " (" << Cell(secs, 0)
            << " s)\n";
  // A missed target: the report is complete, and the exit status says so.
  return met ? kExitOk : kExitTargetMissed;
}

}  // namespace

std::vector<std::string> DetectBenchmarkSets() {
  std::vector<std::string> names;
  for (const SetSpec& s : AllSets()) names.push_back(s.name);
  return names;
}

int RunDetectBenchmark(const DetectBenchmarkOptions& options) {
  return FinishOutputs("svms bench detect", RunBenchmark(options));
}

}  // namespace svms
